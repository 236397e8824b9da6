"""The arm and its gripper, commanded as ros2_control's controllers and real grippers take
them, and timed in sim time: smooth moves to joint goals, arrival and settling, the fingers.

The arm's joints and gripper are its robot configuration's (``config``), its motion
times its choreography's (``motion``; the URDF's velocity limits). A move is a
trajectory_msgs/JointTrajectory the joint_trajectory_controller runs as planned: two points
with zero velocities and accelerations, where the arm rests now (time 0) and the goal,
which the controller joins by one quintic (when the arm is still moving, the goal alone,
which it joins by a cubic from its state); its duration follows from the joint distance
and ``speed`` (``Choreography.motion_time``). A move starts when it is sent: none is sent
while a window is open. An excitation is sent ahead, stamped to start later: its first
point is home at rest, so the arm holds still until then.

Each trajectory goes to the configuration's ``arm_action``
(control_msgs/action/FollowJointTrajectory) with the configuration's ``goal_tolerance`` and
``stopped_velocity_tolerance`` for every joint, and its result is checked; with
``arm_interface`` ``topic`` it is published on ARM_COMMAND_TOPIC instead. The arm rests at
a goal when every joint is within ``goal_tolerance`` of it and slower than
``stopped_velocity_tolerance``.

The gripper is driven as real grippers are: a control_msgs/action/GripperCommand goal to the
configuration's ``gripper_action`` (position in the units of ``gripper_open``, max_effort
N), its result awaited within ``gripper_timeout`` s (wall); or, with ``gripper_interface``
``topic``, one Float64MultiArray value on HAND_COMMAND_TOPIC and a fixed wait.

Every trajectory and gripper command goes out as sent on ARM_SENT_TOPIC and
GRIPPER_SENT_TOPIC, which the bag records (a recorder of topics does not see actions).
"""

from __future__ import annotations

from collections.abc import Mapping

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory, GripperCommand
from control_msgs.msg import GripperCommand as GripperCommandMsg
from control_msgs.msg import JointTolerance
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from com_core.contract import (
    ARM_COMMAND_TOPIC,
    ARM_SENT_TOPIC,
    GRIPPER_SENT_TOPIC,
    HAND_COMMAND_TOPIC,
)
from com_core.planning.decisions import GRIPPER_TIME
from com_core.planning.excitation import Excitation
from com_core.robot.choreography import Choreography
from com_core.robot.config import RobotConfig
from exploration_sequencer.io_node import IoNode, RunError, TimeoutRunError

GOAL_TIME = 2.0
"""s (sim) the arm's goal may take past its trajectory's end to come within its tolerance
(the goal's goal_time_tolerance)."""
ANSWER_TIMEOUT = 10.0
"""s (wall) for an action's server and its answer to a goal."""


def resting(
    joints: Mapping[str, tuple[float, float]],
    names: tuple[str, ...],
    goal: list[float],
    config: RobotConfig,
) -> bool:
    """The joints ``names`` (position rad, speed rad/s) are within ``config``'s
    goal_tolerance of ``goal`` and slower than its stopped_velocity_tolerance."""
    return all(
        abs(joints[j][0] - g) < config.goal_tolerance
        and abs(joints[j][1]) < config.stopped_velocity_tolerance
        for j, g in zip(names, goal, strict=True)
    )


def _duration(seconds: float) -> Duration:
    secs, nsecs = divmod(round(seconds * 1e9), 1_000_000_000)
    return Duration(sec=secs, nanosec=nsecs)


def _trajectory(
    names: tuple[str, ...],
    points: list[tuple[float, list[float], list[float], list[float]]],
    start_ns: int = 0,
) -> JointTrajectory:
    """The joints ``names`` through ``points`` (s from the start, positions, velocities,
    accelerations), stamped ``start_ns`` (sim time; 0: when the controller receives it)."""
    msg = JointTrajectory(joint_names=list(names), points=[
        JointTrajectoryPoint(positions=list(q), velocities=list(dq), accelerations=list(ddq),
                             time_from_start=_duration(t))
        for t, q, dq, ddq in points
    ])  # fmt: skip
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
    return msg


def move_trajectory(
    names: tuple[str, ...], start: list[float] | None, goal: list[float], duration: float
) -> JointTrajectory:
    """A rest-to-rest move of the joints ``names`` to ``goal`` (rad) in ``duration`` s: from
    ``start`` at time 0 (one quintic), or with ``start`` None the goal alone (a cubic from
    the arm's state); zero velocities and accelerations at each point."""
    rest = [0.0] * len(names)
    points = [] if start is None else [(0.0, [float(v) for v in start], rest, rest)]
    points.append((duration, [float(v) for v in goal], rest, rest))
    return _trajectory(names, points)


def excitation_trajectory(
    excitation: Excitation, names: tuple[str, ...], start_ns: int = 0
) -> JointTrajectory:
    """``excitation`` as a trajectory of the joints ``names`` from sim time ``start_ns``
    (0: when the controller receives it): its waypoints with their velocities and
    accelerations (``Excitation.waypoints``), the first at home at rest at its start (the
    arm holds still until then), the last at its end."""
    times, q, dq, ddq = excitation.waypoints(names)
    rows = zip(times, q.tolist(), dq.tolist(), ddq.tolist(), strict=True)
    return _trajectory(names, list(rows), start_ns)


class Arm:
    """Moves the arm and the gripper of the robot configuration ``config``; ``motion``
    (the choreography), ``speed`` (rad/s, mean joint speed), ``settle`` (s to wait
    after arriving), ``arm_interface`` and the gripper's ``gripper_interface`` ('action' or
    'topic'), ``max_effort`` (N) and ``gripper_timeout`` (s, wall) are set by the
    sequencer for each run."""

    def __init__(self, node: Node, io: IoNode, config: RobotConfig) -> None:
        self._log = node.get_logger()
        self._io = io
        self._arm_pub = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self._arm_sent_pub = node.create_publisher(JointTrajectory, ARM_SENT_TOPIC, 10)
        self._hand_pub = node.create_publisher(Float64MultiArray, HAND_COMMAND_TOPIC, 10)
        self._sent_pub = node.create_publisher(GripperCommandMsg, GRIPPER_SENT_TOPIC, 10)
        self._arm_action = ActionClient(node, FollowJointTrajectory, config.arm_action)
        self._gripper_action = ActionClient(node, GripperCommand, config.gripper_action)
        self._running: tuple[Future, str] | None = None  # the arm goal's result, its move
        self.config = config
        self.motion: Choreography | None = None
        self.speed = 1.0
        self.settle = 0.3
        self.arm_interface = "action"
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
        return resting(self._io.joints, self.config.arm_joints, goal, self.config)

    def _still(self) -> bool:
        """Every arm joint is slower than the stopped_velocity_tolerance now."""
        limit = self.config.stopped_velocity_tolerance
        return all(abs(self._io.joints[j][1]) < limit for j in self.config.arm_joints)

    def move(self, goal: list[float], what: str, must_arrive: bool = True) -> int:
        """Move to ``goal`` (rad) now and wait until the arm has rested there ``settle`` s;
        returns that sim time, ns. See ``arrive`` for ``must_arrive``."""
        if self.at(goal):
            return self._io.now_ns()
        return self.arrive(goal, what, self.command(goal, what), must_arrive)

    def command(self, goal: list[float], what: str) -> int:
        """Send a smooth move to ``goal`` (rad), starting now (``move_trajectory``); returns
        the sim time (ns) at which it is planned to end."""
        names = self.config.arm_joints
        here = [self._io.joints[j][0] for j in names]
        assert self.motion is not None, "the sequencer sets the choreography before a move"
        duration = self.motion.motion_time(here, goal, self.speed)
        msg = move_trajectory(names, here if self._still() else None, goal, duration)
        now = self._io.now_ns()
        self._send(msg, f"moving to {what}")
        return now + round(duration * 1e9)

    def follow(self, excitation: Excitation, start_ns: int, what: str) -> int:
        """Send ``excitation`` (a periodic motion from home back to home; the arm rests at
        home) to start at sim time ``start_ns`` (``excitation_trajectory``); returns the
        sim time (ns) it ends. ``finished`` checks its result."""
        msg = excitation_trajectory(excitation, self.config.arm_joints, start_ns)
        self._send(msg, what)
        last = msg.points[-1].time_from_start
        return start_ns + last.sec * 1_000_000_000 + last.nanosec

    def _send(self, msg: JointTrajectory, what: str) -> None:
        """``msg`` as sent on ARM_SENT_TOPIC, then to the arm's action (accepted, its result
        kept for ``finished``) or its topic."""
        self._arm_sent_pub.publish(msg)
        if self.arm_interface == "topic":
            self._arm_pub.publish(msg)
            return
        config = self.config
        goal = FollowJointTrajectory.Goal(trajectory=msg, goal_time_tolerance=_duration(GOAL_TIME))
        goal.goal_tolerance = [
            JointTolerance(name=name, position=config.goal_tolerance,
                           velocity=config.stopped_velocity_tolerance)
            for name in config.arm_joints
        ]  # fmt: skip
        handle = self._answer(
            self._arm_action, goal, config.arm_action, what, ANSWER_TIMEOUT,
            "arm_interface 'topic' commands it by topic instead",
        )  # fmt: skip
        self._running = (handle.get_result_async(), what)

    def finished(self, wall_timeout: float) -> None:
        """Wait for the result of the arm's last goal (through the action), within
        ``wall_timeout`` s: RunError with the controller's error unless it succeeded."""
        if self._running is None:
            return
        future, what = self._running
        self._running = None
        name = self.config.arm_action
        self._io.wait(future.done, f"{what}: waiting for the result of {name}", wall_timeout)
        response = future.result()
        code = None if response is None else response.result.error_code
        if response is None or response.status != GoalStatus.STATUS_SUCCEEDED or code != 0:
            status = "no status" if response is None else f"status {response.status}"
            text = "" if response is None else f", {response.result.error_string}"
            raise RunError(f"{name} did not succeed {what} ({status}, error code {code}{text})")

    def arrive(
        self, goal: list[float], what: str, arrival_ns: int, must_arrive: bool = True
    ) -> int:
        """Wait until the arm rests at ``goal`` (and its goal succeeded: ``finished``) and
        ``settle`` s more, counted from the first joint state that shows it resting
        (however late this node notices) and no earlier than ``arrival_ns``, the move's
        planned end; returns the end of ``settle``, sim time, ns.

        The wait ends 5 s + twice the time to ``arrival_ns`` after the call (wall; a sim
        runs at least real time); then TimeoutRunError, or with ``must_arrive`` False a
        warning and the arm stays where it is.
        """
        io, config = self._io, self.config
        timeout = 5.0 + 2.0 * max(arrival_ns - io.now_ns(), 0) * 1e-9
        try:
            io.wait(lambda: self.at(goal), f"moving to {what}", timeout)
        except RunError as exc:
            if must_arrive:
                raise
            self._log.warning(f"{exc}: going on from where the arm is")
            return io.now_ns()
        target = dict(zip(config.arm_joints, goal, strict=True))

        def still(name: str, position: float, velocity: float) -> bool:
            return (abs(position - target[name]) < config.goal_tolerance
                    and abs(velocity) < config.stopped_velocity_tolerance)  # fmt: skip

        # each joint by its own joint states: a gripper's publisher does not count
        rested = io.joint_states.rested_since(config.arm_joints, still)
        if rested is None:  # moved again since the wait saw it resting
            rested = io.now_ns()
        # never before the move's planned end: a move smaller than the rest tolerance
        # looks resting at its goal before it has begun
        ready = max(rested, arrival_ns) + round(self.settle * 1e9)
        io.sleep_until(ready, f"settling at {what}")
        try:  # its result came while the arm settled: no wait on the run's path
            self.finished(timeout)
        except RunError as exc:
            if must_arrive:
                raise
            self._log.warning(f"{exc}: going on from where the arm is")
        return ready

    def come_to_rest(self, wall_timeout: float = 10.0) -> None:
        """Wait until the arm's joints are slower than the stopped_velocity_tolerance (a
        move under way ends where it was going): a new move starts from rest, as every move
        is planned."""
        self._running = None
        self._io.wait(self._still, "the arm coming to rest", wall_timeout)

    def _answer(self, client: ActionClient, goal, name: str, what: str, timeout: float,
                instead: str):  # fmt: skip
        """Send ``goal`` to the action ``name`` and return its handle once accepted;
        RunError naming the action when no server answers within ``timeout`` s (wall)
        (``instead`` says what to do) or the goal is rejected."""
        io = self._io

        def waited(done, doing: str) -> None:
            try:
                io.wait(done, f"{doing} of the action {name}", timeout)
            except TimeoutRunError as exc:
                raise RunError(
                    f"no {doing.split()[-1]} from the action {name} within {timeout:g} s while "
                    f"{what} (is the driver running? {instead})"
                ) from exc

        waited(client.server_is_ready, "waiting for the server")
        sent = client.send_goal_async(goal)
        waited(sent.done, "waiting for the answer")
        handle = sent.result()
        if handle is None or not handle.accepted:
            raise RunError(f"the action {name} rejected the goal of {what} (its log says why)")
        return handle

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
        name, timeout = self.config.gripper_action, self.gripper_timeout
        doing = f"{what} the gripper (position {command.position:g}, max_effort " \
            f"{command.max_effort:g} N)"  # fmt: skip
        handle = self._answer(
            self._gripper_action, GripperCommand.Goal(command=command), name, doing, timeout,
            "gripper_interface 'topic' commands it by topic instead",
        )  # fmt: skip
        answer = handle.get_result_async()
        try:
            self._io.wait(answer.done, f"waiting for the result of {name}", timeout)
        except TimeoutRunError as exc:
            raise RunError(f"no result from the action {name} within {timeout:g} s while "
                           f"{doing}") from exc  # fmt: skip
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
