"""Record exploration runs as rosbag2 directories (MCAP) from raw subscriptions.

``Recorder(node)`` subscribes to every topic of ``RUN_TOPICS`` with ``raw=True`` (messages
stay CDR bytes, never re-encoded): the latched topics (``LATCHED_TOPICS``) and the other
reliable ones at once; each high-rate stream (``BEST_EFFORT_TOPICS``: ``/clock``,
``/ft_sensor/wrench``, ``/joint_states``, ...) as soon as a publisher of it is seen, with
the QoS its publishers offer (reliable when all of them are, as ros2_control's
broadcasters publish; else best effort), as ``ros2 bag record`` adapts its QoS. A
reliable stream is repaired by DDS when its transport drops a message (a starved
process), as long as the publisher still holds it; the queue is ``STREAM_DEPTH`` deep
(``STREAM_RATE`` x ``WORST_STALL``). Subscribing before any run means discovery is done
when a run starts. ``start(bag_dir)`` begins a recording, ``stop()`` ends it::

    recorder = Recorder(node)       # in the node's __init__
    recorder.start(Path("bags") / run_id)
    ...
    counts = recorder.stop()        # messages written per topic

Callbacks take no lock: they append ``(topic, receive time, bytes)`` to a deque (atomic
in CPython). One pump thread moves them on: into a ``com_core.bags.writer.CrashSafeBagWriter``
while recording (so the executor thread never waits on I/O and a run that dies leaves a bag
readable up to ~0.1 s before the end), else into the pre-roll, the last ``PREROLL``
stream messages. A recording starts with the last message of each latched topic, then the
pre-roll, so that a window a run opens at once is whole in the bag though its first
samples were on their way when the recording started. DDS's message-lost events on the
streams (a message its transport dropped and could not repair) are counted per topic and
written to metadata.yaml's ``custom_data`` (``RECORDER_LOST_KEY``); the pose labels are
guarded otherwise: each waits for every reader's acknowledgement.

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
import json
import threading
import time
from collections import deque
from collections.abc import Callable, Collection, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import rclpy.node
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from com_core.bags.reader import RECORDER_LOST_KEY
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import (
    BEST_EFFORT_TOPICS,
    LATCHED_TOPICS,
)
from com_core.contract import TOPIC_TYPES as RUN_TOPICS
from com_estimator.stream_qos import stream_qos, subscribe_adapted

__all__ = ["RUN_TOPICS", "Recorder"]

RELIABLE_DEPTH = 100
PREROLL = 2000  # stream messages before a start that go into the bag: ~0.5 s at 4 kHz
FLUSH_INTERVAL = 0.1  # s: the most a crash loses
STREAM_WAIT = 5.0  # s (wall) a start waits for an awaited stream's first message
PUMP_TIMEOUT = 20.0  # s (wall) a start or stop waits for the pump (a stop writes a backlog)
_IDLE_WAIT = 0.01  # s the pump sleeps when nothing came

Item = tuple[str, int, bytes]  # topic, log time ns, CDR bytes


class Recorder:
    """Records ``topics`` of ``node`` to one bag directory per run; see module.
    (The sequencer runs it in a process of its own: ``recorder_process``.)"""

    def __init__(
        self,
        node: rclpy.node.Node,
        topics: Mapping[str, str] = RUN_TOPICS,
        latched: Collection[str] = LATCHED_TOPICS,
        on_capture: Callable[[bytes], None] | None = None,
        awaited: Collection[str] = (),
    ) -> None:
        self._node = node
        self._on_capture = on_capture  # called with each message ``capture`` keeps
        self._topics = dict(topics)
        self._latched = frozenset(latched) & self._topics.keys()
        self._incoming: deque[Item] = deque()  # callbacks -> pump
        self._commands: deque[Callable[[], None]] = deque()  # run by the pump, in order
        self._recent: deque[Item] = deque(maxlen=PREROLL)  # the pre-roll (pump only)
        self._latest: dict[str, bytes] = {}  # last message of each latched topic
        self._captures: dict[str, list[bytes]] = {}  # topic -> raw messages kept for a caller
        self._writer: CrashSafeBagWriter | None = None  # the pump's, while recording
        self._error: BaseException | None = None  # why the recording's writer stopped
        self._requested: dict[str, QoSProfile] = {}
        self._lost: dict[str, int] = {}  # messages DDS says this recording lost, per topic
        self._wake = threading.Event()
        self._heard: set[str] = set()  # the topics a message of which came
        self._awaited = tuple(awaited)  # the topics a start waits to hear
        for topic, msgtype in self._topics.items():
            if topic in BEST_EFFORT_TOPICS:  # the streams: as their publishers offer
                events = SubscriptionEventCallbacks(message_lost=self._lost_callback(topic))
                subscribe_adapted(
                    node,
                    _message_class(msgtype),
                    topic,
                    self._stream_callback(topic),
                    on_subscribed=partial(self._requested.__setitem__, topic),
                    raw=True,
                    event_callbacks=events,
                )
                continue
            self._requested[topic] = qos = self._qos_for(topic)
            callback = (
                self._latched_callback(topic)
                if topic in self._latched
                else self._stream_callback(topic)
            )
            node.create_subscription(_message_class(msgtype), topic, callback, qos, raw=True)
        threading.Thread(target=self._pump, name="recorder pump", daemon=True).start()

    @property
    def recording(self) -> bool:
        return self._writer is not None

    @property
    def path(self) -> Path | None:
        """The bag directory being recorded, or None."""
        writer = self._writer
        return writer.path if writer is not None else None

    @property
    def lost(self) -> dict[str, int]:
        """Messages per topic that DDS reported lost (its message-lost events) since the
        recording started: never received, so not in the bag."""
        return {topic: n for topic, n in self._lost.items() if n}

    @property
    def failure(self) -> str:
        """Why the recording's writer stopped ('' while it writes), e.g. a full disk."""
        return "" if self._error is None else f"recording to {self.path} stopped: {self._error}"

    def start(self, bag_dir: Path) -> None:
        """Begin recording to ``bag_dir`` (which must not exist), once each ``awaited``
        topic is heard (``STREAM_WAIT`` s at most: a stream's subscription is made when
        this process discovers its publisher, and any subscription is matched some time
        after its publisher's)."""
        if self._writer is not None:
            raise RuntimeError(f"already recording to {self._writer.path}")
        bag_dir = Path(bag_dir)
        if bag_dir.exists():
            raise FileExistsError(f"{bag_dir} exists already, not overwriting")
        self._wait_for_streams()  # then their publishers' QoS is known too
        writer = CrashSafeBagWriter(
            bag_dir,
            self._topics,
            offered_qos={topic: self._offered_qos(topic) for topic in self._topics},
            flush_interval=FLUSH_INTERVAL,
        )
        writer.open()

        def begin() -> None:  # first the latched messages, then the pre-roll
            self._lost, self._error = {}, None
            start_ns = self._recent[0][1] if self._recent else time.time_ns()
            items = [(t, start_ns, self._latest[t]) for t in self._topics if t in self._latest]
            self._writer = writer
            self._write([*items, *self._recent])
            self._recent.clear()

        self._run(begin)
        self._node.get_logger().info(f"recording {len(self._topics)} topics to {bag_dir}")

    def _wait_for_streams(self) -> None:
        """Wait until each ``awaited`` topic has delivered a message (a latched one's
        latest counts); log the ones that did not within ``STREAM_WAIT`` s."""
        deadline = time.monotonic() + STREAM_WAIT
        while True:
            silent = [t for t in self._awaited if t not in self._heard]
            if not silent:
                return
            if time.monotonic() > deadline:
                self._node.get_logger().warning(
                    f"recording without a message yet of {', '.join(silent)} (none heard "
                    f"within {STREAM_WAIT:g} s)"
                )
                return
            time.sleep(0.02)

    def stop(self) -> dict[str, int]:
        """Finish the recording (every message received before the call, then flush,
        close, final metadata.yaml with the messages lost per topic); messages written
        per topic. RuntimeError when the writer failed (the bag holds what it wrote)."""
        writer = self._writer
        if writer is None:
            raise RuntimeError("not recording")

        def end() -> None:
            self._drain()
            self._writer = None

        self._run(end)
        error = self._error
        writer.custom_data[RECORDER_LOST_KEY] = json.dumps(self.lost)
        try:
            counts = writer.close()
        except Exception as exc:
            error = error or exc
            counts = writer.counts
        if error is not None:
            raise RuntimeError(f"recording to {writer.path} failed: {error}") from error
        self._node.get_logger().info(f"recorded {sum(counts.values())} messages to {writer.path}")
        return counts

    def capture(self, topic: str) -> list[bytes]:
        """Also keep ``topic``'s raw messages for the caller, recording or not; returns the
        list they are appended to (read it, do not change it)."""
        kept: list[bytes] = []
        self._captures[topic] = kept
        return kept

    def release(self, topic: str) -> list[bytes]:
        """Stop keeping ``topic``'s messages; the ones kept since ``capture``."""
        return self._captures.pop(topic, [])

    # --- the pump -----------------------------------------------------------------------

    def _run(self, command: Callable[[], None]) -> None:
        """Run ``command`` on the pump thread, after the messages already received; what
        it raises is raised here."""
        done = threading.Event()
        raised: list[BaseException] = []

        def run() -> None:
            try:
                command()
            except BaseException as exc:
                raised.append(exc)
            finally:
                done.set()

        self._commands.append(run)
        self._wake.set()
        if not done.wait(timeout=PUMP_TIMEOUT):
            raise RuntimeError(f"the recorder's pump did not answer in {PUMP_TIMEOUT:g} s")
        if raised:
            raise raised[0]

    def _pump(self) -> None:
        incoming, commands = self._incoming, self._commands
        while True:
            if commands:
                self._drain()
                commands.popleft()()
            elif incoming:
                self._drain()
            else:
                writer = self._writer
                if writer is not None and self._error is None:
                    try:
                        writer.flush(older_than=FLUSH_INTERVAL)
                    except Exception as exc:
                        self._fail(exc)
                self._wake.wait(_IDLE_WAIT)
                self._wake.clear()

    def _drain(self) -> None:
        """Every message received so far: into the bag while recording, else the pre-roll."""
        incoming = self._incoming
        items = [incoming.popleft() for _ in range(len(incoming))]
        if self._writer is None:
            self._recent.extend(item for item in items if item[0] not in self._latched)
        else:
            self._write(items)

    def _write(self, items: list[Item]) -> None:
        writer, topics = self._writer, self._topics
        if writer is None or self._error is not None:
            return  # a writer that failed writes nothing more; stop() raises its error
        try:
            for topic, stamp, raw in items:
                writer.write(topic, topics[topic], stamp, raw)
        except Exception as exc:
            self._fail(exc)

    def _fail(self, error: BaseException) -> None:
        self._error = error
        self._node.get_logger().error(f"recording to {self.path} stopped: {error!r}")

    # --- subscriptions --------------------------------------------------------------

    def _qos_for(self, topic: str) -> QoSProfile:
        """The latched topics' QoS, a stream's before its publishers are seen, or else
        reliable."""
        if topic in self._latched:
            return QoSProfile(
                depth=RELIABLE_DEPTH,
                reliability=ReliabilityPolicy.RELIABLE,
                durability=DurabilityPolicy.TRANSIENT_LOCAL,
            )
        if topic in BEST_EFFORT_TOPICS:
            return stream_qos(reliable=False)
        return QoSProfile(depth=RELIABLE_DEPTH, reliability=ReliabilityPolicy.RELIABLE)

    def _stream_callback(self, topic: str) -> Callable[[bytes], None]:
        append, captures, on_capture = self._incoming.append, self._captures, self._on_capture
        heard = self._heard

        def record(raw: bytes) -> None:
            append((topic, time.time_ns(), raw))
            heard.add(topic)
            kept = captures.get(topic)
            if kept is not None:
                kept.append(raw)
                if on_capture is not None:
                    on_capture(raw)

        return record

    def _latched_callback(self, topic: str) -> Callable[[bytes], None]:
        append, latest, heard = self._incoming.append, self._latest, self._heard

        def record(raw: bytes) -> None:
            latest[topic] = raw
            append((topic, time.time_ns(), raw))
            heard.add(topic)

        return record

    def _lost_callback(self, topic: str) -> Callable[[Any], None]:
        def count(info: Any) -> None:
            if self._writer is not None:
                self._lost[topic] = self._lost.get(topic, 0) + info.total_count_change

        return count

    def _offered_qos(self, topic: str) -> list[Any]:
        """The QoS its publishers offer (else the one asked for), as rosbags profiles."""
        infos = self._node.get_publishers_info_by_topic(topic)
        requested = self._requested.get(topic) or self._qos_for(topic)
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
