"""com_core.robot.inverse_kinematics on two arms of pybullet_data: the Panda (7 joints, sensor
frame ``panda_hand``) and the xArm6 (6 joints, sensor frame ``xarm_gripper_base_link``,
the flange). Solutions are checked by forward kinematics of their own (pinocchio on a
fresh model data): the sensor frame's orientation relative to home and the pivot's
position."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pinocchio
import pybullet_data
import pytest

from com_core.robot.config import read_robot_config
from com_core.robot.inverse_kinematics import IkResult, largest_reachable_tilt, solve_pose
from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.wrench_model import STANDARD_GRAVITY, rotation_about

DATA = Path(pybullet_data.getDataPath())
PIVOT = (0.0, 0.0, 0.1)  # m in the sensor frame: a grasped object's centre below the flange
ORIENTATION_TOLERANCE = 1e-4  # rad
POSITION_TOLERANCE = 1e-3  # m

HOME_JOINTS = read_robot_config("panda").home_joints
PANDA_HOME = {f"panda_joint{i}": q for i, q in enumerate(HOME_JOINTS, 1)} | {
    "panda_finger_joint1": 0.04,
    "panda_finger_joint2": 0.04,
}
XARM_ARM = read_robot_config("xarm6").home_joints
"""rad, joint1..joint6: the flange at (0.4, 0, 0.5) m, pointing down (its z along -world
z, its x along world x)."""
XARM_GRIPPER = (
    "drive_joint",
    "left_finger_joint",
    "left_inner_knuckle_joint",
    "right_inner_knuckle_joint",
    "right_outer_knuckle_joint",
    "right_finger_joint",
)
XARM_HOME = {f"joint{i}": q for i, q in enumerate(XARM_ARM, 1)} | dict.fromkeys(XARM_GRIPPER, 0.0)

ARMS = {
    "panda": ("franka_panda/panda.urdf", "panda_hand", PANDA_HOME),
    "xarm6": ("xarm/xarm6_with_gripper.urdf", "xarm_gripper_base_link", XARM_HOME),
}
LIMITED = {"panda": ("panda_joint6", "upper"), "xarm6": ("joint5", "lower")}
"""A joint that a positive tilt about the sensor's y turns towards this limit."""


@pytest.fixture(scope="module", params=sorted(ARMS))
def arm(request: pytest.FixtureRequest) -> tuple[str, RobotModel, dict[str, float]]:
    path, sensor, home = ARMS[request.param]
    return request.param, RobotModel((DATA / path).read_text(), sensor), home


def placement(robot: RobotModel, joints: Mapping[str, float]) -> pinocchio.SE3:
    """The sensor frame's placement in the world at ``joints``."""
    data = robot.model.createData()
    pinocchio.framesForwardKinematics(robot.model, data, robot.configuration(joints))
    return data.oMf[robot.model.getFrameId(robot.sensor_frame)]


def limits(robot: RobotModel, name: str) -> tuple[float, float]:
    at = robot.model.idx_qs[robot.model.getJointId(name)]
    return robot.model.lowerPositionLimit[at], robot.model.upperPositionLimit[at]


def angle_between(R1: np.ndarray, R2: np.ndarray) -> float:
    return float(np.linalg.norm(pinocchio.log3(R1.T @ R2)))


def check_reached(
    robot: RobotModel,
    home: Mapping[str, float],
    rotation: np.ndarray,
    result: IkResult,
    arm_joints: set[str],
) -> float:
    """Asserts that ``result`` turns the sensor by ``rotation`` (home axes) about PIVOT,
    within the joint limits, moving only ``arm_joints``; returns how far the pivot moved
    (m) by forward kinematics."""
    assert result.reachable, result.reason
    assert result.reason == ""
    start, end = placement(robot, home), placement(robot, result.joints)
    turned = angle_between(start.rotation.T @ end.rotation, rotation)
    pivot_moved = float(np.linalg.norm(end.act(np.array(PIVOT)) - start.act(np.array(PIVOT))))
    assert turned <= ORIENTATION_TOLERANCE
    assert pivot_moved <= POSITION_TOLERANCE
    assert result.orientation_error == pytest.approx(turned, abs=1e-12)
    assert result.position_error == pytest.approx(pivot_moved, abs=1e-12)
    for name, value in result.joints.items():
        lower, upper = limits(robot, name)
        assert lower <= value <= upper, name
        if name not in arm_joints:
            assert value == home[name], f"{name} moved"
    moved = [result.joints[name] - home[name] for name in sorted(arm_joints)]
    assert result.distance == pytest.approx(float(np.linalg.norm(moved)), rel=1e-12)
    return pivot_moved


def arm_joints_of(name: str) -> set[str]:
    return (
        {f"panda_joint{i}" for i in range(1, 8)}
        if name == "panda"
        else {f"joint{i}" for i in range(1, 7)}
    )


def test_the_homes_point_the_sensor_down_within_the_joint_limits(arm):
    _, robot, home = arm
    assert robot.gravity_in_sensor(home)[2] > 0.999 * STANDARD_GRAVITY
    for joint, value in home.items():
        lower, upper = limits(robot, joint)
        assert lower <= value <= upper, joint


def test_random_tilts_across_z_are_reached_holding_the_pivot(arm):
    name, robot, home = arm
    rng = np.random.default_rng(20240611)
    for _ in range(25):
        phi = rng.uniform(0.0, 2.0 * math.pi)
        tilt = rng.choice([-1.0, 1.0]) * math.radians(rng.uniform(10.0, 30.0))
        rotation = rotation_about([math.cos(phi), math.sin(phi), 0.0], tilt)
        result = solve_pose(robot, home, rotation, PIVOT)
        check_reached(robot, home, rotation, result, arm_joints_of(name))
        assert result.iterations <= 30


def test_thirty_degrees_about_x_and_y_turn_about_the_pivot_not_the_flange(arm):
    name, robot, home = arm
    start = placement(robot, home)
    for axis in ("x", "y"):
        for sign in (1.0, -1.0):
            rotation = rotation_about(axis, sign * math.pi / 6)
            result = solve_pose(robot, home, rotation, PIVOT)
            pivot_moved = check_reached(robot, home, rotation, result, arm_joints_of(name))
            # the sensor's origin swings on a circle of 0.1 m about the pivot: a chord of
            # 2 (0.1 m) sin(15 deg)
            origin_moved = np.linalg.norm(
                placement(robot, result.joints).translation - start.translation
            )
            assert origin_moved == pytest.approx(0.2 * math.sin(math.pi / 12), abs=1e-6)
            print(
                f"{name} {sign * 30:+.0f} deg about {axis}: pivot moved {pivot_moved:.2e} m, "
                f"joint-space distance {result.distance:.3f} rad, {result.iterations} iterations"
            )


def test_a_tilt_of_170_degrees_beyond_the_joint_limits_is_refused(arm):
    _, robot, home = arm
    result = solve_pose(robot, home, rotation_about("y", math.radians(170.0)), PIVOT)
    assert not result.reachable
    assert result.reason.startswith("joint limit: ")
    assert result.at_limit
    assert all(joint in result.reason for joint in result.at_limit)
    assert result.orientation_error > ORIENTATION_TOLERANCE


def test_a_tilt_pushing_a_joint_at_its_limit_further_is_refused_naming_it(arm):
    name, robot, home = arm
    joint, side = LIMITED[name]
    lower, upper = limits(robot, joint)
    at_limit = dict(home) | {joint: upper if side == "upper" else lower}
    refused = solve_pose(robot, at_limit, rotation_about("y", 0.2), PIVOT)
    assert not refused.reachable
    assert joint in refused.at_limit
    assert f"{joint} at its {side} limit" in refused.reason
    # the other way, away from the limit, is reached from the same home
    rotation = rotation_about("y", -0.2)
    reached = solve_pose(robot, at_limit, rotation, PIVOT)
    check_reached(robot, at_limit, rotation, reached, arm_joints_of(name))


def test_the_largest_reachable_tilt_is_reached_and_a_larger_one_is_not(arm):
    name, robot, home = arm
    axis = (0.0, 1.0, 0.0)
    largest = largest_reachable_tilt(robot, home, axis, PIVOT, max_tilt=math.pi)
    assert 0.5 < largest < math.pi
    rotation = rotation_about(axis, largest)
    check_reached(
        robot, home, rotation, solve_pose(robot, home, rotation, PIVOT), arm_joints_of(name)
    )
    beyond = solve_pose(robot, home, rotation_about(axis, largest + 0.01), PIVOT)
    assert not beyond.reachable
    assert beyond.reason
    # below its limit, max_tilt itself is the answer
    assert largest_reachable_tilt(robot, home, axis, PIVOT, max_tilt=0.3) == 0.3


def test_the_solution_is_the_same_to_the_bit_for_the_same_input(arm):
    name, robot, home = arm
    path, sensor, _ = ARMS[name]
    rotation = rotation_about([1.0, 2.0, 0.0], 0.4)
    first = solve_pose(robot, home, rotation, PIVOT)
    solve_pose(robot, home, rotation_about("x", -0.3), PIVOT)  # no state carries over
    robot.gravity_in_sensor(home)
    again = solve_pose(robot, home, rotation, PIVOT)
    fresh = solve_pose(RobotModel((DATA / path).read_text(), sensor), home, rotation, PIVOT)
    for other in (again, fresh):
        assert other == first
        assert [v.hex() for v in other.joints.values()] == [v.hex() for v in first.joints.values()]
        assert other.orientation_error.hex() == first.orientation_error.hex()


def test_the_panda_settles_on_the_solution_nearest_home():
    path, sensor, home = ARMS["panda"]
    robot = RobotModel((DATA / path).read_text(), sensor)
    names = [f"panda_joint{i}" for i in range(1, 8)]
    result = solve_pose(robot, home, rotation_about([1.0, 1.0, 0.0], 0.5), PIVOT)
    assert result.reachable, result.reason
    # at the nearest solution the step from home has no component along the self-motion
    # (the null space of the pose's Jacobian): the distance is stationary along it
    data = robot.model.createData()
    q = robot.configuration(result.joints)
    pinocchio.computeJointJacobians(robot.model, data, q)
    frame = robot.model.getFrameId(sensor)
    pinocchio.updateFramePlacements(robot.model, data)
    J = pinocchio.getFrameJacobian(
        robot.model, data, frame, pinocchio.ReferenceFrame.LOCAL_WORLD_ALIGNED
    )
    columns = [robot.model.idx_vs[robot.model.getJointId(n)] for n in names]
    r = data.oMf[frame].rotation @ np.array(PIVOT)
    skew_r = pinocchio.skew(r)
    A = np.vstack([J[:3, columns] - skew_r @ J[3:, columns], J[3:, columns]])
    self_motion = np.linalg.svd(A)[2][-1]
    step = np.array([result.joints[n] - home[n] for n in names])
    assert abs(self_motion @ step) < 1e-6 * np.linalg.norm(step)
    assert np.linalg.norm(step) > 0.1


def test_only_the_given_joints_move():
    path, sensor, home = ARMS["panda"]
    robot = RobotModel((DATA / path).read_text(), sensor)
    six = {f"panda_joint{i}" for i in range(1, 7)}
    rotation = rotation_about("x", 0.3)
    result = solve_pose(robot, home, rotation, PIVOT, joints=sorted(six))
    check_reached(robot, home, rotation, result, six)
    assert result.joints["panda_joint7"] == home["panda_joint7"]


def test_malformed_input_raises_a_value_error():
    path, sensor, home = ARMS["panda"]
    robot = RobotModel((DATA / path).read_text(), sensor)
    for bad in (2.0 * np.eye(3), np.diag([1.0, 1.0, -1.0]), np.eye(4), np.full((3, 3), np.nan)):
        with pytest.raises(ValueError, match="rotation_sensor"):
            solve_pose(robot, home, bad, PIVOT)
    with pytest.raises(KinematicsError, match="panda_joint8 are not joints"):
        solve_pose(robot, home, np.eye(3), PIVOT, joints=["panda_joint1", "panda_joint8"])
    with pytest.raises(KinematicsError, match=r"no position for joint\(s\) panda_joint7$"):
        solve_pose(robot, {f"panda_joint{i}": q for i, q in enumerate(HOME_JOINTS[:6], 1)})
    with pytest.raises(ValueError, match="pivot"):
        solve_pose(robot, home, np.eye(3), (0.0, 0.1))
    with pytest.raises(ValueError, match="home position of joint panda_joint4"):
        solve_pose(robot, home | {"panda_joint4": 0.1})
    with pytest.raises(ValueError, match="axis"):
        largest_reachable_tilt(robot, home, (0.0, 0.0, 0.0), PIVOT)
