"""The arm's port (``com_core.sequencing.ports.ArmPort``) over ROS: a trajectory controller's
``control_msgs/action/FollowJointTrajectory`` (``ActionArm``, the robot configuration's
``arm_action``, with its goal tolerances; each result checked) or its JointTrajectory topic
(``TopicArm``, ARM_COMMAND_TOPIC; no result). Both publish each path as sent on
ARM_SENT_TOPIC, which the bag records (a recorder of topics does not see actions)."""

from __future__ import annotations

from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from rclpy.node import Node
from rclpy.task import Future
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from com_core.contract import ARM_COMMAND_TOPIC, ARM_SENT_TOPIC
from com_core.robot.config import RobotConfig
from com_core.sequencing.errors import RunError
from com_core.sequencing.ports import JointPath, RunClock
from exploration_sequencer.action_goal import accepted_goal, succeeded_result

GOAL_TIME = 2.0
"""s the arm's goal may take past its trajectory's end to come within its tolerance (the
goal's goal_time_tolerance)."""
ANSWER_TIMEOUT = 10.0
"""s (wall) for the action's server and its answer to a goal."""


def _duration(seconds: float) -> Duration:
    secs, nsecs = divmod(round(seconds * 1e9), 1_000_000_000)
    return Duration(sec=secs, nanosec=nsecs)


def trajectory_message(path: JointPath) -> JointTrajectory:
    """``path`` as a trajectory_msgs/JointTrajectory."""
    msg = JointTrajectory(joint_names=list(path.names), points=[
        JointTrajectoryPoint(positions=list(q), velocities=list(dq), accelerations=list(ddq),
                             time_from_start=_duration(t))
        for t, q, dq, ddq in path.points
    ])  # fmt: skip
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(path.stamp_ns, 1_000_000_000)
    return msg


class TopicArm:
    """Paths on the controller's topic (``-r`` ARM_COMMAND_TOPIC to it); no result."""

    def __init__(self, node: Node) -> None:
        self._command = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self._sent = node.create_publisher(JointTrajectory, ARM_SENT_TOPIC, 10)

    def send(self, path: JointPath, what: str) -> None:
        msg = trajectory_message(path)
        self._sent.publish(msg)
        self._command.publish(msg)

    def finished(self, wall_timeout: float) -> None:
        """Nothing to wait for: a topic has no result."""

    def forget(self) -> None:
        """Nothing kept."""


class ActionArm:
    """Paths to the configuration's ``arm_action``, with its ``goal_tolerance`` and
    ``stopped_velocity_tolerance`` for every joint and GOAL_TIME of leeway."""

    def __init__(self, node: Node, clock: RunClock, config: RobotConfig) -> None:
        from rclpy.action import ActionClient

        self._clock, self._config = clock, config
        self._client = ActionClient(node, FollowJointTrajectory, config.arm_action)
        self._sent = node.create_publisher(JointTrajectory, ARM_SENT_TOPIC, 10)
        self._running: tuple[Future, str] | None = None  # the last goal's result, its move
        self._unanswered: Future | None = None  # a goal's answer a cancel stopped waiting for

    def send(self, path: JointPath, what: str) -> None:
        msg, config = trajectory_message(path), self._config
        self._sent.publish(msg)
        goal = FollowJointTrajectory.Goal(trajectory=msg, goal_time_tolerance=_duration(GOAL_TIME))
        goal.goal_tolerance = [
            JointTolerance(name=name, position=config.goal_tolerance,
                           velocity=config.stopped_velocity_tolerance)
            for name in path.names
        ]  # fmt: skip
        handle = accepted_goal(
            self._clock, self._client, config.arm_action, goal, what, ANSWER_TIMEOUT,
            "arm_interface 'topic' commands it by topic instead", self._left_unanswered,
        )  # fmt: skip
        self._running = (handle.get_result_async(), what)

    def _left_unanswered(self, answer: Future) -> None:
        self._unanswered = answer

    def finished(self, wall_timeout: float) -> None:
        """RunError with the controller's error code and text unless the last goal
        succeeded."""
        if self._running is None:
            return
        future, what = self._running
        self._running = None
        name = self._config.arm_action
        result = succeeded_result(self._clock, future, name, what, wall_timeout)
        if result.error_code != FollowJointTrajectory.Result.SUCCESSFUL:
            raise RunError(
                f"{name} did not succeed {what} (error code {result.error_code}, "
                f"{result.error_string})"
            )

    def forget(self) -> None:
        """The last goal's result dropped. A goal whose answer a cancel stopped waiting
        for is cancelled once the controller accepts it, and its end awaited: the arm is
        held where it is before a move is planned from there (else the controller would
        start it after the arm's position was read, and refuse the next move's jump)."""
        self._running = None
        answer, self._unanswered = self._unanswered, None
        if answer is None:
            return
        name = self._config.arm_action
        try:
            self._clock.wait(answer.done, f"the answer of {name} to a cancelled goal",
                             ANSWER_TIMEOUT)  # fmt: skip
            handle = answer.result()
            if handle is not None and handle.accepted:
                ended = handle.get_result_async()
                handle.cancel_goal_async()
                self._clock.wait(ended.done, f"{name} ending a cancelled goal", ANSWER_TIMEOUT)
        except RunError:  # no answer: the way back starts from where the arm is
            pass
