"""The sequencer's I/O node: joint states, the estimator's statuses and the sim clock, on a
node of their own (``exploration_sequencer_io``) spun apart from the service node, so a
running exploration never stalls them; the run recorder (a process of its own,
``recorder_process``); and the waits of a run.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable, Mapping

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
from com_core.robot.joint_states import JointStates
from com_core.runtime.rosenv import topic_remaps
from com_core.sequencing.errors import CancelledRunError, RunError, TimeoutRunError
from exploration_sequencer.recorder_process import RecorderProcess

_NEVER = -(2**62)


class IoNode(Node):
    """High-rate inputs: joint states, the estimator's answers, the sim clock, recording.

    ``joint_states`` merges /joint_states per joint from any number of publishers (the
    arm's, a gripper's), each joint's last 2 s by its own stamps; a message that names
    one of ``arm_joints`` (any message while it is empty) says the arm answers.
    ``sim_timeout`` (s, wall) is how long ``wait`` goes without /joint_states before it
    says the simulator stopped answering. ``cancel``, once set, makes every ``wait``
    raise ``CancelledRunError``. ``live`` holds the values of the estimator's latest live
    status (the estimate so far), {} before one.
    """

    def __init__(self) -> None:
        super().__init__("exploration_sequencer_io")
        self.sim_timeout = 5.0
        self.joints_wall = -math.inf
        # each joint's latest state, its means over a window, and when the arm came to rest
        self.joint_states = JointStates(keep=2.0)
        self.arm_joints: frozenset[str] = frozenset()
        self.diagnostics: list = []
        self.estimator_latest = _NEVER  # ns: the latest wrench the estimator has heard
        self.estimator_label = _NEVER  # ns: stamp of the latest label it has heard
        self.cancel = threading.Event()
        self.live: dict[str, str] = {}
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.joint_state_callback, 100)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self.diagnostics_callback, 10)
        self.recorder = RecorderProcess(topic_remaps(sys.argv))  # hears what this node does

    def joint_state_callback(self, msg: JointState) -> None:
        """Merge a message of any publisher's joints; one without a position per name is
        dropped."""
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if not self.joint_states.add(stamp, msg.name, msg.position, msg.velocity):
            self.get_logger().warning(
                f"dropped a joint state of {len(msg.name)} names and {len(msg.position)} "
                "positions",
                throttle_duration_sec=10.0,
            )
            return
        if not self.arm_joints or not self.arm_joints.isdisjoint(msg.name):
            self.joints_wall = time.monotonic()

    @property
    def joints(self) -> Mapping[str, tuple[float, float]]:
        """The merged joint state: {name: (position rad or m, velocity rad/s or m/s)} of
        each joint's latest message, whichever publisher sent it; {} before one."""
        return self.joint_states.latest

    def joints_over(self, start_ns: int, end_ns: int) -> dict[str, float]:
        """Each joint's mean position (rad, m) over its own joint states stamped in
        [start_ns, end_ns) (``JointStates.mean_positions``; the last 2 s are kept)."""
        return self.joint_states.mean_positions(start_ns, end_ns)

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

    def rested_since(self, names, resting) -> int | None:
        """``JointStates.rested_since`` of the merged joint states (the JointFeed port)."""
        return self.joint_states.rested_since(names, resting)

    def sleep_until(self, stamp_ns: int, what: str) -> None:
        """Wait until sim time ``stamp_ns``."""
        self.wait(lambda: self.now_ns() >= stamp_ns, what, wall_timeout=None)
