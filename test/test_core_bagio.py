"""Bags written from serialized messages, read back by rosbags, replayed by the core."""

from __future__ import annotations

import numpy as np

from com_core.bags.cdr import encode_header, encode_wrench_stamped
from com_core.bags.reader import feed_bag, read_raw
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import POSE_TOPIC, WRENCH_TOPIC
from com_core.exploration import OK, WARN, Exploration
from com_core.planner import Plan
from com_core.static_windows import label_static_windows
from com_core.synthetic import Load, exploration_stream

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))


def write_stream(path, stream, labels=True) -> None:
    messages = [
        (
            int(s),
            WRENCH_TOPIC,
            "geometry_msgs/msg/WrenchStamped",
            encode_wrench_stamped(int(s), "ft_sensor", w),
        )
        for s, w in zip(stream.stamps, stream.wrenches, strict=True)
    ]
    if labels:
        messages += [
            (s, POSE_TOPIC, "std_msgs/msg/Header", encode_header(s, lbl))
            for s, lbl in stream.labels
        ]
    with CrashSafeBagWriter(path) as bag:
        for stamp, topic, msgtype, raw in sorted(messages, key=lambda m: m[0]):
            bag.write(topic, msgtype, stamp, raw)


def test_bag_round_trip_and_replay_equal_the_direct_feed(tmp_path):
    stream = exploration_stream(
        Plan(dwell=0.3, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(2)
    )
    write_stream(tmp_path / "run", stream)
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


def test_unlabelled_stream_is_cut_into_its_static_windows(tmp_path):
    stream = exploration_stream(
        Plan(dwell=0.5, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(3)
    )
    found = label_static_windows(stream.stamps, stream.wrenches)
    starts = [s for s, lbl in found if lbl != "moving"]
    truth = [s for s, lbl in stream.labels if "/" in lbl]
    assert len(starts) == len(truth) == 10
    # each found window starts within 0.1 s after a true window start (the stream begins
    # at rest, so the first one starts earlier)
    assert starts[0] < truth[0]
    assert all(0 <= s - t <= 100_000_000 for s, t in zip(starts[1:], truth[1:], strict=True))

    write_stream(tmp_path / "unlabelled", stream, labels=False)
    ex = Exploration(untared=True)
    assert feed_bag(tmp_path / "unlabelled", ex)[1] == 0
    for stamp, label in label_static_windows(*ex.samples()):
        ex.add_label(stamp, label)
    solution = ex.solve()
    # tare and object windows together are not one rigid load: flagged, not silent
    assert solution.status == WARN and "no tare" in " ".join(solution.notes)


def test_late_samples_are_dropped_but_a_restarted_clock_is_not():
    ex = Exploration()
    ex.add_samples([1, 2, 3, 8_000_000_000, 8_000_000_001], np.zeros((5, 6)), "ft_sensor")
    late_and_restarted = [1_000_000_000, 1_000_000_001, 999_000_000, 1_000_000_002]
    assert ex.add_samples(late_and_restarted, np.zeros((4, 6)), "ft_sensor") == 3
    assert ex.dropped == {"out of time order": 1}
    assert ex.time_resets == 1
    assert ex.sample_count == 3  # the old timeline is gone
