"""The run recorder in a process of its own, as ``ros2 bag record`` is.

A ``Recorder`` that shares its process with the sequencer shares the interpreter lock and
the CPU share with every computation of a run (inverse kinematics, the tare's noise fit,
the report): on two loaded cores its process was descheduled long enough for DDS to drop
a second of the sensor's stream before it reached the subscription. ``RecorderProcess``
runs the same ``Recorder`` on a node of its own (``exploration_sequencer_recorder``) in
a child process started with ``spawn``; the sequencer drives it through a pipe with the
same calls (``start``, ``stop``, ``capture``, ``release``)::

    recorder = RecorderProcess()          # once: subscribes at once, as Recorder does
    recorder.start(Path("bags") / run_id)
    ...
    counts = recorder.stop()              # messages written per topic
    recorder.lost                         # messages DDS reported lost, per topic
    recorder.close()                      # ends the child

The child ignores SIGINT (a terminal's Ctrl-C reaches the whole process group, and the
sequencer still records its way back after a cancel) and closes its bag and ends when
the pipe closes or its parent is gone (however the parent ended), or on SIGTERM. While a topic is
captured, ``latest_ns`` holds the newest header stamp of its messages (shared memory:
waiting on it costs the child nothing).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from com_core.contract import JOINT_STATES_TOPIC, POSE_TOPIC, WRENCH_TOPIC
from com_core.sequencing.errors import RunError

__all__ = ["RecorderProcess"]

NODE_NAME = "exploration_sequencer_recorder"
START_TIMEOUT = 60.0  # s (wall) the child has to import rclpy and subscribe
AWAITED = (WRENCH_TOPIC, JOINT_STATES_TOPIC, POSE_TOPIC)
"""What a recording of a run waits to hear before it starts: the streams its windows
need, and the sequencer's pose labels (latched: its latest, the handshake's): a label
published before the recorder's subscription matched the sequencer's would be missing."""
CALL_TIMEOUT = 30.0  # s (wall) for an answer; a stop flushes and closes the bag


class RecorderError(RunError):
    """The recorder's process refused a call, did not answer in time or is gone; the
    message says why. A RunError: the run ends by name."""


class RecorderProcess:
    """``Recorder``'s calls, answered by a child process; see module."""

    def __init__(self, remaps: list[str] | None = None) -> None:
        """``remaps``: topic remapping rules (``from:=to``) the child's subscriptions take,
        the sequencer's own (``topic_remaps``): the bag keeps the project's topic names."""
        context = multiprocessing.get_context("spawn")
        self._conn, child = context.Pipe()
        self._latest = context.Value("q", 0, lock=False)
        self._process = context.Process(
            target=_serve, args=(child, self._latest, remaps or []), name=NODE_NAME, daemon=True
        )
        self._process.start()
        child.close()
        self._lock = threading.Lock()  # one call at a time on the pipe
        self._calls = 0  # the number of the latest call
        self._path: Path | None = None
        self.lost: dict[str, int] = {}
        self._call("ready", timeout=START_TIMEOUT)

    @property
    def recording(self) -> bool:
        return self._path is not None

    @property
    def path(self) -> Path | None:
        """The bag directory being recorded, or None."""
        return self._path

    @property
    def latest_ns(self) -> int:
        """Newest header stamp (ns) of a captured topic's messages; 0 before one."""
        return int(self._latest.value)

    def start(self, bag_dir: Path) -> None:
        """Begin recording to ``bag_dir`` (which must not exist)."""
        self._call("start", Path(bag_dir))
        self._path = Path(bag_dir)
        self.lost = {}

    def stop(self) -> dict[str, int]:
        """Finish the recording; messages written per topic (``lost`` then holds the
        messages DDS reported lost). RuntimeError when the recording failed."""
        try:
            counts, self.lost = self._call("stop")
        finally:
            self._path = None
        return counts

    def capture(self, topic: str) -> None:
        """Also keep ``topic``'s raw messages until ``release``; ``latest_ns`` follows
        their stamps."""
        self._latest.value = 0
        self._call("capture", topic)

    def release(self, topic: str) -> list[bytes]:
        """Stop keeping ``topic``'s messages; the ones kept since ``capture``."""
        return self._call("release", topic)

    def failure(self) -> str:
        """Why the recording's writer stopped ('' while it writes), e.g. a full disk."""
        return self._call("failure")

    def close(self) -> None:
        """End the child (a recording still open is closed first)."""
        if self._process.is_alive():
            with contextlib.suppress(RecorderError):
                self._call("close", timeout=CALL_TIMEOUT)
            self._process.join(timeout=5.0)
            if self._process.is_alive():
                self._process.terminate()
                self._process.join(timeout=5.0)
        self._conn.close()

    def _call(self, what: str, *args: Any, timeout: float = CALL_TIMEOUT) -> Any:
        """The child's answer to ``what``; an answer to an earlier call that timed out,
        arriving late, is dropped (each call carries its number)."""
        with self._lock:
            self._calls += 1
            deadline = time.monotonic() + timeout
            try:
                self._conn.send((self._calls, what, args))
                while True:
                    if not self._conn.poll(max(deadline - time.monotonic(), 0.0)):
                        raise RecorderError(
                            f"the recorder did not answer {what!r} in {timeout:g} s"
                        )
                    number, ok, value = self._conn.recv()
                    if number == self._calls:
                        break
            except (EOFError, OSError, BrokenPipeError) as exc:
                code = self._process.exitcode
                raise RecorderError(f"the recorder's process is gone (exit code {code})") from exc
        if not ok:
            raise RecorderError(value)
        return value


def _serve(conn: Connection, latest: Any, remaps: list[str]) -> None:
    """The child: a Recorder on its own node, spun in this process's main thread; the
    pipe's calls answered by a thread of their own."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    stopping = threading.Event()
    signal.signal(signal.SIGTERM, lambda _signum, _frame: stopping.set())

    import rclpy
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    from com_core.bags.cdr import decode_header
    from com_core.runtime.rosenv import keep_dds_local
    from exploration_sequencer.recorder import Recorder

    keep_dds_local()
    rules = [arg for rule in remaps for arg in ("-r", rule)]
    rclpy.init(args=["--ros-args", *rules] if rules else [],
               signal_handler_options=SignalHandlerOptions.NO)  # fmt: skip
    node = Node(NODE_NAME)
    recorder = Recorder(
        node,
        on_capture=lambda raw: _newest(latest, decode_header(raw)[0]),
        awaited=AWAITED,
    )
    executor = EventsExecutor()
    executor.add_node(node)
    thread = threading.Thread(
        target=_answer, args=(conn, recorder, stopping), name="recorder calls", daemon=True
    )
    thread.start()
    parent = os.getppid()
    try:  # until told, or until the parent is gone (even if the call thread is stuck)
        while not stopping.is_set() and rclpy.ok() and os.getppid() == parent:
            executor.spin_once(timeout_sec=0.1)
    finally:
        if recorder.recording:
            try:
                recorder.stop()
            except RuntimeError as exc:
                node.get_logger().error(str(exc))
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


def _newest(latest: Any, stamp_ns: int) -> None:
    if stamp_ns > latest.value:
        latest.value = stamp_ns


def _answer(conn: Connection, recorder: Any, stopping: threading.Event) -> None:
    """Answer the parent's calls (number, what, args) as (number, ok, value) until it
    closes the pipe or says close."""
    try:
        while not stopping.is_set():
            number, what, args = conn.recv()
            try:
                if what == "ready":
                    value: Any = None
                elif what == "start":
                    value = recorder.start(*args)
                elif what == "stop":
                    value = (recorder.stop(), recorder.lost)
                elif what == "capture":
                    recorder.capture(*args)
                    value = None
                elif what == "release":
                    value = recorder.release(*args)
                elif what == "failure":
                    value = recorder.failure
                elif what == "close":
                    conn.send((number, True, None))
                    return
                else:
                    raise ValueError(f"no call {what!r}")
            except Exception as exc:  # answered: the parent raises it
                conn.send((number, False, str(exc)))
            else:
                conn.send((number, True, value))
    except (EOFError, OSError):
        pass  # the parent is gone
    finally:
        stopping.set()
