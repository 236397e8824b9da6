"""The robot configuration's URDF as the sim loads it: read, checked against the
configuration, and in ``rigid`` grasp mode with the gripper fixed open.

The load on the sensor is every link beyond the fixed joint whose child link is the
configuration's ``sensor_frame``. In ``rigid`` mode every movable joint beyond it becomes a
fixed joint of a generated copy of the URDF, at its open position: the gripper joints at
``gripper_open``, a mimic joint at multiplier * position + offset of the joint it mimics,
others at 0.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace

import numpy as np
import pinocchio
from numpy.typing import NDArray

from com_core.robot.config import (
    RobotConfig,
    RobotConfigError,
    grasp_point,
    robot_problems,
    urdf_file,
)
from com_core.robot.model import KinematicsError, RobotModel

__all__ = [
    "CheckedUrdf",
    "checked_urdf",
    "fix_joint",
    "fix_open",
    "joints_beyond",
    "open_positions",
    "read_urdf",
]

_MOVABLE = ("revolute", "continuous", "prismatic")


@dataclass
class CheckedUrdf:
    """A URDF checked against its robot configuration.

    Attributes
    ----------
    root : the URDF's root element, mesh paths absolute.
    grasp : m, ``ft_sensor``; the grasp centre (``com_core.robot.config.grasp_point``).
    sensor_joint : the fixed joint whose child link is the configuration's ``sensor_frame``.
    beyond : every joint beyond it, parents before children.
    """

    root: ET.Element
    grasp: NDArray[np.float64]
    sensor_joint: ET.Element
    beyond: list[ET.Element]


def checked_urdf(robot: RobotConfig, home: NDArray[np.float64], rigid: bool) -> CheckedUrdf:
    """The configuration's URDF, checked against it: its frames and joints, ``home`` (rad) and
    pick within the joint limits, the sensor's joint fixed with no arm joint beyond it, and
    unless ``rigid`` two prismatic fingers. Raises RobotConfigError naming what does not serve."""
    root = read_urdf(robot)
    try:
        model = RobotModel(ET.tostring(root, encoding="unicode"), robot.sensor_frame)
        problems = robot_problems(replace(robot, home_joints=tuple(home.tolist())), model)
    except KinematicsError as error:
        problems = [str(error)]
    if problems:
        raise RobotConfigError(f"robot {robot.robot} ({robot.urdf}): {'; '.join(problems)}")
    grasp = grasp_point(robot, model)
    sensor_joint, beyond = joints_beyond(root, robot.sensor_frame)
    if sensor_joint.get("type") != "fixed":
        raise RobotConfigError(
            f"robot {robot.robot}: the joint before sensor_frame {robot.sensor_frame!r} "
            f"({sensor_joint.get('name')}) is {sensor_joint.get('type')}: the "
            "sensor reads a fixed joint"
        )
    if beyond_arm := set(robot.arm_joints) & {j.get("name") for j in beyond}:
        raise RobotConfigError(
            f"robot {robot.robot}: arm_joints {', '.join(sorted(beyond_arm))} lie beyond "
            f"sensor_frame {robot.sensor_frame!r}"
        )
    if not rigid:
        types = {j.get("name"): j.get("type") for j in beyond}
        fingers = [types.get(name) for name in robot.gripper_joints]
        if fingers != ["prismatic", "prismatic"]:
            raise RobotConfigError(
                f"grasp_mode 'friction' needs two prismatic finger joints (the Panda's "
                f"hand); robot {robot.robot} has gripper_joints "
                f"{', '.join(robot.gripper_joints)}: use grasp_mode 'rigid'"
            )
    return CheckedUrdf(root, grasp, sensor_joint, beyond)


def fix_open(urdf: CheckedUrdf, robot: RobotConfig) -> None:
    """Make every movable joint beyond the sensor a fixed joint at its open position
    (``open_positions``; others at 0), in place."""
    positions = open_positions(urdf.beyond, robot)
    for joint in urdf.beyond:
        if joint.get("type") in _MOVABLE:
            fix_joint(joint, positions.get(joint.get("name"), 0.0))


def read_urdf(robot: RobotConfig) -> ET.Element:
    """The root element of the configuration's URDF (``robot_config.urdf_file``), its mesh
    files made absolute: ``package://<path>`` and relative paths are taken from the URDF's
    directory, where pybullet looks for them."""
    path = urdf_file(robot)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as error:
        raise RobotConfigError(f"urdf {robot.urdf!r}: cannot read it ({error})") from error
    directory = os.path.dirname(os.path.abspath(path))
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "").removeprefix("package://")
        if filename and not os.path.isabs(filename) and "://" not in filename:
            mesh.set("filename", os.path.join(directory, filename))
    return root


def joints_beyond(root: ET.Element, sensor_frame: str) -> tuple[ET.Element, list[ET.Element]]:
    """The joint whose child link is ``sensor_frame`` (the sensor's) and every joint beyond
    it, parents before children."""
    children: dict[str, list[ET.Element]] = {}
    sensor = None
    for joint in root.iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:  # a transmission's joint reference
            continue
        children.setdefault(parent.get("link", ""), []).append(joint)
        if child.get("link") == sensor_frame:
            sensor = joint
    if sensor is None:
        raise RobotConfigError(
            f"sensor_frame {sensor_frame!r} is no joint's child link in the URDF"
        )
    beyond, links = [], [sensor_frame]
    while links:
        for joint in children.get(links.pop(), []):
            beyond.append(joint)
            links.append(joint.find("child").get("link"))
    return sensor, beyond


def open_positions(joints: list[ET.Element], robot: RobotConfig) -> dict[str, float]:
    """Positions (rad, m) of the open gripper by joint name: the gripper joints at
    ``gripper_open``, a mimic joint at multiplier * position + offset of the one it mimics."""
    positions = {
        joint.get("name"): robot.gripper_open
        for joint in joints
        if joint.get("name") in robot.gripper_joints
    }
    for joint in joints:
        mimic = joint.find("mimic")
        if mimic is not None and joint.get("name") not in positions:
            source = positions.get(mimic.get("joint"), 0.0)
            positions[joint.get("name")] = float(mimic.get("multiplier", 1.0)) * source + float(
                mimic.get("offset", 0.0)
            )
    return positions


def fix_joint(joint: ET.Element, position: float) -> None:
    """Make a movable joint a fixed joint at ``position`` (rad or m): its origin moves by the
    joint's motion at that position (along or about its axis, given in the joint's frame)."""
    origin = joint.find("origin")
    if origin is None:
        origin = ET.SubElement(joint, "origin")
    axis_element = joint.find("axis")
    axis = _numbers(axis_element.get("xyz") if axis_element is not None else None, (1.0, 0, 0))
    axis /= np.linalg.norm(axis)
    rotation = pinocchio.rpy.rpyToMatrix(*_numbers(origin.get("rpy"), (0.0, 0, 0)))
    if joint.get("type") == "prismatic":
        xyz = _numbers(origin.get("xyz"), (0.0, 0, 0)) + rotation @ axis * position
        origin.set("xyz", " ".join(repr(float(v)) for v in xyz))
    else:
        rotation = rotation @ pinocchio.exp3(axis * position)
        origin.set("rpy", " ".join(repr(float(v)) for v in pinocchio.rpy.matrixToRpy(rotation)))
    joint.set("type", "fixed")
    for tag in ("axis", "limit", "dynamics", "mimic", "calibration", "safety_controller"):
        for element in joint.findall(tag):
            joint.remove(element)


def _numbers(text: str | None, default: tuple[float, ...]) -> NDArray[np.float64]:
    return np.array([float(v) for v in text.split()] if text else default, dtype=np.float64)
