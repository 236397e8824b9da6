"""Read and write rosbag2 directories (MCAP storage) without ROS, through rosbags.

Messages stay serialized (CDR bytes) end to end: the reader hands them to ``cdr`` for
decoding, exactly as the node's raw subscriptions do. Bags are written by
``com_core.recording.CrashSafeBagWriter``.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

from .cdr import decode_header, decode_wrench_batch
from .exploration import Exploration

__all__ = [
    "POSE_TOPIC",
    "WRENCH_TOPIC",
    "feed_bag",
    "read_raw",
]

WRENCH_TOPIC = "/ft_sensor/wrench"
POSE_TOPIC = "/exploration_sequencer/pose"
_BATCH = 4096


def read_raw(bag: Path | str, topics: Iterable[str]) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, msgtype, log time ns, CDR bytes) of ``topics`` in log-time order."""
    from rosbags.rosbag2 import Reader

    with Reader(Path(bag)) as reader:
        wanted = set(topics)
        conns = [c for c in reader.connections if c.topic in wanted]
        for conn, stamp, raw in reader.messages(connections=conns):
            yield conn.topic, conn.msgtype, stamp, raw


def feed_bag(
    bag: Path | str,
    exploration: Exploration,
    wrench_topic: str = WRENCH_TOPIC,
    pose_topic: str = POSE_TOPIC,
) -> tuple[int, int]:
    """Feed a bag's wrenches and pose labels to ``exploration`` in recorded order.

    Returns (wrench messages, label messages) read. Wrenches are decoded in batches, as
    the node does; the result does not depend on the batching.
    """
    pending: list[bytes] = []
    n_wrench = n_label = 0

    def flush() -> None:
        if pending:
            stamps, wrenches, frames = decode_wrench_batch(pending)
            exploration.add_samples(stamps, wrenches, frames)
            pending.clear()

    for topic, msgtype, _, raw in read_raw(bag, (wrench_topic, pose_topic)):
        if topic == wrench_topic:
            pending.append(raw)
            n_wrench += 1
            if len(pending) >= _BATCH:
                flush()
        elif msgtype == "std_msgs/msg/Header":
            exploration.add_label(*decode_header(raw))
            n_label += 1
    flush()
    return n_wrench, n_label
