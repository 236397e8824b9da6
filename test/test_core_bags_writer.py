"""com_core.bags.writer: the crash-safe bag writer (no DDS); every state a kill can leave
is a readable bag."""

from __future__ import annotations

import contextlib
import os
import random
import signal
import struct
import subprocess
import sys
import textwrap
from collections import Counter
from pathlib import Path

import pytest
import yaml
from mcap.exceptions import EndOfFile
from mcap.reader import NonSeekingReader, make_reader
from rosbags.rosbag2 import Reader

from com_core.bags import writer as bag_writer
from com_core.bags.writer import PAGE, BagWriteError, CrashSafeBagWriter

STRING = "std_msgs/msg/String"


def string_cdr(i: int) -> bytes:
    """A std_msgs/String message (CDR, little endian) of varying length, from ``i``."""
    text = (f"message {i};" * (i % 7 + 1)).encode()
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(text) + 1) + text + b"\x00"


def read_all(bag: Path) -> list[tuple[str, int, bytes]]:
    with Reader(bag) as reader:
        return [(c.topic, stamp, bytes(raw)) for c, stamp, raw in reader.messages()]


def read_mcap_library(mcap: Path, into: list | None = None) -> list[tuple[str, int, bytes]]:
    """Messages as the ``mcap`` package reads them (a second, independent reader)."""
    got = [] if into is None else into
    with open(mcap, "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            got.append((channel.topic, message.log_time, message.data))
    return got


def expected_messages(n: int) -> list[tuple[str, int, bytes]]:
    """Three topics, /c first used late; strictly increasing log times."""
    return [
        (
            "/c" if i % 5 == 4 and i > 300 else "/b" if i % 3 == 0 else "/a",
            10_000 + i,
            string_cdr(i),
        )
        for i in range(n)
    ]


def test_round_trip_reads_back_every_message_exactly(tmp_path):
    messages = expected_messages(5000)
    bag = tmp_path / "run"
    pads = []
    original = bag_writer._padding_before

    def spy(at: int) -> bytes:
        pad = original(at)
        pads.append(len(pad))
        return pad

    bag_writer._padding_before = spy
    try:
        with CrashSafeBagWriter(bag, {"/a": STRING, "/b": STRING}, reserve=PAGE) as writer:
            with Reader(bag) as reader:  # a bag from the first moment
                assert reader.message_count == 0
                assert {c.topic for c in reader.connections} == {"/a", "/b"}
            rng = random.Random(1)
            for i, message in enumerate(messages):
                writer.write(message[0], STRING, message[1], message[2])
                if rng.random() < 0.3:  # many flushes at many offsets: pages, growth
                    writer.flush()
                if i == 2500:
                    assert read_all(bag) == messages[: writer.flushed]
    finally:
        bag_writer._padding_before = original
    assert any(pads), "no flush ended next to a page boundary: the padding path is untested"
    assert writer.counts == Counter(topic for topic, _, _ in messages)
    assert read_all(bag) == messages
    assert read_mcap_library(bag / "run_0.mcap") == messages
    with Reader(bag) as reader:
        assert reader.message_count == 5000
        assert {c.topic: c.msgcount for c in reader.connections} == writer.counts
        connection, _, raw = next(reader.messages())
        from rosbags.typesys import Stores, get_typestore

        msg = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(raw, connection.msgtype)
        assert msg.data == "message 0;"  # the stored definition decodes it
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"]["complete"] == "true"
    assert info["storage_identifier"] == "mcap"


def test_the_final_file_is_a_standard_indexed_mcap(tmp_path):
    messages = expected_messages(3000)
    with CrashSafeBagWriter(tmp_path / "run", chunk_size=8192) as writer:
        for topic, stamp, raw in messages:
            writer.write(topic, STRING, stamp, raw)
    mcap = tmp_path / "run" / "run_0.mcap"
    with open(mcap, "rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == 3000
        assert len(summary.chunk_indexes) == summary.statistics.chunk_count > 1
        assert {c.topic for c in summary.channels.values()} == {"/a", "/b", "/c"}
    with open(mcap, "rb") as stream:  # data section, chunk and summary CRCs all valid
        reader = NonSeekingReader(stream, validate_crcs=True)
        assert sum(1 for _ in reader.iter_messages()) == 3000


def test_log_times_never_decrease_and_existing_bags_are_refused(tmp_path):
    bag = tmp_path / "run"
    with CrashSafeBagWriter(bag) as writer:
        writer.write("/a", STRING, 100, string_cdr(0))
        writer.write("/a", STRING, 50, string_cdr(1))  # a wall clock stepped back
        with pytest.raises(BagWriteError, match="has type"):
            writer.write("/a", "std_msgs/msg/Header", 200, b"")
    assert [stamp for _, stamp, _ in read_all(bag)] == [100, 100]
    with pytest.raises(BagWriteError, match="not open"):
        writer.write("/a", STRING, 300, string_cdr(2))
    with pytest.raises(FileExistsError):
        CrashSafeBagWriter(bag).open()


class SnapshotWriter(CrashSafeBagWriter):
    """Copies the bag before and after every write to the file, and part-way through
    writes that span pages (where a SIGKILL may cut them), with the messages on disk."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.states: list[tuple[bytes, str, int]] = []
        self.watching = False

    def _snapshot(self, extra: tuple[bytes, int] | None = None) -> None:
        data = bytearray(self.mcap_path.read_bytes())
        if extra is not None:
            part, offset = extra
            data[offset : offset + len(part)] = part
        self.states.append((bytes(data), (self.path / "metadata.yaml").read_text(), self.flushed))

    def _pwrite(self, data: bytes, offset: int) -> None:
        if self.watching:
            assert self._end % PAGE <= PAGE - 9, "a PAD header crosses a page"
            self._snapshot()
            cuts = sorted({(offset // PAGE + 1) * PAGE, (offset + len(data)) // PAGE * PAGE})
            for cut in cuts:
                if offset < cut < offset + len(data):
                    self._snapshot((data[: cut - offset], offset))
        super()._pwrite(data, offset)
        if self.watching:
            self._snapshot()

    def _truncate(self, size: int) -> None:
        self._snapshot()
        super()._truncate(size)
        self._snapshot()


def test_every_state_a_kill_can_leave_is_readable(tmp_path):
    messages = expected_messages(1500)
    writer = SnapshotWriter(tmp_path / "run", {"/a": STRING}, chunk_size=2048, reserve=PAGE)
    writer.open()
    writer.watching = True
    for topic, stamp, raw in messages:
        writer.write(topic, STRING, stamp, raw)
    writer.close()
    assert len(writer.states) > 100
    bag = tmp_path / "state"
    bag.mkdir()
    for k, (data, metadata, flushed) in enumerate(writer.states):
        (bag / "run_0.mcap").write_bytes(data)
        (bag / "metadata.yaml").write_text(metadata)
        got = read_all(bag)
        assert len(got) >= flushed, f"state {k}: {len(got)} of {flushed} flushed messages"
        assert got == messages[: len(got)], f"state {k}: not the messages written"
        # the mcap package reads them too; in the moment between moving the PAD's end
        # and the file's end (see recording) it reports EndOfFile after the last message
        from_mcap: list = []
        with contextlib.suppress(EndOfFile):
            read_mcap_library(bag / "run_0.mcap", into=from_mcap)
        assert from_mcap[:flushed] == messages[:flushed], f"state {k} (mcap package)"


KILLED_WRITER = textwrap.dedent(
    """
    import struct, sys
    from com_core.bags.writer import CrashSafeBagWriter

    {string_cdr}
    writer = CrashSafeBagWriter(
        sys.argv[1], {{"/a": "std_msgs/msg/String"}}, chunk_size=8192, reserve=32768
    )
    writer.open()
    i = 0
    while True:
        topic = "/c" if i % 5 == 4 and i > 300 else "/b" if i % 3 == 0 else "/a"
        writer.write(topic, "std_msgs/msg/String", 10_000 + i, string_cdr(i))
        i += 1
        if i % 97 == 0:
            print(writer.flush(), flush=True)
    """
)


def test_a_writer_killed_mid_stream_leaves_a_readable_bag(tmp_path):
    import inspect

    script = KILLED_WRITER.format(string_cdr=inspect.getsource(string_cdr))
    rng = random.Random(7)
    for run in range(4):
        bag = tmp_path / f"run{run}"
        target = rng.randrange(2_000, 60_000)
        proc = subprocess.Popen(
            [sys.executable, "-c", script, str(bag)], stdout=subprocess.PIPE, text=True
        )
        assert proc.stdout is not None
        reported = 0
        for line in proc.stdout:
            reported = int(line)
            if reported >= target:
                break
        os.kill(proc.pid, signal.SIGKILL)
        reported = max([reported, *(int(line) for line in proc.stdout)])
        proc.wait(timeout=10)
        assert proc.returncode == -signal.SIGKILL
        got = read_all(bag)
        assert len(got) >= reported > 0, f"{len(got)} read, {reported} reported flushed"
        assert got == expected_messages(len(got))
