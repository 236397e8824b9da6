"""exploration_sequencer.choreography (no ROS): the joints of each pose of a plan, and the
motion time between poses, against the Panda's limits and the sim's own trajectories."""

from __future__ import annotations

import math

import numpy as np
import pybullet
import pybullet_data
import pytest

from com_core.contract import ARM_JOINTS
from com_core.planner import Plan
from exploration_sequencer.choreography import (
    PANDA_VELOCITY_LIMITS,
    QUINTIC_PEAK,
    WRIST_TURN,
    motion_time,
    pose_joints,
)
from wrench_sim.physics import HOME_JOINTS
from wrench_sim.trajectory import JointLimits, trajectory_from_command

TILT = 0.4
J6, J7 = 5, 6  # indices of panda_joint6 (the tilt) and panda_joint7 (the wrist turn)


def test_poses_home_first_then_y_then_x_and_only_the_wrist_moves():
    home = list(HOME_JOINTS)
    poses = pose_joints(Plan(tilt=TILT), home)
    assert home == list(HOME_JOINTS)  # not modified
    assert [name for name, _ in poses] == ["home", "tilt_y+", "tilt_y-", "tilt_x-", "tilt_x+"]
    q = {name: np.array(joints) for name, joints in poses}
    assert q["home"].tolist() == home
    for name in ("tilt_y+", "tilt_y-", "tilt_x+", "tilt_x-"):
        moved = np.flatnonzero(q[name] != q["home"])
        assert set(moved) <= {J6, J7}, (name, moved)
        assert q[name][:J6].tolist() == home[:J6]  # joints 1-5 keep home
    # about y: joint 6 alone, by +-tilt
    assert q["tilt_y+"][J6] == pytest.approx(home[J6] + TILT, abs=1e-12)
    assert q["tilt_y-"][J6] == pytest.approx(home[J6] - TILT, abs=1e-12)
    assert q["tilt_y+"][J7] == q["tilt_y-"][J7] == home[J7]
    # about x: joint 7 turned by pi/2, joint 6 by +-tilt
    assert math.isclose(WRIST_TURN, math.pi / 2)
    for name, sign in (("tilt_x+", 1.0), ("tilt_x-", -1.0)):
        assert q[name][J7] == pytest.approx(home[J7] + math.pi / 2, abs=1e-12)
        assert q[name][J6] == pytest.approx(home[J6] + sign * TILT, abs=1e-12)
    # tilt_y- and tilt_x- share joint 6: between them only the wrist turns
    assert q["tilt_y-"][J6] == q["tilt_x-"][J6]


def test_the_papers_single_tilt_and_unsupported_axes():
    poses = pose_joints(Plan(tilt=0.3, axes=("x",), both_directions=False), HOME_JOINTS)
    assert [name for name, _ in poses] == ["home", "tilt_x+"]
    assert poses[1][1][J6] == pytest.approx(HOME_JOINTS[J6] + 0.3, abs=1e-12)
    with pytest.raises(ValueError, match="x and y only, not z"):
        pose_joints(Plan(axes=("y", "z")), HOME_JOINTS)


def gravity_in_sensor(client: int, robot: int, joints) -> np.ndarray:
    """Unit gravity direction in ft_sensor (panda_hand's axes) at ``joints``, by FK."""
    for j, value in enumerate(joints):
        pybullet.resetJointState(robot, j, value, physicsClientId=client)
    orientation = pybullet.getLinkState(
        robot, 8, computeForwardKinematics=True, physicsClientId=client
    )[5]
    R_world_sensor = np.array(pybullet.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    return R_world_sensor.T @ [0.0, 0.0, -1.0]


@pytest.fixture(scope="module")
def panda():
    client = pybullet.connect(pybullet.DIRECT)
    robot = pybullet.loadURDF(
        f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf",
        useFixedBase=True,
        physicsClientId=client,
    )
    assert pybullet.getJointInfo(robot, 8, physicsClientId=client)[12] == b"panda_hand"
    yield client, robot
    pybullet.disconnect(client)


def physical_and_planned(panda, axis: str) -> list[tuple[str, np.ndarray, np.ndarray]]:
    plan = Plan(tilt=TILT, gravity_home=(0.0, 0.0, 1.0))  # the sim's home: gravity along +z
    planned = dict(zip([name for name, _ in plan.poses()], plan.gravity_directions(), strict=True))
    return [
        (name, gravity_in_sensor(*panda, q), planned[name])
        for name, q in pose_joints(plan, HOME_JOINTS)
        if name == "home" or name[-2] == axis
    ]


def test_the_joints_tilt_the_sensor_by_the_tilt_about_its_own_axis(panda):
    """Forward kinematics of the Panda: home has gravity along +z of the sensor, and each
    tilt pose turns it by exactly the tilt, in the plane normal to the tilt axis."""
    for axis, normal in (("y", 1), ("x", 0)):
        for name, g, _ in physical_and_planned(panda, axis):
            assert abs(g[normal]) < 1e-6, (name, g)  # no component along the tilt axis
            angle = math.acos(np.clip(g[2], -1.0, 1.0))
            assert angle == pytest.approx(0.0 if name == "home" else TILT, abs=1e-6), name


def test_the_y_tilts_give_the_plans_gravity_directions(panda):
    for name, g, planned in physical_and_planned(panda, "y"):
        np.testing.assert_allclose(g, planned, atol=1e-6, err_msg=name)


def test_the_x_tilts_give_the_plans_gravity_directions(panda):
    for name, g, planned in physical_and_planned(panda, "x"):
        np.testing.assert_allclose(g, planned, atol=1e-6, err_msg=name)


def test_motion_time_is_the_slowest_joint_at_its_cap_with_a_floor():
    home = np.array(HOME_JOINTS)
    assert motion_time(home, home) == 0.4  # no motion: the floor
    assert motion_time(home, home, floor=0.1) == 0.1
    wrist = home.copy()
    wrist[J6] += 1.0  # joint 6: limit 2.61 / 1.875 = 1.392 rad/s > speed: speed binds
    assert motion_time(home, wrist) == pytest.approx(1.0 / 1.35)
    shoulder = home.copy()
    shoulder[0] -= 1.0  # joint 1: limit 2.175 / 1.875 = 1.16 rad/s < speed: the limit binds
    assert motion_time(home, shoulder) == pytest.approx(1.0 * 1.875 / 2.175)
    both = wrist.copy()
    both[0] -= 1.0
    assert motion_time(home, both) == pytest.approx(1.0 * 1.875 / 2.175)  # the slowest
    assert motion_time(home, wrist, speed=0.5) == pytest.approx(2.0)
    assert motion_time(wrist, home) == motion_time(home, wrist)  # either way
    with pytest.raises(ValueError):
        motion_time(home[:6], home)  # one joint short


def panda_limits() -> JointLimits:
    return JointLimits(
        ARM_JOINTS,
        np.full(7, -10.0),
        np.full(7, 10.0),
        np.array(PANDA_VELOCITY_LIMITS),
    )


def test_a_motion_of_motion_time_is_one_the_sim_accepts_and_no_faster():
    """The quintic's peak is 1.875x its mean speed (15/8): a move of ``motion_time`` keeps
    every joint under the Panda's limit, and the same move 10 % faster does not, when
    the limit binds (speed above limit / 1.875)."""
    assert QUINTIC_PEAK == 15 / 8
    rng = np.random.default_rng(4)
    home = np.array(HOME_JOINTS)
    rest = (home, np.zeros(7), np.zeros(7))
    for _ in range(20):
        goal = home + rng.uniform(-1.5, 1.5, 7)
        duration = motion_time(home, goal, speed=10.0)  # every joint at its limit's cap
        trajectory = trajectory_from_command(
            ARM_JOINTS, [duration], [goal], panda_limits(), 0.0, rest
        )
        peak = trajectory.peak_speed()
        slowest = int(np.argmax(np.abs(goal - home) / PANDA_VELOCITY_LIMITS))
        assert peak[slowest] == pytest.approx(PANDA_VELOCITY_LIMITS[slowest], rel=2e-3)
        with pytest.raises(ValueError, match="velocity limit"):
            trajectory_from_command(
                ARM_JOINTS, [0.9 * duration], [goal], panda_limits(), 0.0, rest
            )


def test_a_windows_joints_are_the_mean_of_its_own_joint_states():
    """The joint states inside the window, not the latest one: after the window's end the
    next move may have begun (a cached tare's joints give the hand's model its gravity)."""
    from exploration_sequencer.io_node import mean_joint_positions

    history = [
        (0, {"j": (1.0, 0.0)}),
        (10, {"j": (1.0, 0.0)}),
        (20, {"j": (1.2, 0.0)}),
        (30, {"j": (1.5, 2.0)}),  # the next move, after the window's end
    ]
    assert mean_joint_positions(history, 0, 30) == {"j": (1.0 + 1.0 + 1.2) / 3}
    assert mean_joint_positions(history, 40, 50) == {"j": 1.5}  # none inside: the latest
    assert mean_joint_positions([], 0, 10) == {}
