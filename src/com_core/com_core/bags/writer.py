"""Crash-safe rosbag2 recording (MCAP storage) from serialized messages, without ROS.

``CrashSafeBagWriter`` writes a rosbag2 directory (``metadata.yaml`` + ``<name>_0.mcap``)
that a rosbag2 reader opens at every moment of its life, up to the last message flushed,
even when the writing process is killed (SIGKILL) at an arbitrary instant::

    with CrashSafeBagWriter(path, {WRENCH_TOPIC: "geometry_msgs/msg/WrenchStamped"}) as bag:
        bag.write(WRENCH_TOPIC, "geometry_msgs/msg/WrenchStamped", stamp_ns, raw)

While recording, the MCAP file ends in a private padding record and a trailer (DataEnd,
a Footer without summary, magic) that readers accept; each flush makes complete records
visible with one 9-byte write that never crosses a page, so a killed process leaves a
file that opens up to its last flush (``flush_interval`` s, ``chunk_size`` bytes). At
close the summary is written and the file is a standard indexed MCAP file. Log times
never decrease (a smaller one is raised to the previous). metadata.yaml is replaced
atomically on every new topic and every ``metadata_interval`` s; after a crash its
``custom_data.complete`` is ``"false"``. The protocol, and the facts about the readers
it relies on, are in docs/bag_writer.md. A call the writer refuses (not open, opened
twice, a topic's type changed) raises ``BagWriteError``.
"""

from __future__ import annotations

import functools
import os
import struct
import tempfile
import time
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path
from types import TracebackType
from typing import Any

__all__ = ["MESSAGE_DEFINITIONS", "BagWriteError", "CrashSafeBagWriter"]

MESSAGE_DEFINITIONS = {
    "control_msgs/msg/GripperCommand": "float64 position\nfloat64 max_effort\n",
}
"""The definitions (.msg text) of recorded message types that rosbags' Jazzy type store
lacks (``com_core.contract.TOPIC_TYPES``): their schema in a bag."""

MAGIC = b"\x89MCAP0\r\n"
PAGE = 4096
PAD_OPCODE = 0x80  # private record: every reader skips it by its length
PROFILE, LIBRARY = "ros2", "com_core.bags.writer"
ROS_DISTRO = "jazzy"

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
_OP_CHUNK, _OP_MESSAGE_INDEX, _OP_CHUNK_INDEX, _OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
_OP_METADATA, _OP_METADATA_INDEX, _OP_SUMMARY_OFFSET, _OP_DATA_END = 0x0C, 0x0D, 0x0E, 0x0F

_RECORD = struct.Struct("<BQ")  # opcode, content length: 9 bytes
_MESSAGE = struct.Struct("<BQHIQQ")  # record header + channel, sequence, log, publish time
_MESSAGE_CONTENT = 22  # bytes of a Message record's content before its data
_TIMES = struct.Struct("<QQ")
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_FOOTER = struct.Struct("<BQQQI")


def _string(text: str) -> bytes:
    data = text.encode()
    return _U32.pack(len(data)) + data


def _record(opcode: int, content: bytes) -> bytes:
    return _RECORD.pack(opcode, len(content)) + content


def _trailer() -> bytes:
    """DataEnd (no CRC), Footer without summary, magic: what ends the file while open."""
    return _record(_OP_DATA_END, _U32.pack(0)) + _FOOTER.pack(_OP_FOOTER, 20, 0, 0, 0) + MAGIC


@functools.cache
def _typestore() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    for msgtype, text in MESSAGE_DEFINITIONS.items():  # types the store lacks
        store.register(get_types_from_msg(text, msgtype))
    return store


def _yaml_text(data: Any) -> str:
    from ruamel.yaml import YAML

    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    yaml.width = 4096  # no folded lines
    stream = StringIO()
    yaml.dump(data, stream)
    return stream.getvalue()


class BagWriteError(RuntimeError):
    """The writer refuses the call: not open, opened twice, a topic's type changed."""


@dataclass
class _Channel:
    id: int
    topic: str
    msgtype: str
    digest: str
    qos: list[dict[str, Any]]
    record: bytes  # the Channel record
    count: int = 0  # messages accepted
    flushed: int = 0  # messages on disk


@dataclass
class _Chunk:
    """The chunk being filled: its records and per-channel message index."""

    records: bytearray = field(default_factory=bytearray)
    index: dict[int, bytearray] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    start: int = 0
    end: int = 0
    since: float = 0.0  # monotonic time of the first message


class CrashSafeBagWriter:
    """A rosbag2 directory (MCAP storage) that stays readable if the writer dies; see module.

    ``write(topic, msgtype, stamp_ns, raw)`` takes serialized (CDR) messages, as
    the rosbag2 convention; ``topics`` (topic -> msgtype) are declared at open,
    others on first use. ``offered_qos`` (topic -> rosbags ``Qos`` profiles) is stored
    for ``ros2 bag play``. Messages are held in memory until ``flush()``, or until the chunk
    reaches ``chunk_size`` bytes or its first message is ``flush_interval`` s old (checked on
    ``write``). Not thread-safe: one thread writes. ``counts`` are messages accepted per
    topic, ``flushed`` the messages that a reader would find after a crash now.
    """

    def __init__(
        self,
        path: Path | str,
        topics: Mapping[str, str] | None = None,
        *,
        offered_qos: Mapping[str, Sequence[Any]] | None = None,
        chunk_size: int = 256 * 1024,
        flush_interval: float = 0.1,
        metadata_interval: float = 1.0,
        reserve: int = 4 * 2**20,
    ) -> None:
        self.path = Path(path)
        self.chunk_size = chunk_size
        self.flush_interval = flush_interval
        self.metadata_interval = metadata_interval
        self.reserve = max(reserve, PAGE)
        self._initial_topics = dict(topics or {})
        self._offered_qos = dict(offered_qos or {})
        self._mcap_name = f"{self.path.name}_0.mcap"
        self._fd: int | None = None
        self._closed = False
        self._schemas: dict[str, tuple[int, bytes]] = {}  # msgtype -> (id, record)
        self._channels: dict[str, _Channel] = {}
        self._pending = bytearray()  # schema and channel records not yet on disk
        self._chunk = _Chunk()
        self._chunk_indexes: list[bytes] = []
        self._last_stamp = 0
        self._first_stamp: int | None = None  # of flushed messages
        self._flushed_end_stamp = 0
        self._end = 0  # offset of the PAD header = end of the visible data
        self._trailer_at = 0  # offset of the trailer
        self._data_crc = 0  # CRC32 of the bytes before the PAD
        self._metadata_wall = 0.0
        self.flushed = 0
        self.custom_data: dict[str, str] = {}
        """Entries metadata.yaml's ``custom_data`` carries beside ``writer`` and
        ``complete`` (rosbag2's map of strings), e.g. the recorder's lost messages."""

    # --- context manager ----------------------------------------------------------

    def __enter__(self) -> CrashSafeBagWriter:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # --- public -------------------------------------------------------------------

    @property
    def counts(self) -> dict[str, int]:
        """Messages accepted per topic (all of them are on disk after ``close``)."""
        return {topic: chan.count for topic, chan in self._channels.items()}

    @property
    def mcap_path(self) -> Path:
        return self.path / self._mcap_name

    def open(self) -> None:
        """Create the bag: metadata.yaml and an MCAP file readable from this moment."""
        if self._fd is not None or self._closed:
            raise BagWriteError(f"{self.path}: already opened")
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists already, not overwriting")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", dir=self.path.parent))
        try:
            staging.chmod(0o755)
            self._fd = os.open(
                staging / self._mcap_name, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o644
            )
            for topic, msgtype in self._initial_topics.items():
                self._add_topic(topic, msgtype)
            head = bytearray(MAGIC)
            head += _record(_OP_HEADER, _string(PROFILE) + _string(LIBRARY))
            head += self._pending
            self._pending.clear()
            head += _padding_before(len(head))
            self._end = len(head)
            self._trailer_at = _align_up(self._end + 9 + self.reserve)
            self._data_crc = zlib.crc32(head)
            self._pwrite(bytes(head) + self._pad_header(self._end), 0)
            self._pwrite(_trailer(), self._trailer_at)
            self._write_metadata(staging)
            if self.path.exists():
                raise FileExistsError(f"{self.path} exists already, not overwriting")
            staging.rename(self.path)
        except BaseException:
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None
            for child in staging.iterdir():
                child.unlink()
            staging.rmdir()
            raise

    def add_topic(self, topic: str, msgtype: str, offered_qos: Sequence[Any] = ()) -> None:
        """Declare a topic (before its first message); metadata.yaml lists it at once."""
        self._check_open()
        if topic in self._channels:
            raise BagWriteError(f"topic {topic} already added")
        if offered_qos:
            self._offered_qos[topic] = list(offered_qos)
        self._add_topic(topic, msgtype)
        self._write_metadata(self.path)

    def write(self, topic: str, msgtype: str, stamp_ns: int, raw: bytes) -> None:
        """Append one serialized message with log time ``stamp_ns`` (ns; see module)."""
        chan = self._channels.get(topic)
        if chan is None:
            self.add_topic(topic, msgtype)
            chan = self._channels[topic]
        elif chan.msgtype != msgtype:
            raise BagWriteError(f"{topic} has type {chan.msgtype}, not {msgtype}")
        self._check_open()
        stamp = max(int(stamp_ns), self._last_stamp)
        self._last_stamp = stamp
        chunk = self._chunk
        if not chunk.records:
            chunk.start, chunk.since = stamp, time.monotonic()
        chunk.end = stamp
        offset = len(chunk.records)
        chunk.records += _MESSAGE.pack(
            _OP_MESSAGE, _MESSAGE_CONTENT + len(raw), chan.id, 0, stamp, stamp
        )
        chunk.records += raw
        index = chunk.index.get(chan.id)
        if index is None:
            index = chunk.index[chan.id] = bytearray()
            chunk.counts[chan.id] = 0
        index += _TIMES.pack(stamp, offset)
        chunk.counts[chan.id] += 1
        chan.count += 1
        if (
            len(chunk.records) >= self.chunk_size
            or time.monotonic() - chunk.since >= self.flush_interval
        ):
            self.flush()

    def flush(self, older_than: float = 0.0) -> int:
        """Put the pending messages on disk if the oldest is ``older_than`` s old or more.

        Returns the number of messages on disk (``flushed``). Also refreshes metadata.yaml
        when it is ``metadata_interval`` s old.
        """
        self._check_open()
        chunk = self._chunk
        if self._pending or (chunk.records and time.monotonic() - chunk.since >= older_than):
            self._commit_pending()
        if time.monotonic() - self._metadata_wall >= self.metadata_interval:
            self._write_metadata(self.path)
        return self.flushed

    def close(self) -> dict[str, int]:
        """Flush, write the summary and final metadata.yaml; returns messages per topic."""
        if self._closed:
            return self.counts
        self._check_open()
        if self._chunk.records or self._pending:
            self._commit_pending()
        tail = self._final_tail()
        if self._end + len(tail) > self._trailer_at:
            self._grow(self._end + len(tail))
        self._pwrite(tail[9:], self._end + 9)  # invisible, inside the PAD
        self._truncate(self._end + len(tail))  # the new Footer indexes everything
        self._pwrite(tail[:9], self._end)  # PAD -> Metadata record: a standard file
        assert self._fd is not None
        os.close(self._fd)
        self._fd = None
        self._closed = True
        self._write_metadata(self.path, complete=True)
        return self.counts

    # --- records ------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._fd is None:
            raise BagWriteError(f"{self.path}: not open" + (" (closed)" if self._closed else ""))

    def _add_topic(self, topic: str, msgtype: str) -> None:
        store = _typestore()
        schema = self._schemas.get(msgtype)
        if schema is None:
            msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
            encoding = "ros2idl" if msgdef.startswith("=" * 80 + "\nIDL: ") else "ros2msg"
            schema_id = len(self._schemas) + 1
            content = _U16.pack(schema_id) + _string(msgtype) + _string(encoding)
            content += _U32.pack(len(msgdef.encode())) + msgdef.encode()
            schema = self._schemas[msgtype] = (schema_id, _record(_OP_SCHEMA, content))
            self._pending += schema[1]
        qos = _qos_dicts(self._offered_qos.get(topic, ()))
        digest = store.hash_rihs01(msgtype)
        metadata = b"".join(
            _string(key) + _string(value)
            for key, value in (
                ("offered_qos_profiles", _yaml_text(qos).strip()),
                ("topic_type_hash", digest),
            )
        )
        chan_id = len(self._channels) + 1
        content = _U16.pack(chan_id) + _U16.pack(schema[0]) + _string(topic) + _string("cdr")
        content += _U32.pack(len(metadata)) + metadata
        record = _record(_OP_CHANNEL, content)
        self._channels[topic] = _Channel(chan_id, topic, msgtype, digest, qos, record)
        self._pending += record

    def _commit_pending(self) -> None:
        records, messages = self._flush_records()
        self._commit(records)
        self.flushed += messages

    def _flush_records(self) -> tuple[bytearray, int]:
        """Pending schema/channel records, the chunk and its message indexes; resets them.

        Also the number of messages in them.
        """
        out = bytearray(self._pending)
        self._pending.clear()
        chunk, self._chunk = self._chunk, _Chunk()
        if not chunk.records:
            return out, 0
        chunk_at = self._end + len(out)
        records = chunk.records
        crc = zlib.crc32(records)
        out += _RECORD.pack(_OP_CHUNK, 40 + len(records))
        out += _TIMES.pack(chunk.start, chunk.end) + _U64.pack(len(records)) + _U32.pack(crc)
        out += _string("") + _U64.pack(len(records))
        out += records
        chunk_length = self._end + len(out) - chunk_at
        index_offsets = bytearray()
        index_start = len(out)
        for chan_id in sorted(chunk.index):
            entries = chunk.index[chan_id]
            index_offsets += _U16.pack(chan_id) + _U64.pack(self._end + len(out))
            out += _record(
                _OP_MESSAGE_INDEX, _U16.pack(chan_id) + _U32.pack(len(entries)) + entries
            )
        index = _TIMES.pack(chunk.start, chunk.end) + _TIMES.pack(chunk_at, chunk_length)
        index += _U32.pack(len(index_offsets)) + index_offsets
        index += _U64.pack(len(out) - index_start) + _string("")
        index += _TIMES.pack(len(records), len(records))
        self._chunk_indexes.append(_record(_OP_CHUNK_INDEX, index))
        for chan in self._channels.values():
            chan.flushed += chunk.counts.get(chan.id, 0)
        if self._first_stamp is None:
            self._first_stamp = chunk.start
        self._flushed_end_stamp = chunk.end
        return out, sum(chunk.counts.values())

    def _final_tail(self) -> bytes:
        """Metadata record, DataEnd, summary, summary offsets, Footer, magic."""
        serialized = _yaml_text(self._metadata(complete=True)["rosbag2_bagfile_information"])
        metadata_content = _string("rosbag2") + _map({"serialized_metadata": serialized.strip()})
        metadata = _record(_OP_METADATA, metadata_content)
        data_crc = zlib.crc32(metadata, self._data_crc)
        head = metadata + _record(_OP_DATA_END, _U32.pack(data_crc))
        summary_start = self._end + len(head)
        groups: list[tuple[int, bytes]] = [
            (_OP_SCHEMA, b"".join(record for _, record in self._schemas.values())),
            (_OP_CHANNEL, b"".join(chan.record for chan in self._channels.values())),
            (_OP_CHUNK_INDEX, b"".join(self._chunk_indexes)),
            (
                _OP_METADATA_INDEX,
                _record(
                    _OP_METADATA_INDEX,
                    _TIMES.pack(self._end, len(metadata)) + _string("rosbag2"),
                ),
            ),
            (_OP_STATISTICS, _record(_OP_STATISTICS, self._statistics())),
        ]
        summary = bytearray()
        offsets = bytearray()
        for opcode, group in groups:
            if group:
                start = summary_start + len(summary)
                offsets += _record(
                    _OP_SUMMARY_OFFSET, bytes([opcode]) + _TIMES.pack(start, len(group))
                )
                summary += group
        offsets_start = summary_start + len(summary)
        footer_fields = _RECORD.pack(_OP_FOOTER, 20) + _TIMES.pack(summary_start, offsets_start)
        crc = zlib.crc32(footer_fields, zlib.crc32(offsets, zlib.crc32(summary)))
        return head + bytes(summary) + bytes(offsets) + footer_fields + _U32.pack(crc) + MAGIC

    def _statistics(self) -> bytes:
        chans = sorted(self._channels.values(), key=lambda c: c.id)
        counts = b"".join(_U16.pack(c.id) + _U64.pack(c.flushed) for c in chans)
        start = self._first_stamp or 0
        end = self._flushed_end_stamp if self.flushed else 0
        return (
            _U64.pack(self.flushed)
            + _U16.pack(len(self._schemas))
            + _U32.pack(len(self._channels))
            + _U32.pack(0)  # attachments
            + _U32.pack(1)  # metadata records
            + _U32.pack(len(self._chunk_indexes))
            + _TIMES.pack(start, end)
            + _U32.pack(len(counts))
            + counts
        )

    # --- the crash-safe append protocol ------------------------------------------------

    def _pad_header(self, at: int) -> bytes:
        return _RECORD.pack(PAD_OPCODE, self._trailer_at - (at + 9))

    def _commit(self, records: bytearray) -> None:
        """Make complete ``records`` visible at the end of the data; see module."""
        if not records:
            return
        records += _padding_before(self._end + len(records))
        new_end = self._end + len(records)
        if new_end + 9 > self._trailer_at:
            self._grow(new_end + 9)
        self._pwrite(bytes(records[9:]) + self._pad_header(new_end), self._end + 9)
        self._pwrite(bytes(records[:9]), self._end)  # one page: all or nothing
        self._data_crc = zlib.crc32(records, self._data_crc)
        self._end = new_end

    def _grow(self, needed: int) -> None:
        """Point the PAD past ``needed`` (and a reserve), then move the trailer there."""
        self._trailer_at = _align_up(needed + max(self.reserve, needed // 4))
        self._pwrite(_U64.pack(self._trailer_at - (self._end + 9)), self._end + 1)  # (a)
        self._pwrite(_trailer(), self._trailer_at)  # (b): the file's end moves

    def _truncate(self, size: int) -> None:
        assert self._fd is not None
        os.ftruncate(self._fd, size)

    def _pwrite(self, data: bytes, offset: int) -> None:
        assert self._fd is not None
        view = memoryview(data)
        while view:
            done = os.pwrite(self._fd, view, offset)
            view, offset = view[done:], offset + done

    # --- metadata.yaml --------------------------------------------------------------

    def _metadata(self, complete: bool) -> dict[str, Any]:
        start = self._first_stamp or 0
        duration = self._flushed_end_stamp - start if self.flushed else 0
        topics = [
            {
                "topic_metadata": {
                    "name": chan.topic,
                    "type": chan.msgtype,
                    "serialization_format": "cdr",
                    "offered_qos_profiles": chan.qos,
                    "type_description_hash": chan.digest,
                },
                "message_count": chan.flushed,
            }
            for chan in self._channels.values()
        ]

        def span() -> dict[str, Any]:  # fresh dicts: no YAML anchors
            return {
                "starting_time": {"nanoseconds_since_epoch": start},
                "duration": {"nanoseconds": duration},
                "message_count": self.flushed,
            }

        return {
            "rosbag2_bagfile_information": {
                "version": 9,
                "storage_identifier": "mcap",
                "relative_file_paths": [self._mcap_name],
                **span(),
                "topics_with_message_count": topics,
                "compression_format": "",
                "compression_mode": "",
                "files": [{"path": self._mcap_name, **span()}],
                "custom_data": {
                    **self.custom_data,
                    "writer": LIBRARY,
                    "complete": str(complete).lower(),
                },
                "ros_distro": ROS_DISTRO,
            }
        }

    def _write_metadata(self, directory: Path, complete: bool = False) -> None:
        """Replace metadata.yaml atomically (write a temporary file, rename it)."""
        tmp = directory / "metadata.yaml.tmp"
        tmp.write_text(_yaml_text(self._metadata(complete)), "utf8")
        tmp.replace(directory / "metadata.yaml")
        self._metadata_wall = time.monotonic()


def _align_up(offset: int) -> int:
    return -(-offset // PAGE) * PAGE


def _padding_before(at: int) -> bytes:
    """A private record moving ``at`` to the next page if a 9-byte header there would cross it."""
    if at % PAGE <= PAGE - 9:
        return b""
    size = (-at) % PAGE + PAGE  # >= 9 bytes, ends on a page start
    return _RECORD.pack(PAD_OPCODE, size - 9) + bytes(size - 9)


def _map(items: Mapping[str, str]) -> bytes:
    data = b"".join(_string(k) + _string(v) for k, v in items.items())
    return _U32.pack(len(data)) + data


def _qos_dicts(profiles: Sequence[Any]) -> list[dict[str, Any]]:
    """rosbags ``Qos`` profiles as metadata.yaml version 9 writes them."""
    from rosbags.rosbag2.metadata import dump_qos_v9

    return [dict(d) for d in dump_qos_v9(list(profiles))]
