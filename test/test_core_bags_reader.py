"""com_core.bags.reader: bags written from serialized messages, read back (by rosbags, or
record by record when a copy is cut short), and fed to an Exploration."""

from __future__ import annotations

import os

import numpy as np
from conftest import write_stream_bag

from com_core.bags.cdr import decode_wrenches, encode_wrench_stamped
from com_core.bags.reader import INCOMPLETE_TEXT, BagReading, read_metadata, read_raw
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import OK, POSE_TOPIC, TOPIC_TYPES, WRENCH_TOPIC
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.feed import feed_bag
from com_core.paper.synthetic import Load, exploration_stream
from com_core.planning.planner import Plan

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))


def test_bag_round_trip_and_replay_equal_the_direct_feed(tmp_path):
    stream = exploration_stream(
        Plan(dwell=0.3, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(2)
    )
    write_stream_bag(tmp_path / "run", stream)
    assert (tmp_path / "run" / "metadata.yaml").exists()
    topics = {t for t, *_ in read_raw(tmp_path / "run", (WRENCH_TOPIC, POSE_TOPIC))}
    assert topics == {WRENCH_TOPIC, POSE_TOPIC}

    direct = Exploration()
    direct.add_samples(stream.stamps, stream.wrenches, "ft_sensor")
    for stamp, label in stream.labels:
        direct.add_label(stamp, label)
    replayed = Exploration()
    assert feed_bag(tmp_path / "run", replayed) == (len(stream.stamps), len(stream.labels))
    a, b = direct.solve(), replayed.solve()
    assert a.status == b.status == OK
    assert a.as_dict() == b.as_dict()  # same numbers to the last bit


def test_a_copy_cut_short_is_read_record_by_record_up_to_the_cut(tmp_path):
    """rosbags refuses an MCAP file without its Footer; the reader falls back to the
    records before the cut, says so, and what it yields is a prefix of the full bag."""
    stream = exploration_stream(
        Plan(dwell=0.3, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(3)
    )
    bag = tmp_path / "run"
    write_stream_bag(bag, stream, chunk_size=16 * 1024)  # many chunks: a fine-grained cut
    full = list(read_raw(bag, (WRENCH_TOPIC, POSE_TOPIC)))
    assert len(full) == len(stream.stamps) + len(stream.labels)
    (mcap,) = bag.glob("*.mcap")
    os.truncate(mcap, mcap.stat().st_size // 2)

    reading = BagReading()
    cut = list(read_raw(bag, (WRENCH_TOPIC, POSE_TOPIC), reading))
    assert reading.cut_short and reading.fallback.startswith("rosbags could not open the bag")
    assert reading.stopped.startswith(mcap.name)
    assert reading.file_bytes == mcap.stat().st_size
    assert cut == full[: len(cut)]  # in order, nothing made up
    share = reading.read[WRENCH_TOPIC] / len(stream.stamps)
    assert 0.45 < share < 0.5, share  # all but the chunk the cut falls in (48.6 %)
    assert reading.listed[WRENCH_TOPIC] == len(stream.stamps)  # from metadata.yaml
    assert reading.read[WRENCH_TOPIC] + reading.read[POSE_TOPIC] == len(cut)
    assert "the bag's MCAP file is cut short" in reading.cut_text()
    assert f"{WRENCH_TOPIC}: {reading.read[WRENCH_TOPIC]} of {len(stream.stamps)}" in (
        reading.counts_text()
    )


def test_an_unclosed_recording_is_read_and_named_incomplete(tmp_path):
    """What a recorder that died leaves: flushed messages, ``complete: false``."""
    bag = tmp_path / "run"
    writer = CrashSafeBagWriter(bag)
    writer.open()
    try:
        for k in range(100):
            stamp = 1_000_000_000 + k * 1_000_000
            raw = encode_wrench_stamped(stamp, "ft_sensor", [k, 0.0, 9.8, 0.0, 0.0, 0.0])
            writer.write(WRENCH_TOPIC, TOPIC_TYPES[WRENCH_TOPIC], stamp, raw)
        writer.flush()
        _, complete, files = read_metadata(bag)
        assert complete is False and files == ["run_0.mcap"]
        reading = BagReading()
        got = list(read_raw(bag, (WRENCH_TOPIC,), reading))
        assert [log_ns for _, _, log_ns, _ in got] == [
            1_000_000_000 + k * 1_000_000 for k in range(100)
        ]
        assert reading.complete is False and INCOMPLETE_TEXT in reading.notes()
    finally:
        writer.close()
    assert read_metadata(bag)[:2] == ({WRENCH_TOPIC: 100}, True)
    assert read_metadata(tmp_path / "no_bag") == ({}, None, [])


def test_malformed_messages_in_a_bag_are_dropped_and_counted(tmp_path):
    """A corrupt wrench and a corrupt label: the rest replays, the solution says what was
    dropped (a batch is not lost for one bad message, and nothing raises)."""
    good = [encode_wrench_stamped(k, "ft_sensor", np.full(6, float(k))) for k in range(1, 4)]
    stamps, wrenches, _, bad = decode_wrenches([good[0], good[1][:20], good[2]])
    assert bad == 1 and stamps.tolist() == [1, 3] and wrenches[:, 0].tolist() == [1.0, 3.0]

    stream = exploration_stream(
        Plan(dwell=0.3, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(4)
    )
    write_stream_bag(tmp_path / "run", stream)
    copy = tmp_path / "corrupt"
    with CrashSafeBagWriter(copy) as bag:
        for n, (topic, _, stamp, raw) in enumerate(read_raw(tmp_path / "run", TOPIC_TYPES)):
            if n in (500, 501) and topic == WRENCH_TOPIC:
                raw = raw[:24]  # cut inside the frame_id
            bag.write(topic, TOPIC_TYPES[topic], stamp, raw)
        bag.write(POSE_TOPIC, TOPIC_TYPES[POSE_TOPIC], stamp + 1, b"\x00\x01\x00\x00")
    ex = Exploration()
    feed_bag(copy, ex)
    solution = ex.solve()
    assert solution.status == "WARN" and solution.estimate is not None, solution.reason
    assert "dropped 2 samples undecodable (malformed CDR)" in solution.reason
    assert "dropped 1 labels undecodable (malformed CDR)" in solution.reason
