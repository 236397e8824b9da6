"""The sim's gripper as a control_msgs/action/GripperCommand server (the robot configuration's
``gripper_action``): open and close on nothing reach their goal; closing on the object
stalls beyond ``gripper_closed`` with the grip's effort, and the object is held; feedback
while the fingers move; a goal outside the gripper's range is rejected.
"""

from __future__ import annotations

from typing import Any

import pytest
from conftest import log_tail, spin_until

from com_core.contract import ARM_COMMAND_TOPIC, JOINT_STATES_TOPIC, OBJECT_TOPIC
from com_core.robot.config import read_robot_config

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.system

from builtin_interfaces.msg import Duration  # noqa: E402
from control_msgs.action import GripperCommand  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import String  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

PANDA = read_robot_config("panda")
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class GripperClient:
    """A node with the gripper's action client, the joint states and the object's state."""

    def __init__(self, context: Any) -> None:
        self.node = rclpy.create_node("gripper_action_test", context=context)
        self.action = ActionClient(self.node, GripperCommand, PANDA.gripper_action)
        self.joint_state: JointState | None = None  # the arm's publisher's latest
        self.fingers: JointState | None = None  # the gripper's publisher's latest
        self.objects: list[str] = []
        self.node.create_subscription(JointState, JOINT_STATES_TOPIC, self._joints, 10)
        self.node.create_subscription(String, OBJECT_TOPIC, self._object, LATCHED)
        self.arm = self.node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)

    def _joints(self, msg: JointState) -> None:
        if msg.name[0] == PANDA.arm_joints[0]:
            self.joint_state = msg
        else:
            self.fingers = msg

    def _object(self, msg: String) -> None:
        self.objects.append(msg.data)

    def send(self, position: float, max_effort: float = 20.0) -> tuple[bool, Any, list[Any]]:
        """(accepted, result or None, feedback messages) of one goal."""
        feedback: list[Any] = []
        goal = GripperCommand.Goal()
        goal.command.position, goal.command.max_effort = position, max_effort
        sent = self.action.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m))
        assert spin_until(self.node, sent.done, 10.0), "no answer to the goal"
        handle = sent.result()
        if not handle.accepted:
            return False, None, feedback
        result = handle.get_result_async()
        assert spin_until(self.node, result.done, 10.0), "no result"
        return True, result.result().result, feedback

    def move(self, goal: tuple[float, ...], duration: float = 2.0) -> None:
        zeros = [0.0] * len(goal)  # at rest: a cubic from where the arm is
        point = JointTrajectoryPoint(
            positions=list(goal), velocities=zeros, accelerations=zeros,
            time_from_start=Duration(sec=int(duration)),
        )  # fmt: skip
        self.arm.publish(JointTrajectory(joint_names=list(PANDA.arm_joints), points=[point]))

        def arrived() -> bool:
            state = self.joint_state
            return (
                state is not None
                and max(abs(p - g) for p, g in zip(state.position[:7], goal, strict=True)) < 2e-3
                and max(abs(v) for v in state.velocity[:7]) < 1e-2
            )

        assert spin_until(self.node, arrived, 20.0), f"the arm did not reach {goal}"


@pytest.mark.parametrize("grasp_mode", ["rigid", "friction"])
def test_the_gripper_action_reaches_its_goal_or_stalls_on_the_object(
    start_node, rclpy_context, grasp_mode
):
    process = start_node(
        "sim_node",
        "wrench_sim",
        {"object": "box", "seed": 1, "grasp_mode": grasp_mode, "real_time_factor": 4.0},
    )
    client = GripperClient(rclpy_context)
    try:
        up = spin_until(
            client.node,
            lambda: client.joint_state is not None and client.action.server_is_ready(),
            40.0,
        )
        assert up, f"no gripper action:\n{log_tail(process.log_path)}"
        opened, closed = PANDA.gripper_open, PANDA.gripper_closed
        tolerance = 0.02 * abs(opened - closed)

        accepted, result, _ = client.send(0.05)  # beyond the Panda's open 0.04 m
        assert not accepted
        accepted, result, _ = client.send(closed)  # at home: nothing between the pads
        assert accepted and result.reached_goal and not result.stalled, result
        assert result.position == pytest.approx(closed, abs=tolerance)
        accepted, result, feedback = client.send(opened)
        assert accepted and result.reached_goal and not result.stalled, result
        assert result.position == pytest.approx(opened, abs=tolerance)
        assert feedback, "no feedback while the fingers moved"
        assert all(not f.feedback.reached_goal for f in feedback[:-1])

        client.move(PANDA.pick_joints)
        accepted, result, _ = client.send(closed, max_effort=20.0)
        assert accepted and result.stalled and not result.reached_goal, result
        assert result.position > closed + 0.005  # the pads on the box (half width 0.025 m)
        assert result.effort > 1.0, result
        assert spin_until(client.node, lambda: "state=held" in client.objects[-1], 5.0)
        client.fingers = None
        assert spin_until(client.node, lambda: client.fingers is not None, 5.0)
        fingers = client.fingers.position
        assert tuple(client.fingers.name) == PANDA.gripper_joints
        assert min(fingers) > closed + 0.005, fingers
        assert process.poll() is None
    finally:
        client.node.destroy_node()
