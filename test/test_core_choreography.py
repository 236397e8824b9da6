"""com_core.robot.choreography on every arm of the robot configurations (the Panda and
the xArm6 of pybullet_data, the UR5e of com_core's config): the joints of each pose of a
plan, checked by forward kinematics of their own (the sensor's orientation and the grasp
centre), poses out of reach, a configuration the URDF does not serve, and the motion time
between poses against the URDF's velocity limits and the sim's own trajectories."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import choreography

from com_core.planning.planner import Plan
from com_core.robot.choreography import (
    MAX_PIVOT_SHIFT,
    QUINTIC_ACCELERATION,
    QUINTIC_PEAK,
    VERIFY_AXIS,
    VERIFY_TILT,
    Choreography,
    PoseUnreachable,
)
from com_core.robot.config import ROBOTS, RobotConfigError, read_robot_config, urdf_file
from com_core.robot.model import RobotModel
from com_core.sensing.wrench_model import rotation_about
from wrench_sim.trajectory import JointLimits, trajectory_from_command

TILT = 0.4
ORIENTATION_TOLERANCE = 1e-4  # rad
REACHES_EVERY_TILT = {"ur5e"}
"""Arms whose joints turn +-2 pi: every tilt the plans allow (below pi/2) is within reach
about both axes."""


def urdf_of(robot: str) -> str:
    """The URDF text of a shipped configuration's ``urdf`` file."""
    return urdf_file(read_robot_config(robot)).read_text()


@pytest.fixture(scope="module", params=ROBOTS)
def arm(request: pytest.FixtureRequest) -> tuple[str, Choreography]:
    return request.param, choreography(request.param)


def placement(arm: tuple[str, Choreography], joints: list[float]) -> tuple[np.ndarray, ...]:
    """(R_base_sensor, the grasp centre in the base frame, m) at arm ``joints``, from a
    robot model of its own."""
    name, motion = arm
    config = read_robot_config(name)
    robot = RobotModel(urdf_of(name), config.sensor_frame, config.base_frame)
    q = dict(zip(motion.arm_joints, joints, strict=True)) | motion.others
    T_base_sensor = np.linalg.inv(robot.frame_in_sensor(config.base_frame, q))
    return T_base_sensor[:3, :3], T_base_sensor[:3, :3] @ motion.pivot + T_base_sensor[:3, 3]


def angle_between(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """rad of the rotation R_a^T R_b."""
    return math.acos(np.clip((np.trace(R_a.T @ R_b) - 1.0) / 2.0, -1.0, 1.0))


def test_each_pose_turns_the_sensor_by_the_plans_rotation_about_the_grasp_centre(arm):
    motion = arm[1]
    plan = Plan(tilt=TILT)
    poses = motion.pose_joints(plan)
    assert [name for name, _ in poses] == ["home", "tilt_y+", "tilt_y-", "tilt_x-", "tilt_x+"]
    assert poses[0][1] == list(motion.home)
    R_home, pivot_home = placement(arm, poses[0][1])
    rotations = dict(plan.poses())
    for name, joints in poses:
        R, pivot = placement(arm, joints)
        angle = angle_between(R_home @ rotations[name], R)
        assert angle < ORIENTATION_TOLERANCE, (name, angle)
        assert np.linalg.norm(pivot - pivot_home) < MAX_PIVOT_SHIFT, name
        limits = motion.robot.joint_limits()
        for joint, value in zip(motion.arm_joints, joints, strict=True):
            assert limits[joint][0] <= value <= limits[joint][1], (name, joint)


def test_gravity_at_each_pose_is_the_plans(arm):
    """The plan's gravity directions (R_rel^T g_home) are what the joints give."""
    motion = arm[1]
    g = motion.robot.gravity_in_sensor(motion.home_positions())
    plan = Plan(tilt=TILT, gravity_home=tuple(g / np.linalg.norm(g)))
    planned = dict(zip([n for n, _ in plan.poses()], plan.gravity_directions(), strict=True))
    for name, joints in motion.pose_joints(plan):
        q = dict(zip(motion.arm_joints, joints, strict=True)) | motion.others
        g_pose = motion.robot.gravity_in_sensor(q)
        np.testing.assert_allclose(g_pose / np.linalg.norm(g_pose), planned[name], atol=2e-4)


def test_the_papers_single_tilt_and_the_verification_pose(arm):
    motion = arm[1]
    poses = motion.pose_joints(Plan(tilt=0.3, axes=("x",), both_directions=False))
    assert [name for name, _ in poses] == ["home", "tilt_x+"]
    joints, reason = motion.verify_joints()
    assert joints is not None, reason
    R_home, _ = placement(arm, list(motion.home))
    R, _ = placement(arm, joints)
    turn = rotation_about(np.array(VERIFY_AXIS), VERIFY_TILT)
    assert angle_between(R_home @ turn, R) < ORIENTATION_TOLERANCE


def test_a_tilt_beyond_reach_is_refused_with_the_largest_the_arm_reaches(arm):
    """A tilt of 1.5 rad about each axis: where it is out of reach, the refusal names the
    pose and a reason, and its largest tilt is reached while 0.01 rad more is not."""
    name, motion = arm
    refused = 0
    for axis in ("x", "y"):
        plan = Plan(tilt=1.5, axes=(axis,))
        try:
            motion.pose_joints(plan)
        except PoseUnreachable as exc:
            refused += 1
            assert exc.pose.startswith(f"tilt_{axis}") and exc.reason
            assert f"{exc.largest:.3f} rad" in str(exc)
            assert 0.0 < exc.largest < 1.5
            smaller = Plan(tilt=exc.largest, axes=(axis,))
            assert len(motion.pose_joints(smaller)) == 3
            with pytest.raises(PoseUnreachable):
                motion.pose_joints(Plan(tilt=exc.largest + 0.01, axes=(axis,)))
    if name in REACHES_EVERY_TILT:
        assert refused == 0
    else:  # a limit below 1.5 rad about one of its axes
        assert refused >= 1


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_configuration_the_urdf_does_not_serve_names_what(robot):
    config = read_robot_config(robot)
    urdf = urdf_of(robot)
    for change, named in (
        ({"sensor_frame": "ft_link"}, "sensor_frame 'ft_link' is not a frame"),
        ({"grasp_frame": "tcp"}, "grasp_frame 'tcp' is not a frame"),
        ({"arm_joints": (*config.arm_joints[:-1], "wrist_3")}, "no joint 'wrist_3'"),
    ):
        values = config.parameters() | change
        with pytest.raises(RobotConfigError, match=named):
            Choreography.of(type(config).from_parameters(values), urdf)
    home = list(config.home_joints)
    lower, _, _ = RobotModel(urdf, config.sensor_frame).joint_limits()[config.arm_joints[1]]
    home[1] = lower - 0.1
    values = config.parameters() | {"home_joints": home}
    with pytest.raises(RobotConfigError, match=f"home_joints: {config.arm_joints[1]} = "):
        Choreography.of(type(config).from_parameters(values), urdf)


def test_motion_time_is_the_slowest_joint_at_its_urdf_cap_with_a_floor():
    motion = choreography("panda")
    limits = motion.velocity_limits()
    assert limits == [2.175] * 4 + [2.61] * 3  # the URDF's
    home = np.array(motion.home)
    assert motion.motion_time(home, home) == 0.4  # no motion: the floor
    assert motion.motion_time(home, home, floor=0.1) == 0.1
    wrist = home.copy()
    wrist[5] += 1.0  # joint 6: limit 2.61 / 1.875 = 1.392 rad/s > speed: speed binds
    assert motion.motion_time(home, wrist) == pytest.approx(1.0 / 1.35)
    shoulder = home.copy()
    shoulder[0] -= 1.0  # joint 1: limit 2.175 / 1.875 = 1.16 rad/s < speed: the limit binds
    assert motion.motion_time(home, shoulder) == pytest.approx(1.0 * 1.875 / 2.175)
    both = wrist.copy()
    both[0] -= 1.0
    assert motion.motion_time(home, both) == pytest.approx(1.0 * 1.875 / 2.175)  # the slowest
    assert motion.motion_time(home, wrist, speed=0.5) == pytest.approx(2.0)
    assert motion.motion_time(wrist, home) == motion.motion_time(home, wrist)  # either way
    elbow = home.copy()
    elbow[1] += 0.3  # joint 2, 7.5 rad/s^2 the arm's own: its quintic's peak acceleration binds
    assert motion.motion_time(home, elbow) == pytest.approx(math.sqrt(QUINTIC_ACCELERATION
                                                                      * 0.3 / 7.5))  # fmt: skip
    assert motion.motion_time(home, elbow) > max(0.4, 0.3 * 1.875 / 2.175)
    unstated = dataclasses.replace(motion, acceleration_limits=())
    assert unstated.motion_time(home, elbow) == 0.4  # an arm that states none: the floor
    with pytest.raises(ValueError):
        motion.motion_time(home[:6], home)  # one joint short


def test_a_motion_of_motion_time_is_one_the_sim_accepts_and_no_faster(arm):
    """The quintic's peak is 1.875x its mean speed (15/8): a move of ``motion_time`` keeps
    every joint under its URDF limit, and the same move 10 % faster does not, when the
    limit binds (speed above limit / 1.875); the arm's own acceleration limits left out
    (they make a move slower still: ``test_motion_time_is_the_slowest_joint_...``)."""
    motion = dataclasses.replace(arm[1], acceleration_limits=())
    assert QUINTIC_PEAK == 15 / 8
    rng = np.random.default_rng(4)
    home = np.array(motion.home)
    n = len(home)
    velocity = np.array(motion.velocity_limits())
    limits = JointLimits(motion.arm_joints, np.full(n, -10.0), np.full(n, 10.0), velocity)
    still, rest = (home, np.zeros(n)), [np.zeros(n)] * 2

    def move(goal, duration):  # two points at rest: one quintic
        return trajectory_from_command(motion.arm_joints, [0.0, duration], [home, goal],
                                       limits, 0.0, 0.0, still, rest, rest)  # fmt: skip

    for _ in range(20):
        goal = home + rng.uniform(-1.5, 1.5, n)
        duration = motion.motion_time(home, goal, speed=10.0)  # every joint at its cap
        peak = move(goal, duration).peak_speed()
        slowest = int(np.argmax(np.abs(goal - home) / velocity))
        assert peak[slowest] == pytest.approx(velocity[slowest], rel=2e-3)
        with pytest.raises(ValueError, match="velocity limit"):
            move(goal, 0.9 * duration)
