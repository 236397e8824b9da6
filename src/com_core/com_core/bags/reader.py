"""Read rosbag2 directories (MCAP storage) without ROS, through rosbags (and mcap).

Messages stay serialized (CDR bytes) end to end: the reader hands them to ``cdr`` for
decoding, exactly as the node's raw subscriptions do. Bags are written by
``com_core.bags.writer.CrashSafeBagWriter``.

A bag rosbags cannot read is read with the ``mcap`` package instead: rosbags needs the
file's Footer, which a copy cut short (a full disk, an interrupted transfer) does not
have, and metadata.yaml, whose topic list it trusts (it drops the channels not listed);
and it stops at the first chunk whose checksum fails. A file with its summary is read
chunk by chunk through its chunk index, and a damaged chunk (a bad sector, a copy gone
wrong) is skipped and counted, its lost messages per topic taken from the chunk's message
index; a file without one is read record by record up to where it ends. ``BagReading``
says what was read, how, and what was cut or damaged.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "INCOMPLETE_TEXT",
    "RECORDER_LOST_KEY",
    "BagReading",
    "read_metadata",
    "read_raw",
    "recorder_lost",
    "recorder_lost_text",
]


RawMessage = tuple[str, str, int, bytes]
"""(topic, msgtype, log time ns, CDR bytes)."""

RECORDER_LOST_KEY = "recorder_lost_messages"
"""metadata.yaml's ``custom_data`` key: a JSON object of messages lost per topic."""


def recorder_lost_text(lost: dict[str, int]) -> str:
    """One line on the messages a recorder lost ('' when none)."""
    if not lost:
        return ""
    parts = ", ".join(f"{n} of {topic}" for topic, n in lost.items())
    return f"the recorder lost {parts} before they reached it (metadata.yaml)"


INCOMPLETE_TEXT = (
    "metadata.yaml says the recording is incomplete (custom_data.complete: false): "
    "its recorder never closed it"
)


@dataclass
class BagReading:
    """What reading a bag found; ``read_raw`` fills it in as it reads.

    Attributes
    ----------
    read : messages read per requested topic.
    listed : messages per requested topic that metadata.yaml counts (a topic it does not
        list, or a bag without metadata.yaml, is absent). The crash-safe writer's counts
        may lag its MCAP file by up to a second after a crash.
    complete : metadata.yaml's ``custom_data.complete``: False for a recording that was
        never closed (the crash-safe writer's state while recording and after a crash);
        None when the bag does not say.
    fallback : why rosbags did not read the bag ('' when it did): it could not open it,
        or metadata.yaml does not list a requested topic the MCAP file holds (rosbags
        drops those). The MCAP files were then read record by record with ``mcap``.
    cut_short : an MCAP file ends before its Footer (a truncated file): every message
        in complete records before the cut was read, the rest is lost.
    stopped : the error that ended the read of a cut file, with the file's name.
    damaged : one line per damaged chunk skipped: file, byte offset, time span, the
        error, and the messages lost per requested topic where its index tells.
    lost : messages of requested topics in damaged chunks, per topic, where the chunk's
        message index survived.
    file_bytes : size of the MCAP files read, bytes.
    robot_description : the last URDF on /robot_description ('' if none was read).
    estimator_values : the values of the estimator's last exploration status on
        /diagnostics ({} if none was read): its window counts, to hold the bag's against.
    recorder_lost : messages of requested topics the recorder counted lost before they
        reached it (``recorder_lost``), per topic; {} when none or not said.
    """

    read: dict[str, int] = field(default_factory=dict)
    listed: dict[str, int] = field(default_factory=dict)
    complete: bool | None = None
    fallback: str = ""
    cut_short: bool = False
    stopped: str = ""
    damaged: list[str] = field(default_factory=list)
    lost: dict[str, int] = field(default_factory=dict)
    file_bytes: int = 0
    robot_description: str = ""
    estimator_values: dict[str, str] = field(default_factory=dict)
    recorder_lost: dict[str, int] = field(default_factory=dict)

    def counts_text(self) -> str:
        """'/ft_sensor/wrench: 7681 of 15982 listed in metadata.yaml (48.1 %); ...'."""
        parts = []
        for topic in dict.fromkeys([*self.listed, *self.read]):
            n, listed = self.read.get(topic, 0), self.listed.get(topic)
            if listed is None:
                parts.append(f"{topic}: {n} (not listed in metadata.yaml)")
            else:
                share = f" ({100 * n / listed:.1f} %)" if listed else ""
                parts.append(f"{topic}: {n} of {listed} listed in metadata.yaml{share}")
        return "; ".join(parts) or "no messages"

    def cut_text(self) -> str:
        """One line on a cut file ('' when no file was cut)."""
        if not self.cut_short:
            return ""
        return (
            f"the bag's MCAP file is cut short ({self.file_bytes} bytes, no Footer; "
            f"{self.stopped}), read up to the cut: {self.counts_text()}"
        )

    def damaged_text(self) -> str:
        """One line on the damaged chunks skipped ('' when none)."""
        if not self.damaged:
            return ""
        return (
            f"{len(self.damaged)} damaged chunk(s) of the MCAP file skipped (the rest read): "
            f"{'; '.join(self.damaged)}; {self.counts_text()}"
        )

    def notes(self) -> list[str]:
        """Lines for the user: a fallback read, a cut file, damaged chunks, an unclosed
        recording."""
        out = []
        if self.fallback:
            out.append(f"{self.fallback}: read with the mcap package")
        if self.cut_short:
            out.append(self.cut_text())
        if self.damaged:
            out.append(self.damaged_text())
        if self.complete is False:
            out.append(INCOMPLETE_TEXT)
        if self.recorder_lost:
            out.append(recorder_lost_text(self.recorder_lost))
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the attributes above."""
        return {
            "read": dict(self.read),
            "listed": dict(self.listed),
            "complete": self.complete,
            "fallback": self.fallback,
            "cut_short": self.cut_short,
            "stopped": self.stopped,
            "damaged": list(self.damaged),
            "lost": dict(self.lost),
            "file_bytes": self.file_bytes,
            "recorder_lost": dict(self.recorder_lost),
        }


def _bag_information(bag: Path | str) -> dict[str, Any]:
    """metadata.yaml's ``rosbag2_bagfile_information`` ({} when missing or unreadable)."""
    from ruamel.yaml import YAML, YAMLError

    path = Path(bag) / "metadata.yaml"
    try:
        info = YAML(typ="safe").load(path.read_text("utf8"))["rosbag2_bagfile_information"]
    except (OSError, YAMLError, KeyError, TypeError):
        return {}
    return info if isinstance(info, dict) else {}


def read_metadata(bag: Path | str) -> tuple[dict[str, int], bool | None, list[str]]:
    """metadata.yaml of a rosbag2 directory: (messages per topic, complete, MCAP files).

    ``complete`` is ``custom_data.complete`` (None when absent); the files are the
    relative paths it names. A missing or unreadable metadata.yaml gives ({}, None, []).
    """
    return _metadata_of(_bag_information(bag))


def _metadata_of(info: dict[str, Any]) -> tuple[dict[str, int], bool | None, list[str]]:
    """``read_metadata`` of metadata.yaml's parsed ``info``."""
    counts: dict[str, int] = {}
    for entry in info.get("topics_with_message_count") or []:
        try:
            counts[str(entry["topic_metadata"]["name"])] = int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            continue
    custom = info.get("custom_data") or {}
    flag = str(custom.get("complete", "")).lower() if isinstance(custom, dict) else ""
    complete = {"true": True, "false": False}.get(flag)
    files = [str(f) for f in info.get("relative_file_paths") or []]
    return counts, complete, files


def recorder_lost(bag: Path | str) -> dict[str, int]:
    """Messages per topic that the recorder was told it lost (DDS's message-lost
    events), from metadata.yaml's ``custom_data`` (``RECORDER_LOST_KEY``); {} when the
    bag does not say."""
    return _lost_of(_bag_information(bag))


def _lost_of(info: dict[str, Any]) -> dict[str, int]:
    """``recorder_lost`` of metadata.yaml's parsed ``info``."""
    custom = info.get("custom_data") or {}
    text = custom.get(RECORDER_LOST_KEY, "") if isinstance(custom, dict) else ""
    try:
        lost = json.loads(text) if text else {}
        return {str(topic): int(n) for topic, n in lost.items() if int(n) > 0}
    except (ValueError, TypeError, AttributeError):
        return {}


def read_raw(
    bag: Path | str, topics: Iterable[str], reading: BagReading | None = None
) -> Iterator[RawMessage]:
    """(topic, msgtype, log time ns, CDR bytes) of ``topics`` in log-time order.

    ``reading``, if given, is filled in while reading (see ``BagReading``). When rosbags
    cannot open the bag, the MCAP files are read in file order (the log-time order of a
    bag recorded as it came) up to where they end.
    """
    from rosbags.rosbag2 import Reader, ReaderError

    bag = Path(bag)
    wanted = set(topics)
    reading = BagReading() if reading is None else reading
    info = _bag_information(bag)  # metadata.yaml parsed once
    counts, reading.complete, files = _metadata_of(info)
    reading.listed = {t: n for t, n in counts.items() if t in wanted}
    reading.recorder_lost = {t: n for t, n in _lost_of(info).items() if t in wanted}
    try:
        reader = Reader(bag)
        reader.open()
    except (ReaderError, FileNotFoundError) as exc:
        paths = _mcap_files(bag, files)
        if not paths:
            raise
        reading.fallback = f"rosbags could not open the bag ({exc})"
        yield from _stream_mcap_files(paths, wanted, reading)
        return
    unlisted = _unlisted_topics(wanted - {c.topic for c in reader.connections}, bag, files)
    if unlisted:
        reader.close()
        names = ", ".join(sorted(unlisted))
        reading.fallback = f"metadata.yaml does not list {names}, which the MCAP file holds"
        yield from _stream_mcap_files(_mcap_files(bag, files), wanted, reading)
        return
    last = None  # log time of the last message read, ns
    try:
        reading.file_bytes = sum(p.stat().st_size for p in _mcap_files(bag, files))
        conns = [c for c in reader.connections if c.topic in wanted]
        for conn, stamp, raw in reader.messages(connections=conns):
            reading.read[conn.topic] = reading.read.get(conn.topic, 0) + 1
            last = stamp
            yield conn.topic, conn.msgtype, stamp, raw
    except ReaderError as exc:  # a damaged chunk: the rest, chunk by chunk
        reading.fallback = f"rosbags stopped reading the bag ({exc})"
        reading.file_bytes = 0
        yield from _stream_mcap_files(_mcap_files(bag, files), wanted, reading, after=last)
    finally:
        reader.close()


def _unlisted_topics(missing: set[str], bag: Path, files: list[str]) -> set[str]:
    """Of the topics rosbags did not find (``missing``), those the MCAP files' summaries
    hold: rosbags drops the channels metadata.yaml does not list. A file without a
    summary (one being recorded) is not searched."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    found: set[str] = set()
    if not missing:
        return found
    for path in _mcap_files(bag, files):
        with path.open("rb") as stream:
            try:
                summary = make_reader(stream).get_summary()
            except (McapError, ValueError, struct.error, OSError):
                continue
        if summary is not None:
            found |= {c.topic for c in summary.channels.values()} & missing
    return found


def _mcap_files(bag: Path, named: list[str]) -> list[Path]:
    """The MCAP files of ``bag``: those metadata.yaml names that exist, else ``*.mcap``."""
    paths = [bag / name for name in named if (bag / name).is_file()]
    return paths or sorted(bag.glob("*.mcap"))


def _stream_mcap_files(
    paths: list[Path], wanted: set[str], reading: BagReading, after: int | None = None
) -> Iterator[RawMessage]:
    """Messages of ``wanted`` topics from MCAP files, logged after ``after`` (ns; None:
    all): through each file's chunk index when it has a readable summary (damaged chunks
    skipped, ``_indexed_messages``), else record by record up to where it ends."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    for path in paths:
        reading.file_bytes += path.stat().st_size
        with path.open("rb") as stream:
            try:
                summary = make_reader(stream).get_summary()
            except (McapError, ValueError, struct.error, OSError):
                summary = None
            if summary is not None and summary.chunk_indexes:
                yield from _indexed_messages(path, stream, summary, wanted, reading, after)
            else:
                stream.seek(0)
                yield from _records(path, stream, wanted, reading, after)


def _indexed_messages(
    path: Path,
    stream: Any,
    summary: Any,
    wanted: set[str],
    reading: BagReading,
    after: int | None,
) -> Iterator[RawMessage]:
    """The messages of ``wanted`` topics chunk by chunk in the order of the chunk index
    (a recording's chunks follow one another in time), each chunk's in log-time order;
    a chunk that cannot be read or fails its checksum is skipped and counted."""
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError
    from mcap.opcode import Opcode
    from mcap.records import Chunk, Message, MessageIndex
    from mcap.stream_reader import breakup_chunk

    topics = {cid: c.topic for cid, c in summary.channels.items() if c.topic in wanted}
    types = {
        cid: summary.schemas[c.schema_id].name if c.schema_id in summary.schemas else ""
        for cid, c in summary.channels.items()
    }
    chunks = sorted(
        summary.chunk_indexes, key=lambda c: (c.message_start_time, c.chunk_start_offset)
    )
    for index in chunks:
        if after is not None and index.message_end_time < after:
            continue  # read before
        try:
            stream.seek(index.chunk_start_offset + 1 + 8)  # past the opcode and length
            records = breakup_chunk(Chunk.read(ReadDataStream(stream)), validate_crc=True)
        except (McapError, ValueError, struct.error, OSError, EOFError) as exc:
            lost: dict[str, int] = {}
            unknown: list[str] = []
            for cid, offset in index.message_index_offsets.items():
                if cid not in topics:
                    continue
                try:
                    stream.seek(offset)
                    opcode = stream.read(1)
                    stream.seek(offset + 1 + 8)
                    message_index = MessageIndex.read(ReadDataStream(stream))
                    if opcode != bytes([Opcode.MESSAGE_INDEX]) or message_index.channel_id != cid:
                        raise ValueError("not a message index")
                except (McapError, ValueError, struct.error, OSError, EOFError):
                    unknown.append(topics[cid])  # the index is damaged too
                    continue
                n = len(message_index.records)
                lost[topics[cid]] = lost.get(topics[cid], 0) + n
            for topic, n in lost.items():
                reading.lost[topic] = reading.lost.get(topic, 0) + n
            span = f"{index.message_start_time * 1e-9:.3f}-{index.message_end_time * 1e-9:.3f} s"
            what = ", ".join([f"{n} {t}" for t, n in lost.items()] + [f"? {t}" for t in unknown])
            reading.damaged.append(
                f"{path.name} at byte {index.chunk_start_offset} ({span} log time; "
                f"{type(exc).__name__}: {exc or 'unreadable'}; lost {what or 'nothing wanted'})"
            )
            continue
        messages = [r for r in records if isinstance(r, Message) and r.channel_id in topics]
        for record in sorted(messages, key=lambda r: r.log_time):
            if after is not None and record.log_time <= after:
                continue
            topic = topics[record.channel_id]
            reading.read[topic] = reading.read.get(topic, 0) + 1
            yield topic, types[record.channel_id], record.log_time, record.data


def _records(
    path: Path, stream: Any, wanted: set[str], reading: BagReading, after: int | None
) -> Iterator[RawMessage]:
    """Messages of ``wanted`` topics read record by record, up to where the file ends; a
    file that ends before its Footer sets ``reading.cut_short``."""
    from mcap.exceptions import McapError
    from mcap.reader import StreamReader
    from mcap.records import Channel, Message, Schema

    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}  # id -> (topic, msgtype)
    try:
        for record in StreamReader(stream, validate_crcs=True).records:
            if isinstance(record, Message):
                channel = channels.get(record.channel_id)
                if channel is not None and (after is None or record.log_time > after):
                    topic, msgtype = channel
                    reading.read[topic] = reading.read.get(topic, 0) + 1
                    yield topic, msgtype, record.log_time, record.data
            elif isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel) and record.topic in wanted:
                msgtype = schemas.get(record.schema_id, "")
                channels[record.id] = (record.topic, msgtype)
    except (McapError, ValueError, struct.error) as exc:
        # a record that runs past the end of the file: EndOfFile, or a short read of
        # its header (struct.error), or a chunk whose CRC fails (ValueError)
        reading.cut_short = True
        detail = f": {exc}" if str(exc) else ""
        reading.stopped = f"{path.name}: {type(exc).__name__}{detail}"
