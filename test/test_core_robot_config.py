"""com_core.robot.config: the shipped robot configurations, and files that cannot serve
refused with the file and the key named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from com_core.robot.config import (
    BAG_ROBOT_FILE,
    CONFIG_DIR,
    KEYS,
    ROBOTS,
    RobotConfig,
    RobotConfigError,
    declared_parameters,
    grasp_point,
    read_robot_config,
    robot_config_path,
    robot_problems,
    urdf_file,
    write_robot_config,
)
from com_core.robot.model import RobotModel


@pytest.mark.parametrize("robot", ROBOTS)
def test_each_shipped_configuration_serves_its_urdf(robot):
    config = read_robot_config(robot)
    assert config.robot == robot and robot_config_path(robot) == CONFIG_DIR / f"{robot}.yaml"
    model = RobotModel(urdf_file(config).read_text(), config.sensor_frame, config.base_frame)
    assert robot_problems(config, model) == []
    # the grasp centre below the sensor, between the pads, on its axis
    np.testing.assert_allclose(grasp_point(config, model)[:2], 0.0, atol=1e-12)
    assert 0.1 < grasp_point(config, model)[2] < 0.2
    # home points the sensor's z down: gravity along +z of the sensor
    home = dict(zip(config.arm_joints, config.home_joints, strict=True))
    others = {name: 0.0 for name in model.joint_names if name not in home}
    gravity = model.gravity_in_sensor(home | others)
    np.testing.assert_allclose(gravity / np.linalg.norm(gravity), [0, 0, 1], atol=1e-3)
    # the parameters round trip
    assert RobotConfig.from_parameters(config.parameters()) == config
    assert list(config.parameters()) == list(KEYS)


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_file_beside_a_bag_reads_back_to_the_same_configuration(tmp_path, robot):
    config = read_robot_config(robot)
    write_robot_config(config, tmp_path / BAG_ROBOT_FILE)
    assert read_robot_config(str(tmp_path / BAG_ROBOT_FILE)) == config


def write(tmp_path: Path, values: dict) -> Path:
    path = tmp_path / "arm.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": values}}))
    return path


def test_files_that_cannot_serve_are_refused_naming_the_file_and_the_key(tmp_path):
    values = read_robot_config("xarm6").parameters()
    cases = [
        ({k: v for k, v in values.items() if k != "grasp_frame"}, "missing key.*grasp_frame"),
        (values | {"home_joints": [0.0] * 5}, "home_joints must be 6 finite numbers"),
        (values | {"pick_joints": [0.0] * 5 + [float("nan")]}, "pick_joints must be 6"),
        (values | {"sensor_frame": ""}, "sensor_frame must be a non-empty string"),
        (values | {"gripper_closed": 0.0}, "gripper_open and gripper_closed must differ"),
        (values | {"arm_joints": []}, "arm_joints must be a non-empty list"),
        (values | {"gripper_joints": "drive_joint"}, "gripper_joints must be a list"),
        (values | {"gripper_joints": ["joint6"]}, "joint6 in both arm_joints and gripper_"),
        (values | {"arm_joints": ["joint1"] * 6}, "arm_joints names a joint twice"),
        (values | {"joint_state_rate": 0.0}, r"joint_state_rate must be in \(0, 1000\] Hz"),
        (values | {"joint_state_rate": 2000.0}, "joint_state_rate must be in"),
        (values | {"max_joint_acceleration": [10.0] * 7}, "max_joint_acceleration must be 6"),
        (values | {"max_joint_acceleration": [10.0] * 5 + [0.0]}, "must be 6 numbers > 0"),
    ]
    for changed, named in cases:
        path = write(tmp_path, changed)
        with pytest.raises(RobotConfigError, match=named) as error:
            read_robot_config(str(path))
        assert str(path) in str(error.value)
    older = write(tmp_path, {k: v for k, v in values.items() if k != "joint_state_rate"})
    assert read_robot_config(str(older)).joint_state_rate == 100.0  # optional: its default
    path = tmp_path / "plain.yaml"
    path.write_text(yaml.safe_dump(values))  # not a ROS 2 parameters file
    with pytest.raises(RobotConfigError, match="ros__parameters"):
        read_robot_config(str(path))
    with pytest.raises(RobotConfigError, match=f"known robots: {', '.join(ROBOTS)}$"):
        read_robot_config("ur10e")


def test_a_grasp_frame_that_moves_relative_to_the_sensor_is_refused():
    config = read_robot_config("panda")
    model = RobotModel(urdf_file(config).read_text(), config.sensor_frame, config.base_frame)
    finger = RobotConfig.from_parameters(config.parameters() | {"grasp_frame": "panda_leftfinger"})
    assert robot_problems(finger, model) == [
        "grasp_frame 'panda_leftfinger' moves relative to sensor_frame 'panda_hand' (a joint "
        "between them): the grasp centre must be rigid"
    ]


def test_a_home_outside_the_joint_limits_is_named_with_the_limits():
    config = read_robot_config("xarm6")
    model = RobotModel(urdf_file(config).read_text(), config.sensor_frame, config.base_frame)
    home = list(config.home_joints)
    home[2] = 0.5  # joint3's upper limit is 0.19198 rad
    bad = RobotConfig.from_parameters(config.parameters() | {"home_joints": home})
    assert robot_problems(bad, model) == [
        "home_joints: joint3 = 0.5000 rad is outside its limits [-3.9270, 0.1920]"
    ]


def test_an_arm_states_its_own_acceleration_limits_or_none():
    """Franka's arms state their joints' acceleration limits (the FCI's tables); UR and
    UFACTORY publish none, and the nodes declare the key empty, so that no arm's file
    without it inherits the Panda's."""
    assert read_robot_config("panda").max_joint_acceleration == (15, 7.5, 10, 12.5, 15, 20, 20)
    assert read_robot_config("fr3").max_joint_acceleration == (10.0,) * 7
    assert read_robot_config("ur5e").max_joint_acceleration == ()
    assert read_robot_config("xarm6").max_joint_acceleration == ()
    declared = declared_parameters()
    assert declared["max_joint_acceleration"] == []
    assert declared | {"max_joint_acceleration": [15, 7.5, 10, 12.5, 15, 20, 20]} == (
        read_robot_config("panda").parameters()
    )
