"""The sequencer's I/O node: joint states, the estimator's statuses and the sim clock, on a
node of their own (``exploration_sequencer_io``) spun apart from the service node, so a
running exploration never stalls them; the run recorder (a process of its own,
``recorder_process``); and the waits of a run.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState

from com_core.contract import (
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    JOINT_STATES_TOPIC,
    LIVE_STATUS_NAME,
    heard_stamps,
)
from exploration_sequencer.recorder_process import RecorderProcess

_NEVER = -(2**62)


class RunError(RuntimeError):
    """An exploration cannot go on; the message says why."""


class TimeoutRunError(RunError):
    """Something the sim answers did not happen in time (e.g. the arm was blocked)."""


class RecordingError(RunError):
    """The run's recording stopped (a full or failing disk): the run goes back and ends."""


class CancelledRunError(RunError):
    """The run was cancelled (a goal's cancel, or the node stopping)."""


class IoNode(Node):
    """High-rate inputs: joint states, the estimator's answers, the sim clock, recording.

    ``sim_timeout`` (s, wall) is how long ``wait`` goes without /joint_states before it
    says the simulator stopped answering. ``cancel``, once set, makes every ``wait``
    raise ``CancelledRunError``. ``live`` holds the values of the estimator's latest live
    status (the estimate so far), {} before one.
    """

    def __init__(self) -> None:
        super().__init__("exploration_sequencer_io")
        self.sim_timeout = 5.0
        self.joints_wall = -math.inf
        # (stamp ns, {name: (position, velocity)}) of the last 2 s at 100 Hz: the latest
        # joint state, and when the arm came to rest
        self.joint_history: deque[tuple[int, dict[str, tuple[float, float]]]] = deque(maxlen=200)
        self.diagnostics: list = []
        self.estimator_latest = _NEVER  # ns: the latest wrench the estimator has heard
        self.estimator_label = _NEVER  # ns: stamp of the latest label it has heard
        self.cancel = threading.Event()
        self.live: dict[str, str] = {}
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.joint_state_callback, 100)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self.diagnostics_callback, 10)
        self.recorder = RecorderProcess()

    def joint_state_callback(self, msg: JointState) -> None:
        velocities = msg.velocity if len(msg.velocity) == len(msg.name) else [0.0] * len(msg.name)
        joints = dict(zip(msg.name, zip(msg.position, velocities, strict=True), strict=True))
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.joint_history.append((stamp, joints))
        self.joints_wall = time.monotonic()

    @property
    def joints(self) -> dict[str, tuple[float, float]]:
        """The latest joint state: {name: (position rad or m, velocity)}; {} before one."""
        return self.joint_history[-1][1] if self.joint_history else {}

    def joints_over(self, start_ns: int, end_ns: int) -> dict[str, float]:
        """``mean_joint_positions`` of the history (its last 2 s) over [start_ns, end_ns)."""
        return mean_joint_positions(self.joint_history, start_ns, end_ns)

    def diagnostics_callback(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            heard = heard_stamps(status)
            if heard is not None:
                self.estimator_latest, label = heard
                self.estimator_label = _NEVER if label is None else label
            if status.name == LIVE_STATUS_NAME:
                self.live = {kv.key: kv.value for kv in status.values}
            if status.name == DIAGNOSTIC_NAME:
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                self.diagnostics.append((stamp, status))

    def now_ns(self) -> int:
        """Sim time, ns."""
        return self.get_clock().now().nanoseconds

    def wait(self, done: Callable[[], object], what: str, wall_timeout: float | None) -> None:
        """Poll ``done`` until true; RunError when the sim stops answering (or never
        did), TimeoutRunError after ``wall_timeout`` s (None: no limit)."""
        start = time.monotonic()
        while not done():
            if self.cancel.is_set():
                raise CancelledRunError(f"cancelled while {what}")
            age = time.monotonic() - self.joints_wall
            if age > self.sim_timeout and time.monotonic() - start > self.sim_timeout:
                if math.isinf(age):
                    raise RunError(
                        f"no {JOINT_STATES_TOPIC} since this node started (is wrench_sim "
                        f"running?) while {what}"
                    )
                raise RunError(
                    f"wrench_sim stopped answering (no {JOINT_STATES_TOPIC} for {age:.1f} s) "
                    f"while {what}"
                )
            if wall_timeout is not None and time.monotonic() - start > wall_timeout:
                raise TimeoutRunError(f"timed out after {wall_timeout:g} s while {what}")
            if not rclpy.ok():
                raise RunError("shutting down")
            time.sleep(0.002)

    def sleep_until(self, stamp_ns: int, what: str) -> None:
        """Wait until sim time ``stamp_ns``."""
        self.wait(lambda: self.now_ns() >= stamp_ns, what, wall_timeout=None)


def mean_joint_positions(
    history: Iterable[tuple[int, dict[str, tuple[float, float]]]], start_ns: int, end_ns: int
) -> dict[str, float]:
    """The mean joint positions (rad, m) of the joint states (stamp ns, {name: (position,
    velocity)}) stamped in [start_ns, end_ns): a window's own, not a reading taken after
    it, when the next move may have begun; the latest joint state's if none is inside."""
    states = list(history)
    inside = [joints for stamp, joints in states if start_ns <= stamp < end_ns]
    if not inside:
        return {name: q for name, (q, _) in states[-1][1].items()} if states else {}
    return {name: sum(j[name][0] for j in inside) / len(inside) for name in inside[-1]}
