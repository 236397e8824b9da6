"""The arm and its gripper, commanded over the ros2_control topics of the contract and
timed in sim time: smooth moves to joint goals, arrival and settling, the fingers.

A move is one ``trajectory_msgs/JointTrajectory`` point whose duration follows from the
joint distance and ``speed`` (``choreography.motion_time``); it may be stamped to start
later (the controller starts it at its header stamp), which lets a pass send each move
ahead. The arm rests at a goal when every joint is within 5 mrad of it and slower than
5 mrad/s.
"""

from __future__ import annotations

from builtin_interfaces.msg import Duration
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from com_core.contract import (
    ARM_COMMAND_TOPIC,
    ARM_JOINTS,
    FINGER_JOINTS,
    FINGER_OPEN,
    HAND_COMMAND_TOPIC,
)
from exploration_sequencer.choreography import motion_time
from exploration_sequencer.io_node import IoNode, TimeoutRunError

REST_POSITION, REST_SPEED = 5e-3, 5e-3  # rad, rad/s


def resting(joints: dict[str, tuple[float, float]], goal: list[float]) -> bool:
    """The arm's joints (position rad, speed rad/s) are within REST_POSITION of ``goal``
    and slower than REST_SPEED."""
    return all(
        abs(joints[j][0] - g) < REST_POSITION and abs(joints[j][1]) < REST_SPEED
        for j, g in zip(ARM_JOINTS, goal, strict=True)
    )


class Arm:
    """Moves the arm and the fingers; ``speed`` (rad/s, mean joint speed) and ``settle``
    (s to wait after arriving) are set by the sequencer for each run."""

    def __init__(self, node: Node, io: IoNode) -> None:
        self._log = node.get_logger()
        self._io = io
        self._arm_pub = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self._hand_pub = node.create_publisher(Float64MultiArray, HAND_COMMAND_TOPIC, 10)
        self.speed = 1.0
        self.settle = 0.3

    def finger_opening(self) -> float:
        """The smaller opening of the two fingers, m (FINGER_OPEN when not reported)."""
        return min(self._io.joints.get(j, (FINGER_OPEN, 0.0))[0] for j in FINGER_JOINTS)

    def at(self, goal: list[float]) -> bool:
        """The arm rests at ``goal`` now."""
        return resting(self._io.joints, goal)

    def move(self, goal: list[float], what: str, must_arrive: bool = True) -> int:
        """Move to ``goal`` (rad) now and wait until the arm has rested there ``settle`` s;
        returns that sim time, ns. See ``arrive`` for ``must_arrive``."""
        if self.at(goal):
            return self._io.now_ns()
        return self.arrive(goal, what, self.command(goal), must_arrive)

    def command(self, goal: list[float], start_ns: int = 0) -> int:
        """Send a smooth move to ``goal`` (rad) starting at sim time ``start_ns`` (0: when
        the controller receives it); returns the sim time (ns) at which it ends."""
        start = [self._io.joints[j][0] for j in ARM_JOINTS]
        duration = round(motion_time(start, goal, self.speed) * 1e9)
        secs, nsecs = divmod(duration, 1_000_000_000)
        point = JointTrajectoryPoint(
            positions=[float(v) for v in goal], time_from_start=Duration(sec=secs, nanosec=nsecs)
        )
        msg = JointTrajectory(joint_names=list(ARM_JOINTS), points=[point])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
        self._arm_pub.publish(msg)
        return max(start_ns, self._io.now_ns()) + duration

    def arrive(
        self, goal: list[float], what: str, arrival_ns: int, must_arrive: bool = True
    ) -> int:
        """Wait until the arm rests at ``goal`` and ``settle`` s more, counted from the
        first joint state that shows it resting (however late this node notices); returns
        the end of ``settle``, sim time, ns.

        The wait ends 5 s + twice the time to ``arrival_ns`` after the call (wall; a sim
        runs at least real time); then TimeoutRunError, or with ``must_arrive`` False a
        warning and the arm stays where it is.
        """
        io = self._io
        timeout = 5.0 + 2.0 * max(arrival_ns - io.now_ns(), 0) * 1e-9
        try:
            io.wait(lambda: self.at(goal), f"moving to {what}", timeout)
        except TimeoutRunError as exc:
            if must_arrive:
                raise
            self._log.warning(f"{exc}: going on from where the arm is")
            return io.now_ns()
        rested = io.now_ns()
        for stamp, joints in reversed(tuple(io.joint_history)):  # tuple(): one C call
            if not resting(joints, goal):
                break
            rested = stamp
        ready = rested + round(self.settle * 1e9)
        io.sleep_until(ready, f"settling at {what}")
        return ready

    def gripper(self, opening: float, wait: float = 0.0) -> None:
        """Move each finger to ``opening`` m and wait ``wait`` s (sim)."""
        self._hand_pub.publish(Float64MultiArray(data=[opening]))
        self._io.sleep_until(self._io.now_ns() + round(wait * 1e9), "moving the fingers")

    def put_back(self, home: list[float], pick: list[float]) -> None:
        """Carry what the hand holds home, down to the stand, open, and back home."""
        self.move(home, "home")
        self.move(pick, "the stand", must_arrive=False)  # a shifted object may hit it
        self.gripper(FINGER_OPEN, wait=0.6)
        self.move(home, "home")
