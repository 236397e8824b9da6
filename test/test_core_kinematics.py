"""com_core.robot.model: gravity in the sensor frame from a URDF and joint positions, and
a clear error for a URDF, frame or joint set that cannot serve. (Against the simulated
sensor itself: test_sim_physics.py.)"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet_data
import pytest
from numpy.testing import assert_allclose

from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.wrench_model import STANDARD_GRAVITY

PANDA = (Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf").read_text()
HOME = {f"panda_joint{i}": q for i, q in enumerate([0, -0.156, 0, -2.198, 0, 2.042, 0.785], 1)}
FINGERS = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}

# one continuous joint about z, then a fixed sensor frame turned by +90 deg about x
TURNTABLE = """<robot name="turntable">
  <link name="base"/><link name="plate"/><link name="sensor"/>
  <joint name="spin" type="continuous"><parent link="base"/><child link="plate"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="mount" type="fixed"><parent link="plate"/><child link="sensor"/>
    <origin rpy="1.5707963267948966 0 0"/></joint>
</robot>"""


def test_gravity_in_a_sensor_frame_turned_about_x_and_a_continuous_joint():
    robot = RobotModel(TURNTABLE, "sensor")
    assert robot.joint_names == ("spin",)
    # the sensor's y axis is the base's z: gravity (0, 0, -g) in base reads (0, -g, 0)
    for angle in (0.0, 0.7, -2.5):
        assert_allclose(
            robot.gravity_in_sensor({"spin": angle}), [0, -STANDARD_GRAVITY, 0], atol=1e-12
        )
    # a base tilted so gravity has an x component: the spin turns it in the sensor frame
    tilted = RobotModel(TURNTABLE, "sensor", gravity=(1.0, 0.0, -9.0))
    g = tilted.gravity_in_sensor({"spin": math.pi / 2})
    # spun by pi/2 the plate's -y is the base's x, and the sensor's z is the plate's -y
    assert_allclose(g, [0.0, -9.0, 1.0], atol=1e-12)
    assert np.linalg.norm(g) == pytest.approx(math.hypot(1.0, 9.0))


def test_the_panda_at_home_has_gravity_along_the_hand_z():
    robot = RobotModel(PANDA, "panda_hand", base_frame="panda_link0")
    g = robot.gravity_in_sensor(HOME | FINGERS)
    assert g[2] > 0.99 * STANDARD_GRAVITY  # the hand points down: gravity along +z
    assert set(robot.joint_names) == set(HOME) | set(FINGERS)


def test_a_missing_frame_or_joint_is_named():
    with pytest.raises(KinematicsError, match="sensor_frame 'ft_sensor' is not a frame"):
        RobotModel(PANDA, "ft_sensor")
    with pytest.raises(KinematicsError, match="base_frame 'world'"):
        RobotModel(PANDA, "panda_hand", base_frame="world")
    robot = RobotModel(PANDA, "panda_hand")
    # the fingers, beyond the sensor, need no position (a gripper's own driver sends them)
    assert robot.chain_names == tuple(HOME) and robot.missing_joints(HOME) == []
    assert_allclose(robot.gravity_in_sensor(HOME), robot.gravity_in_sensor(HOME | FINGERS))
    arm = {k: v for k, v in HOME.items() if k != "panda_joint7"}
    assert robot.missing_joints(arm | FINGERS) == ["panda_joint7"]
    with pytest.raises(KinematicsError, match=r"no position for joint\(s\) panda_joint7$"):
        robot.gravity_in_sensor(arm)


def test_a_urdf_that_does_not_parse_gives_the_parsers_message():
    with pytest.raises(KinematicsError, match="the URDF does not parse"):
        RobotModel("<robot name='x'><link name='a'/><joint name='j'", "a")
    with pytest.raises(KinematicsError, match="finite non-zero"):
        RobotModel(TURNTABLE, "sensor", gravity=(0.0, 0.0, 0.0))
