"""The FR3's URDF (com_core's config/fr3.urdf) against Franka's published data: its forward
kinematics (pinocchio) to the flange and to the hand's TCP equal the chain of Franka's
Craig parameters, its joint limits are the FR3's, its masses franka_description's, and it
carries franka_description's names."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio
import pytest

from com_core.robot.config import read_robot_config, urdf_file

# Franka's FR3 kinematics (Craig's convention): a (m), d (m), alpha (rad) of joints 1..7
CRAIG = ((0.0, 0.333, 0.0), (0.0, 0.0, -math.pi / 2), (0.0, 0.316, math.pi / 2),
         (0.0825, 0.0, math.pi / 2), (-0.0825, 0.384, -math.pi / 2), (0.0, 0.0, math.pi / 2),
         (0.088, 0.0, math.pi / 2))  # fmt: skip
FLANGE = 0.107  # m along joint 7's axis
TCP = 0.1034  # m from the hand, which is turned by -pi/4 about the flange's z
LIMITS = ((-2.7437, 2.7437, 2.62, 87.0), (-1.7837, 1.7837, 2.62, 87.0),
          (-2.9007, 2.9007, 2.62, 87.0), (-3.0421, -0.1518, 2.62, 87.0),
          (-2.8065, 2.8065, 5.26, 12.0), (0.5445, 4.5169, 4.18, 12.0),
          (-3.0159, 3.0159, 5.26, 12.0))  # fmt: skip
MASSES = (2.3966, 2.9274653454, 2.9355370338, 2.2449013699, 2.6155955791, 2.3271207594,
          1.8170376524, 0.6271432862)  # fmt: skip
"""kg of fr3_link0 .. fr3_link7 (franka_description)."""


def transform(rotation: np.ndarray | None = None, along: tuple[float, ...] = (0, 0, 0)):
    out = np.eye(4)
    if rotation is not None:
        out[:3, :3] = rotation
    out[:3, 3] = along
    return out


def rx(a: float) -> np.ndarray:
    return pinocchio.utils.rotate("x", a)


def rz(a: float) -> np.ndarray:
    return pinocchio.utils.rotate("z", a)


def craig_flange(q: np.ndarray) -> np.ndarray:
    """T_link0_flange (4, 4) at joints ``q`` (rad): Rx(alpha) Tx(a) Rz(q) Tz(d) per joint."""
    T = np.eye(4)
    for (a, d, alpha), theta in zip(CRAIG, q, strict=True):
        T = T @ transform(rx(alpha)) @ transform(along=(a, 0, 0))
        T = T @ transform(rz(theta)) @ transform(along=(0, 0, d))
    return T @ transform(along=(0, 0, FLANGE))


@pytest.fixture(scope="module")
def model() -> pinocchio.Model:
    return pinocchio.buildModelFromXML(urdf_file(read_robot_config("fr3")).read_text())


def test_the_forward_kinematics_are_the_craig_chains_at_random_joints(model):
    data = model.createData()
    rng = np.random.default_rng(7)
    lower, upper = np.array(LIMITS)[:, 0], np.array(LIMITS)[:, 1]
    for arm in rng.uniform(lower, upper, (20, 7)):
        q = pinocchio.neutral(model)
        for i, value in enumerate(arm, 1):
            q[model.idx_qs[model.getJointId(f"fr3_joint{i}")]] = value
        pinocchio.framesForwardKinematics(model, data, q)
        flange = craig_flange(arm)
        link8 = data.oMf[model.getFrameId("fr3_link8")].homogeneous
        np.testing.assert_allclose(link8, flange, rtol=0, atol=1e-9)
        tcp = flange @ transform(rz(-math.pi / 4)) @ transform(along=(0, 0, TCP))
        hand_tcp = data.oMf[model.getFrameId("fr3_hand_tcp")].homogeneous
        np.testing.assert_allclose(hand_tcp, tcp, rtol=0, atol=1e-9)


def test_the_joint_limits_masses_and_names_are_the_fr3s(model):
    for i, (lower, upper, velocity, effort) in enumerate(LIMITS, 1):
        joint = model.getJointId(f"fr3_joint{i}")
        at, v = model.idx_qs[joint], model.idx_vs[joint]
        assert (model.lowerPositionLimit[at], model.upperPositionLimit[at]) == (lower, upper)
        assert (model.velocityLimit[v], model.effortLimit[v]) == (velocity, effort)
    root = ET.parse(urdf_file(read_robot_config("fr3"))).getroot()
    masses = {
        link.get("name"): float(link.find("inertial/mass").get("value"))
        for link in root.iter("link")
    }
    assert [masses[f"fr3_link{i}"] for i in range(8)] == list(MASSES)
    assert (masses["fr3_hand"], masses["fr3_leftfinger"], masses["fr3_rightfinger"]) == (
        0.73,
        0.015,
        0.015,
    )  # the Franka Hand's
    for frame in ("fr3_link0", "fr3_link8", "fr3_hand", "fr3_hand_tcp"):
        assert model.existFrame(frame), frame
    for name in ("fr3_finger_joint1", "fr3_finger_joint2"):
        at = model.idx_qs[model.getJointId(name)]
        assert (model.lowerPositionLimit[at], model.upperPositionLimit[at]) == (0.0, 0.04)
    config = read_robot_config("fr3")
    assert config.gripper_joints == ("fr3_finger_joint1", "fr3_finger_joint2")
    assert config.gripper_action == "/franka_gripper/gripper_action"
    assert config.arm_action == "/fr3_arm_controller/follow_joint_trajectory"
