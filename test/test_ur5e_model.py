"""The UR5e's URDF (com_core's config/ur5e.urdf) against Universal Robots' published data:
its forward kinematics (pinocchio) to tool0 equal the DH chain's, each link's mass and
centre of mass are UR's (given in the DH frames), its joint limits are the UR5e's, and it
carries the names of ur_description and of the Robotiq driver."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio
import pytest

from com_core.robot.config import read_robot_config, urdf_file

# UR's DH parameters of the UR5e (m, rad) and its links' dynamics (kg; m in DH frame i)
D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
A = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
MASS = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
COM = ((0.0, -0.02561, 0.00193), (0.2125, 0.0, 0.11336), (0.15, 0.0, 0.0265),
       (0.0, -0.0018, 0.01634), (0.0, 0.0018, 0.01634), (0.0, 0.0, -0.001159))  # fmt: skip
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint")  # fmt: skip
LINKS = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
         "wrist_3_link")  # fmt: skip


def dh_frames(q: np.ndarray) -> list[np.ndarray]:
    """T_base_i (4, 4) of DH frames 1..6 at joints ``q`` (rad), in UR's ``base`` frame."""
    T, out = np.eye(4), []
    for theta, d, a, alpha in zip(q, D, A, ALPHA, strict=True):
        ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
        T = T @ np.array(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
             [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]]
        )  # fmt: skip
        out.append(T)
    return out


@pytest.fixture(scope="module")
def model() -> pinocchio.Model:
    return pinocchio.buildModelFromXML(urdf_file(read_robot_config("ur5e")).read_text())


def configuration(model: pinocchio.Model, arm: np.ndarray) -> np.ndarray:
    """The pinocchio configuration with the arm at ``arm`` (rad) and the gripper open."""
    q = pinocchio.neutral(model)
    for name, value in zip(JOINTS, arm, strict=True):
        q[model.idx_qs[model.getJointId(name)]] = value
    return q


def test_the_forward_kinematics_are_the_dh_chains_at_random_joints(model):
    data = model.createData()
    rng = np.random.default_rng(5)
    for arm in rng.uniform(-2 * math.pi, 2 * math.pi, (20, 6)):
        pinocchio.framesForwardKinematics(model, data, configuration(model, arm))
        base = data.oMf[model.getFrameId("base")].homogeneous
        tool0 = np.linalg.inv(base) @ data.oMf[model.getFrameId("tool0")].homogeneous
        np.testing.assert_allclose(tool0[:3, 3], dh_frames(arm)[-1][:3, 3], rtol=0, atol=1e-9)
        np.testing.assert_allclose(tool0[:3, :3], dh_frames(arm)[-1][:3, :3], rtol=0, atol=1e-9)
        # base: base_link turned by pi about z (x backwards, as UR's controller has it)
        np.testing.assert_allclose(base[:3, :3], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)


def test_each_link_has_urs_mass_and_centre_of_mass(model):
    root = ET.parse(urdf_file(read_robot_config("ur5e"))).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
    data = model.createData()
    arm = np.random.default_rng(6).uniform(-math.pi, math.pi, 6)
    pinocchio.framesForwardKinematics(model, data, configuration(model, arm))
    base = data.oMf[model.getFrameId("base")].homogeneous
    for name, link, mass, com, T_dh in zip(JOINTS, LINKS, MASS, COM, dh_frames(arm), strict=True):
        frame = model.getFrameId(link)
        assert model.frames[frame].parentJoint == model.getJointId(name)
        inertial = links[link].find("inertial")
        assert float(inertial.find("mass").get("value")) == mass
        lever = [float(v) for v in inertial.find("origin").get("xyz").split()]
        com_world = data.oMf[frame].act(np.array(lever))
        expected = (base @ T_dh @ np.array([*com, 1.0]))[:3]
        np.testing.assert_allclose(com_world, expected, rtol=0, atol=1e-9)


def test_the_joint_limits_and_names_are_the_ur5e_and_robotiq_drivers(model):
    for name in JOINTS:
        joint = model.getJointId(name)
        at, v = model.idx_qs[joint], model.idx_vs[joint]
        assert model.lowerPositionLimit[at] == pytest.approx(-2 * math.pi)
        assert model.upperPositionLimit[at] == pytest.approx(2 * math.pi)
        assert model.velocityLimit[v] == pytest.approx(math.pi)  # 180 deg/s
        effort = 150.0 if name in JOINTS[:3] else 28.0
        assert model.effortLimit[v] == pytest.approx(effort)
    for frame in ("base_link", "base", "flange", "tool0", "robotiq_85_base_link"):
        assert model.existFrame(frame), frame
    gripper = model.getJointId("robotiq_85_left_knuckle_joint")
    at = model.idx_qs[gripper]
    assert (model.lowerPositionLimit[at], model.upperPositionLimit[at]) == (0.0, 0.8)
    config = read_robot_config("ur5e")
    assert config.gripper_joints == ("robotiq_85_left_knuckle_joint",)
    assert config.gripper_action == "/robotiq_gripper_controller/gripper_cmd"
