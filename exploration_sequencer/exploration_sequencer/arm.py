"""The arm and its gripper, commanded over the ros2_control topics of the contract and
timed in sim time: smooth moves to joint goals, arrival and settling, the fingers.

The arm's joints and gripper are its robot configuration's (``config``), its motion
times its choreography's (``motion``; the URDF's velocity limits). A move is one
``trajectory_msgs/JointTrajectory`` point whose duration follows from the joint distance
and ``speed`` (``Choreography.motion_time``); it may be stamped to start
later (the controller starts it at its header stamp), which lets a pass send each move
ahead. The arm rests at a goal when every joint is within 5 mrad of it and slower than
5 mrad/s.

The gripper is driven as real grippers are: a control_msgs/action/GripperCommand goal to the
configuration's ``gripper_action`` (position in the units of ``gripper_open``, max_effort
N), its result awaited within ``gripper_timeout`` s (wall); or, with ``gripper_interface``
``topic``, one Float64MultiArray value on HAND_COMMAND_TOPIC and a fixed wait. Either way
each command goes out as sent on GRIPPER_SENT_TOPIC, which the bag records.
"""

from __future__ import annotations

from collections.abc import Mapping

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import GripperCommand
from control_msgs.msg import GripperCommand as GripperCommandMsg
from rclpy.action import ActionClient
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from com_core.contract import ARM_COMMAND_TOPIC, GRIPPER_SENT_TOPIC, HAND_COMMAND_TOPIC
from com_core.planning.decisions import GRIPPER_TIME
from com_core.planning.excitation import Excitation
from com_core.robot.choreography import Choreography
from com_core.robot.config import RobotConfig
from exploration_sequencer.io_node import IoNode, RunError, TimeoutRunError

REST_POSITION, REST_SPEED = 5e-3, 5e-3  # rad, rad/s


def resting(
    joints: Mapping[str, tuple[float, float]], names: tuple[str, ...], goal: list[float]
) -> bool:
    """The joints ``names`` (position rad, speed rad/s) are within REST_POSITION of
    ``goal`` and slower than REST_SPEED."""
    return all(
        abs(joints[j][0] - g) < REST_POSITION and abs(joints[j][1]) < REST_SPEED
        for j, g in zip(names, goal, strict=True)
    )


def excitation_trajectory(
    excitation: Excitation, names: tuple[str, ...], start_ns: int = 0
) -> JointTrajectory:
    """``excitation`` as a trajectory of the joints ``names`` from sim time ``start_ns``
    (0: when the controller receives it): its waypoints with their velocities and
    accelerations (``Excitation.waypoints``), the last at its end."""
    times, q, dq, ddq = excitation.waypoints(names)
    points = []
    for t, *row in zip(times, q, dq, ddq, strict=True):
        secs, nsecs = divmod(round(t * 1e9), 1_000_000_000)
        points.append(JointTrajectoryPoint(
            positions=row[0].tolist(), velocities=row[1].tolist(),
            accelerations=row[2].tolist(), time_from_start=Duration(sec=secs, nanosec=nsecs),
        ))  # fmt: skip
    msg = JointTrajectory(joint_names=list(names), points=points)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
    return msg


class Arm:
    """Moves the arm and the gripper of the robot configuration ``config``; ``motion``
    (the choreography), ``speed`` (rad/s, mean joint speed), ``settle`` (s to wait
    after arriving) and the gripper's ``gripper_interface`` ('action' or 'topic'),
    ``max_effort`` (N) and ``gripper_timeout`` (s, wall) are set by the sequencer for each
    run."""

    def __init__(self, node: Node, io: IoNode, config: RobotConfig) -> None:
        self._log = node.get_logger()
        self._io = io
        self._arm_pub = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self._hand_pub = node.create_publisher(Float64MultiArray, HAND_COMMAND_TOPIC, 10)
        self._sent_pub = node.create_publisher(GripperCommandMsg, GRIPPER_SENT_TOPIC, 10)
        self._gripper_action = ActionClient(node, GripperCommand, config.gripper_action)
        self.config = config
        self.motion: Choreography | None = None
        self.speed = 1.0
        self.settle = 0.3
        self.gripper_interface = "action"
        self.max_effort = 20.0
        self.gripper_timeout = 10.0

    def gripper_closed(self) -> float:
        """How far the gripper is closed, 0 open .. 1 closed: its most closed joint (a
        joint not reported counts as open)."""
        config = self.config
        return max(
            config.gripper_closed_fraction(self._io.joints.get(j, (config.gripper_open, 0.0))[0])
            for j in config.gripper_joints
        )

    def at(self, goal: list[float]) -> bool:
        """The arm rests at ``goal`` now."""
        return resting(self._io.joints, self.config.arm_joints, goal)

    def move(self, goal: list[float], what: str, must_arrive: bool = True) -> int:
        """Move to ``goal`` (rad) now and wait until the arm has rested there ``settle`` s;
        returns that sim time, ns. See ``arrive`` for ``must_arrive``."""
        if self.at(goal):
            return self._io.now_ns()
        return self.arrive(goal, what, self.command(goal), must_arrive)

    def command(self, goal: list[float], start_ns: int = 0) -> int:
        """Send a smooth move to ``goal`` (rad) starting at sim time ``start_ns`` (0: when
        the controller receives it); returns the sim time (ns) at which it ends."""
        names = self.config.arm_joints
        start = [self._io.joints[j][0] for j in names]
        assert self.motion is not None, "the sequencer sets the choreography before a move"
        duration = round(self.motion.motion_time(start, goal, self.speed) * 1e9)
        secs, nsecs = divmod(duration, 1_000_000_000)
        point = JointTrajectoryPoint(
            positions=[float(v) for v in goal], time_from_start=Duration(sec=secs, nanosec=nsecs)
        )
        msg = JointTrajectory(joint_names=list(names), points=[point])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
        self._arm_pub.publish(msg)
        return max(start_ns, self._io.now_ns()) + duration

    def follow(self, excitation: Excitation, start_ns: int) -> int:
        """Send ``excitation`` (a periodic motion from home back to home; the arm rests at
        home) to start at sim time ``start_ns`` (``excitation_trajectory``); returns the
        sim time (ns) it ends."""
        msg = excitation_trajectory(excitation, self.config.arm_joints, start_ns)
        self._arm_pub.publish(msg)
        last = msg.points[-1].time_from_start
        return start_ns + last.sec * 1_000_000_000 + last.nanosec

    def arrive(
        self, goal: list[float], what: str, arrival_ns: int, must_arrive: bool = True
    ) -> int:
        """Wait until the arm rests at ``goal`` and ``settle`` s more, counted from the
        first joint state that shows it resting (however late this node notices) and no
        earlier than ``arrival_ns``, the move's planned end; returns the end of
        ``settle``, sim time, ns.

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
        target = dict(zip(self.config.arm_joints, goal, strict=True))

        def still(name: str, position: float, velocity: float) -> bool:
            return abs(position - target[name]) < REST_POSITION and abs(velocity) < REST_SPEED

        # each joint by its own joint states: a gripper's publisher does not count
        rested = io.joint_states.rested_since(self.config.arm_joints, still)
        if rested is None:  # moved again since the wait saw it resting
            rested = io.now_ns()
        # never before the move's planned end: a move smaller than the rest tolerance
        # looks resting at its goal before it has begun
        ready = max(rested, arrival_ns) + round(self.settle * 1e9)
        io.sleep_until(ready, f"settling at {what}")
        return ready

    def come_to_rest(self, wall_timeout: float = 10.0) -> None:
        """Wait until the arm's joints are slower than REST_SPEED (a move under way ends
        where it was going): a new move starts from rest, as every move is planned."""
        names = self.config.arm_joints
        self._io.wait(
            lambda: all(abs(self._io.joints[j][1]) < REST_SPEED for j in names),
            "the arm coming to rest",
            wall_timeout,
        )

    def gripper(self, close: bool, wait: float = 0.0) -> GripperCommand.Result | None:
        """Close (or open) the gripper; the command goes out on GRIPPER_SENT_TOPIC too.
        Through the action: until its result, which is returned (RunError naming the action
        when no server answers, the goal is rejected or does not succeed, or no result comes
        within ``gripper_timeout``), and no earlier than ``wait`` s (sim) after the command,
        the fingers' time in the run's plan. Through the topic: then ``wait`` s (sim), None."""
        position = self.config.gripper_closed if close else self.config.gripper_open
        command = GripperCommandMsg(position=float(position), max_effort=float(self.max_effort))
        self._sent_pub.publish(command)
        until = self._io.now_ns() + round(wait * 1e9)
        result = None
        if self.gripper_interface == "topic":
            self._hand_pub.publish(Float64MultiArray(data=[position]))
        else:
            result = self._gripper_goal(command, "closing" if close else "opening")
        self._io.sleep_until(until, "moving the fingers")
        return result

    def _gripper_goal(self, command: GripperCommandMsg, what: str) -> GripperCommand.Result:
        """Send ``command`` to the gripper's action and wait for its result (see
        ``gripper``)."""
        client, name, timeout = (
            self._gripper_action,
            self.config.gripper_action,
            self.gripper_timeout,
        )
        io = self._io

        def waited(done, doing: str) -> None:
            try:
                io.wait(done, f"{doing} of the gripper action {name}", timeout)
            except TimeoutRunError as exc:
                raise RunError(
                    f"no {doing.split()[-1]} from the gripper action {name} within "
                    f"{timeout:g} s while {what} the gripper (is the gripper's driver "
                    "running? gripper_interface 'topic' commands it by topic instead)"
                ) from exc

        waited(client.server_is_ready, "waiting for the server")
        sent = client.send_goal_async(GripperCommand.Goal(command=command))
        waited(sent.done, "waiting for the answer")
        handle = sent.result()
        if handle is None or not handle.accepted:
            raise RunError(
                f"the gripper action {name} rejected the goal of {what} the gripper (position "
                f"{command.position:g}, max_effort {command.max_effort:g} N)"
            )
        answer = handle.get_result_async()
        waited(answer.done, "waiting for the result")
        response = answer.result()
        if response is None or response.status != GoalStatus.STATUS_SUCCEEDED:
            status = "no status" if response is None else f"status {response.status}"
            raise RunError(
                f"the gripper action {name} did not succeed {what} the gripper ({status})"
            )
        result = response.result
        self._log.info(
            f"gripper {what}: at {result.position:.4f}, effort {result.effort:.1f} N"
            f"{', stalled' if result.stalled else ''}"
            f"{', reached its goal' if result.reached_goal else ''}"
        )
        return result

    def put_back(self, home: list[float], pick: list[float]) -> None:
        """Carry what the hand holds home, down to the stand, open, and back home."""
        self.move(home, "home")
        self.move(pick, "the stand", must_arrive=False)  # a shifted object may hit it
        self.gripper(close=False, wait=GRIPPER_TIME)
        self.move(home, "home")
