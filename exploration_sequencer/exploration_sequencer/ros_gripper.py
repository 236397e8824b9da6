"""The gripper's port (``com_core.sequencing.ports.GripperPort``) over ROS: a gripper
driver's ``control_msgs/action/GripperCommand`` (``ActionGripper``, the robot
configuration's ``gripper_action``; its result is the outcome) or one Float64MultiArray
value on its command topic (``TopicGripper``, HAND_COMMAND_TOPIC; no outcome). Both publish
each command as sent on GRIPPER_SENT_TOPIC, which the bag records."""

from __future__ import annotations

from control_msgs.action import GripperCommand
from control_msgs.msg import GripperCommand as GripperCommandMsg
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Float64MultiArray

from com_core.contract import GRIPPER_SENT_TOPIC, HAND_COMMAND_TOPIC
from com_core.robot.config import RobotConfig
from com_core.sequencing.errors import RunError
from com_core.sequencing.ports import GripperOutcome, RunClock
from exploration_sequencer.action_goal import accepted_goal, succeeded_result


class TopicGripper:
    """One value on the gripper's command topic; the fingers' time is the run's plan."""

    def __init__(self, node: Node) -> None:
        self._command = node.create_publisher(Float64MultiArray, HAND_COMMAND_TOPIC, 10)
        self._sent = node.create_publisher(GripperCommandMsg, GRIPPER_SENT_TOPIC, 10)

    def command(self, position: float, max_effort: float, what: str) -> None:
        self._sent.publish(GripperCommandMsg(position=position, max_effort=max_effort))
        self._command.publish(Float64MultiArray(data=[position]))


class ActionGripper:
    """Goals to the configuration's ``gripper_action``, each awaited within ``timeout`` s
    (wall; the sequencer's ``gripper_timeout``). A goal the run stops waiting for (its
    result late, or the run cancelled) is cancelled, once accepted if it was not yet: the
    fingers do not go on after the run has given them up."""

    def __init__(self, node: Node, clock: RunClock, config: RobotConfig) -> None:
        from rclpy.action import ActionClient

        self._log, self._clock, self._name = node.get_logger(), clock, config.gripper_action
        self._client = ActionClient(node, GripperCommand, config.gripper_action)
        self._sent = node.create_publisher(GripperCommandMsg, GRIPPER_SENT_TOPIC, 10)
        self.timeout = 10.0

    def command(self, position: float, max_effort: float, what: str) -> GripperOutcome:
        command = GripperCommandMsg(position=position, max_effort=max_effort)
        self._sent.publish(command)
        doing = f"{what} the gripper (position {position:g}, max_effort {max_effort:g} N)"
        handle = accepted_goal(
            self._clock, self._client, self._name, GripperCommand.Goal(command=command), doing,
            self.timeout, "gripper_interface 'topic' commands it by topic instead",
            _cancel_once_accepted,
        )  # fmt: skip
        ended = handle.get_result_async()
        try:
            result = succeeded_result(self._clock, ended, self._name, doing, self.timeout)
        except RunError:
            if not ended.done():
                handle.cancel_goal_async()
            raise
        self._log.info(
            f"gripper {what}: at {result.position:.4f}, effort {result.effort:.1f} N"
            f"{', stalled' if result.stalled else ''}"
            f"{', reached its goal' if result.reached_goal else ''}"
        )
        return GripperOutcome(result.position, result.effort, result.stalled, result.reached_goal)


def _cancel_once_accepted(answer: Future) -> None:
    """The goal whose ``answer`` the run's cancel stopped waiting for, cancelled when the
    driver accepts it."""

    def cancel(done: Future) -> None:
        handle = done.result()
        if handle is not None and handle.accepted:
            handle.cancel_goal_async()

    answer.add_done_callback(cancel)
