"""com_core.robot.dynamics: the wrench a rigid load exerts on the sensor in motion, linear
in its 10 inertial parameters (pinocchio), against the static model at rest and against
the joint torques the same load adds to the arm (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PANDA

from com_core.robot.config import urdf_file
from com_core.robot.dynamics import inertial_parameters, load_of, sensor_regressor
from com_core.robot.model import RobotModel
from com_core.sensing.wrench_model import gravity_in_sensor

LOAD = inertial_parameters(
    0.5, [0.01, -0.02, 0.1], [[2e-3, 1e-4, 0.0], [1e-4, 3e-3, -2e-4], [0.0, -2e-4, 1e-3]]
)


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel(urdf_file(PANDA).read_text(), PANDA.sensor_frame)


def joints(panda: RobotModel, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions near home, and a fast motion's velocities and accelerations."""
    rng = np.random.default_rng(seed)
    n = len(panda.joint_names)
    home = np.array([PANDA.home_joints[i] if i < 7 else 0.0 for i in range(n)])
    return (
        home + rng.normal(0, 0.3, n) * (np.arange(n) < 7),
        rng.normal(0, 1.0, n),
        rng.normal(0, 5.0, n),
    )


def test_the_parameters_and_the_load_are_one_another(panda):
    mass, com, inertia = load_of(LOAD)
    assert mass == 0.5
    np.testing.assert_allclose(com, [0.01, -0.02, 0.1], atol=1e-15)
    np.testing.assert_allclose(inertia, [[2e-3, 1e-4, 0], [1e-4, 3e-3, -2e-4], [0, -2e-4, 1e-3]],
                               atol=1e-15)  # fmt: skip
    with pytest.raises(ValueError, match="not > 0"):
        load_of(np.zeros(10))


def test_at_rest_the_wrench_is_the_static_gravity_wrench(panda):
    q, _, _ = joints(panda, 0)
    zero = np.zeros_like(q)
    wrench = sensor_regressor(panda, q, zero, zero) @ LOAD
    g = gravity_in_sensor(panda.sensor_rotation_of(q), panda.gravity)
    mass, com, _ = load_of(LOAD)
    np.testing.assert_allclose(wrench[:3], mass * g, atol=1e-12)
    np.testing.assert_allclose(wrench[3:], np.cross(com, mass * g), atol=1e-12)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_in_motion_the_wrench_is_what_the_load_adds_to_the_joint_torques(panda, seed):
    """The load welded to the sensor's body adds J_s^T (-w_s) to the torques of RNEA (an
    independent path: the whole arm's Newton-Euler with the load in its tree)."""
    import pinocchio

    q_, v_, a_ = joints(panda, seed)
    wrench = sensor_regressor(panda, q_, v_, a_) @ LOAD
    model = panda.model.copy()
    frame = model.frames[model.getFrameId(PANDA.sensor_frame)]
    mass, com, inertia = load_of(LOAD)
    model.inertias[frame.parentJoint] += frame.placement.act(pinocchio.Inertia(mass, com, inertia))
    data = model.createData()
    q = panda._configuration(q_)
    v, a = np.zeros(model.nv), np.zeros(model.nv)
    for name, dq, ddq in zip(panda.joint_names, v_, a_, strict=True):
        at = model.idx_vs[model.getJointId(name)]
        v[at], a[at] = dq, ddq
    model.gravity.linear = panda.gravity
    with_load = pinocchio.rnea(model, data, q, v, a).copy()
    without = pinocchio.rnea(panda.model, panda.model.createData(), q, v, a)
    pinocchio.computeJointJacobians(model, data, q)
    jacobian = pinocchio.getFrameJacobian(model, data, model.getFrameId(PANDA.sensor_frame),
                                          pinocchio.ReferenceFrame.LOCAL)  # fmt: skip
    np.testing.assert_allclose(with_load - without, jacobian.T @ -wrench, atol=1e-9)
    assert np.abs(wrench - sensor_regressor(panda, q_, 0 * v_, 0 * a_) @ LOAD).max() > 0.1
