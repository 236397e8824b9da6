"""Record exploration runs as rosbag2 directories (MCAP) from raw subscriptions.

``Recorder(node)`` subscribes, at once, to every topic of ``RUN_TOPICS`` with ``raw=True``
(messages stay CDR bytes, never re-encoded): best effort with depth 5000 for the high-rate
streams (``/clock``, ``/ft_sensor/wrench``, ``/joint_states``), reliable for the rest,
transient local for ``LATCHED_TOPICS``. Subscribing before any run means discovery is done when a
run starts. ``start(bag_dir)`` begins a recording, ``stop()`` ends it::

    recorder = Recorder(node)       # in the node's __init__
    recorder.start(Path("bags") / run_id)
    ...
    counts = recorder.stop()        # messages written per topic

Callbacks only append ``(topic, receive time, bytes)`` to a deque; a writer thread moves
them to a ``com_core.bags.writer.CrashSafeBagWriter``, so the executor thread never waits on
I/O and a run that dies leaves a bag readable up to ~0.1 s before the end. The last message
of each latched topic is remembered even when not recording and written first when a
recording starts, with the start time as its log time.

Log times are the wall-clock receive time (``time.time_ns()`` when the callback runs), as
``ros2 bag record`` does by default, also under ``use_sim_time``: they order the bag and
never go back (a wall clock stepped back is clamped). Sim time is in the messages' stamps.
Each topic's offered QoS (from its publishers at ``start``; else the profile the recorder
asked for) goes into the bag, so ``ros2 bag play`` republishes latched topics latched.
The node must be spun by an executor that keeps up: ``EventsExecutor`` with
``spin_once(timeout_sec=0.1)`` in a loop (about 30 kHz of raw messages on this machine).
"""

from __future__ import annotations

import importlib
import threading
import time
from collections import deque
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import Any

import rclpy.node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import BEST_EFFORT_TOPICS, LATCHED_TOPICS
from com_core.contract import TOPIC_TYPES as RUN_TOPICS

__all__ = ["RUN_TOPICS", "Recorder"]

BEST_EFFORT_DEPTH = 5000  # 1 s of a 5 kHz stream
RELIABLE_DEPTH = 100
FLUSH_INTERVAL = 0.1  # s: the most a crash loses
_IDLE_WAIT = 0.01  # s the writer thread sleeps when the queue is empty

Item = tuple[str, int, bytes]  # topic, log time ns, CDR bytes


class _Session:
    """One recording: its writer, queue and thread."""

    def __init__(
        self,
        writer: CrashSafeBagWriter,
        topics: Mapping[str, str],
        queue: deque[Item],
        logger: Any,
    ) -> None:
        self.writer = writer
        self.logger = logger
        self.topics = topics
        self.queue = queue
        self.stopping = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(
            target=self.run, name=f"recorder {writer.path.name}", daemon=True
        )

    def run(self) -> None:
        writer, topics, queue = self.writer, self.topics, self.queue
        pop, write = queue.popleft, writer.write
        try:
            while True:
                if queue:
                    while queue:
                        topic, stamp, raw = pop()
                        write(topic, topics[topic], stamp, raw)
                elif self.stopping.is_set():
                    return
                else:
                    writer.flush(older_than=FLUSH_INTERVAL)
                    self.stopping.wait(_IDLE_WAIT)
        except BaseException as exc:  # raised again by stop(); the bag stays readable
            self.error = exc
            self.logger.error(f"recording to {writer.path} stopped: {exc!r}")


class Recorder:
    """Records ``topics`` of ``node`` to one bag directory per run; see module."""

    def __init__(
        self,
        node: rclpy.node.Node,
        topics: Mapping[str, str] = RUN_TOPICS,
        latched: Collection[str] = LATCHED_TOPICS,
    ) -> None:
        self._node = node
        self._topics = dict(topics)
        self._latched = frozenset(latched) & self._topics.keys()
        self._lock = threading.Lock()
        self._queue: deque[Item] | None = None  # set while recording
        self._latest: dict[str, bytes] = {}  # last message of each latched topic
        self._captures: dict[str, list[bytes]] = {}  # topic -> raw messages kept for a caller
        self._session: _Session | None = None
        self._requested: dict[str, QoSProfile] = {}
        for topic, msgtype in self._topics.items():
            qos = self._qos_for(topic)
            self._requested[topic] = qos
            callback = (
                self._latched_callback(topic)
                if topic in self._latched
                else self._stream_callback(topic)
            )
            node.create_subscription(_message_class(msgtype), topic, callback, qos, raw=True)

    @property
    def recording(self) -> bool:
        return self._session is not None

    @property
    def path(self) -> Path | None:
        """The bag directory being recorded, or None."""
        return self._session.writer.path if self._session is not None else None

    def start(self, bag_dir: Path) -> None:
        """Begin recording to ``bag_dir`` (which must not exist)."""
        if self._session is not None:
            raise RuntimeError(f"already recording to {self._session.writer.path}")
        bag_dir = Path(bag_dir)
        if bag_dir.exists():
            raise FileExistsError(f"{bag_dir} exists already, not overwriting")
        writer = CrashSafeBagWriter(
            bag_dir,
            self._topics,
            offered_qos={topic: self._offered_qos(topic) for topic in self._topics},
            flush_interval=FLUSH_INTERVAL,
        )
        writer.open()
        queue: deque[Item] = deque()
        session = _Session(writer, self._topics, queue, self._node.get_logger())
        start_ns = time.time_ns()
        with self._lock:
            for topic in self._topics:
                if topic in self._latest:
                    queue.append((topic, start_ns, self._latest[topic]))
            self._queue = queue
        self._session = session
        session.thread.start()
        self._node.get_logger().info(f"recording {len(self._topics)} topics to {bag_dir}")

    def stop(self) -> dict[str, int]:
        """Finish the recording (flush, close, final metadata.yaml); messages per topic."""
        session = self._session
        if session is None:
            raise RuntimeError("not recording")
        with self._lock:
            self._queue = None  # no callback appends to the session's queue after this
        session.stopping.set()
        session.thread.join()
        self._session = None
        error = session.error
        try:
            counts = session.writer.close()
        except Exception as exc:
            error = error or exc
            counts = session.writer.counts
        if error is not None:
            raise RuntimeError(f"recording to {session.writer.path} failed: {error}") from error
        self._node.get_logger().info(
            f"recorded {sum(counts.values())} messages to {session.writer.path}"
        )
        return counts

    # --- subscriptions --------------------------------------------------------------

    def _qos_for(self, topic: str) -> QoSProfile:
        if topic in self._latched:
            return QoSProfile(
                depth=RELIABLE_DEPTH,
                reliability=ReliabilityPolicy.RELIABLE,
                durability=DurabilityPolicy.TRANSIENT_LOCAL,
            )
        if topic in BEST_EFFORT_TOPICS:
            return QoSProfile(depth=BEST_EFFORT_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT)
        return QoSProfile(depth=RELIABLE_DEPTH, reliability=ReliabilityPolicy.RELIABLE)

    def capture(self, topic: str) -> list[bytes]:
        """Also keep ``topic``'s raw messages for the caller, recording or not; returns the
        list they are appended to (read it, do not change it)."""
        with self._lock:
            kept: list[bytes] = []
            self._captures[topic] = kept
            return kept

    def release(self, topic: str) -> list[bytes]:
        """Stop keeping ``topic``'s messages; the ones kept since ``capture``."""
        with self._lock:
            return self._captures.pop(topic, [])

    def _stream_callback(self, topic: str) -> Callable[[bytes], None]:
        lock = self._lock

        def record(raw: bytes) -> None:
            with lock:
                if self._queue is not None:
                    self._queue.append((topic, time.time_ns(), raw))
                kept = self._captures.get(topic)
                if kept is not None:
                    kept.append(raw)

        return record

    def _latched_callback(self, topic: str) -> Callable[[bytes], None]:
        lock = self._lock

        def record(raw: bytes) -> None:
            with lock:
                self._latest[topic] = raw
                if self._queue is not None:
                    self._queue.append((topic, time.time_ns(), raw))

        return record

    def _offered_qos(self, topic: str) -> list[Any]:
        """The QoS its publishers offer (else the one asked for), as rosbags profiles."""
        infos = self._node.get_publishers_info_by_topic(topic)
        requested = self._requested[topic]
        for info in infos:
            offered = info.qos_profile
            if (
                requested.durability == DurabilityPolicy.TRANSIENT_LOCAL
                and offered.durability != DurabilityPolicy.TRANSIENT_LOCAL
            ):
                self._node.get_logger().warning(
                    f"{info.node_name} publishes {topic} without transient-local durability:"
                    " the recorder's latched subscription does not receive it"
                )
        return [_rosbags_qos(info.qos_profile) for info in infos] or [_rosbags_qos(requested)]


def _message_class(msgtype: str) -> type:
    """The Python class of ``pkg/msg/Type``."""
    package, _, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def _rosbags_qos(profile: QoSProfile) -> Any:
    """An rclpy QoS profile as a rosbags ``Qos`` (same enum values: both are rmw's)."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    def span(duration: Any) -> QosTime:
        return QosTime(*divmod(int(duration.nanoseconds), 1_000_000_000))

    return Qos(
        QosHistory(int(profile.history)),
        int(profile.depth),
        QosReliability(int(profile.reliability)),
        QosDurability(int(profile.durability)),
        span(profile.deadline),
        span(profile.lifespan),
        QosLiveliness(int(profile.liveliness)),
        span(profile.liveliness_lease_duration),
        bool(profile.avoid_ros_namespace_conventions),
    )
