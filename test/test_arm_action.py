"""The sim's arm as a joint_trajectory_controller over ROS: the FollowJointTrajectory action
(results, tolerances, rejection in the goal callback, preemption) and a trajectory stamped
ahead on the topic moving the arm at once."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from conftest import PANDA, log_tail, spin_until

from com_core.contract import ARM_COMMAND_TOPIC, JOINT_STATES_TOPIC

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.system

from builtin_interfaces.msg import Duration  # noqa: E402
from control_msgs.action import FollowJointTrajectory  # noqa: E402
from control_msgs.msg import JointTolerance  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

Result = FollowJointTrajectory.Result


def trajectory(points: list[tuple[float, list[float]]], stamp_ns: int = 0) -> JointTrajectory:
    """The arm's joints through ``points`` (s from the stamp, positions), each at rest."""
    msg = JointTrajectory(joint_names=list(PANDA.arm_joints))
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    for t, positions in points:
        sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
        zeros = [0.0] * len(positions)
        msg.points.append(JointTrajectoryPoint(
            positions=list(positions), velocities=zeros, accelerations=zeros,
            time_from_start=Duration(sec=sec, nanosec=nanosec),
        ))  # fmt: skip
    return msg


class ArmClient:
    def __init__(self, context: Any) -> None:
        self.node = rclpy.create_node("arm_action_test", context=context)
        self.action = ActionClient(self.node, FollowJointTrajectory, PANDA.arm_action)
        self.topic = self.node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self.states: list[JointState] = []
        self.node.create_subscription(JointState, JOINT_STATES_TOPIC, self._joints, 100)

    def _joints(self, msg: JointState) -> None:
        if msg.name[0] == PANDA.arm_joints[0]:
            self.states.append(msg)

    @property
    def positions(self) -> np.ndarray:
        return np.array(self.states[-1].position)

    @property
    def now_ns(self) -> int:
        stamp = self.states[-1].header.stamp
        return stamp.sec * 1_000_000_000 + stamp.nanosec

    def send(self, goal: FollowJointTrajectory.Goal):
        """The goal's handle once answered (accepted or not)."""
        sent = self.action.send_goal_async(goal)
        assert spin_until(self.node, sent.done, 10.0), "no answer to the goal"
        return sent.result()

    def result(self, handle, timeout: float = 20.0):
        answer = handle.get_result_async()
        assert spin_until(self.node, answer.done, timeout), "no result"
        return answer.result()


@pytest.fixture
def arm(start_node, rclpy_context):
    process = start_node("sim_node", "wrench_sim", {"seed": 1, "real_time_factor": 4.0})
    client = ArmClient(rclpy_context)
    up = spin_until(client.node, lambda: client.states and client.action.server_is_ready(), 40)
    assert up, f"no arm action:\n{log_tail(process.log_path)}"
    yield process, client
    client.node.destroy_node()


def test_a_goal_succeeds_at_its_end_and_bad_goals_are_rejected_in_the_goal_callback(arm):
    process, client = arm
    home = np.array(PANDA.home_joints)
    goal_pose = home + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.4])
    goal = FollowJointTrajectory.Goal(trajectory=trajectory([(0.0, home), (1.0, goal_pose)]))
    goal.goal_tolerance = [JointTolerance(name=n, position=2e-3, velocity=1e-2)
                           for n in PANDA.arm_joints]  # fmt: skip
    goal.goal_time_tolerance = Duration(sec=2)
    start = client.now_ns
    handle = client.send(goal)
    assert handle.accepted
    answer = client.result(handle)
    assert answer.status == 4 and answer.result.error_code == Result.SUCCESSFUL, (
        answer
    )  # SUCCEEDED
    assert client.now_ns - start >= 0.99e9  # not before the trajectory's end
    assert np.abs(client.positions - goal_pose).max() < 2e-3

    beyond = goal_pose.copy()
    beyond[3] = 0.5  # panda_joint4's upper limit is -0.0698 rad
    bad = [
        trajectory([(1.0, beyond)]),
        trajectory([(0.0, home), (1.0, goal_pose)]),  # a point due now, 0.4 rad away
        trajectory([(1.0, home)], stamp_ns=1),  # ended long ago
        JointTrajectory(joint_names=list(PANDA.arm_joints)),  # no points
    ]
    for msg in bad:
        assert not client.send(FollowJointTrajectory.Goal(trajectory=msg)).accepted
    log = process.log_path.read_text()
    assert log.count("rejected trajectory goal") == len(bad), log_tail(process.log_path)
    assert "outside its limits" in log and "would jump" in log and "before it arrived" in log


def test_tolerances_abort_a_goal_and_a_new_goal_replaces_a_running_one(arm):
    _, client = arm
    here = client.positions
    away = here + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5])
    tight = FollowJointTrajectory.Goal(trajectory=trajectory([(0.0, here), (1.0, away)]))
    tight.path_tolerance = [JointTolerance(name=PANDA.arm_joints[6], position=1e-7)]
    answer = client.result(client.send(tight))
    assert answer.status == 6, answer  # ABORTED, the arm held where it was
    assert answer.result.error_code == Result.PATH_TOLERANCE_VIOLATED
    assert answer.result.error_string.startswith("path tolerance: panda_joint7 is")

    here = client.positions
    slow = client.send(FollowJointTrajectory.Goal(
        trajectory=trajectory([(0.0, here), (3.0, here + np.eye(7)[6] * 0.3)])))  # fmt: skip
    spin_until(client.node, lambda: False, 0.3)
    replacing = client.send(FollowJointTrajectory.Goal(trajectory=trajectory([(1.0, here)])))
    first = client.result(slow)
    assert first.status == 6, first  # ABORTED
    assert first.result.error_code == Result.INVALID_GOAL
    assert first.result.error_string == "replaced by a new goal"
    assert client.result(replacing).result.error_code == Result.SUCCESSFUL
    assert np.abs(client.positions - here).max() < 5e-3

    # a goal tolerance the arm cannot meet (1e-12 rad): aborted goal_time_tolerance after the end
    impossible = FollowJointTrajectory.Goal(trajectory=trajectory([(0.0, here), (1.0, here)]))
    impossible.goal_tolerance = [JointTolerance(name=PANDA.arm_joints[1], position=1e-12)]
    impossible.goal_time_tolerance = Duration(nanosec=200_000_000)
    answer = client.result(client.send(impossible))
    assert answer.result.error_code == Result.GOAL_TOLERANCE_VIOLATED, answer
    assert answer.result.error_string.startswith("goal tolerance, 0.2"), answer
    assert "panda_joint2 is" in answer.result.error_string


def test_a_trajectory_stamped_ahead_on_the_topic_moves_the_arm_at_once(arm):
    """The controller starts a trajectory when it arrives, from the state then toward its
    first point at stamp + time_from_start: the arm creeps before the stamp."""
    _, client = arm
    here = client.positions
    goal_pose = here + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3])
    stamp = client.now_ns + 2_000_000_000
    client.topic.publish(trajectory([(0.5, goal_pose)], stamp_ns=stamp))
    assert spin_until(client.node, lambda: np.abs(client.positions - here).max() > 0.01, 10.0), (
        "the arm did not move"
    )
    assert client.now_ns < stamp  # moving well before the stamp
    assert spin_until(client.node, lambda: client.now_ns > stamp + 600_000_000, 10.0)
    assert np.abs(client.positions - goal_pose).max() < 5e-3
