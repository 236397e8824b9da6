"""A wrench estimated from the joint torques, not read by a wrist sensor: what an arm
without one gives as its external wrench (a Franka Research 3's ``K_F_ext_hat_K``), with
the error its dynamic model adds (``wrench_sim.sensor`` then adds the noise, the bias's
drift and the arm's modes of the profile).

Such an arm measures each joint's torque tau_J (link-side torque sensors) and takes off
what its model says its own links need; what is left, mapped through the Jacobian J(q)
of the sensor frame, is the external wrench:

    tau_ext^ = tau_J - tau_model(q, dq, ddq),     F^ = (J(q)^T)^+ tau_ext^

The model is not this arm's own: Franka's is one dynamic model for every arm, not
identified per robot (franka_ros issue 404), and its torque sensors have offsets. So

    F^ = F + (J(q)^T)^+ (Y(q, dq, ddq) dpi + tau_0)

with Y the arm's joint torque regressor (pinocchio's ``computeJointTorqueRegressor``),
dpi the error of its links' inertial parameters (each of the 10 of every arm link off by
N(0, ``link_model_error``^2) times its own magnitude) and tau_0 each joint's torque offset
(N(0, ``joint_torque_offset``^2) N m), both drawn from the serial's stream: one arm's, the
same in every run. The error depends on the configuration: an offset that moves from pose
to pose at rest (franka_ros issue 404 reports some 2 N and 0.5 N m with nothing held),
more while the arm accelerates (libfranka's documentation says as much) and where J is
ill-conditioned. The accelerations are the measured velocities' backward difference
between readings, as an observer would see them.

Frames and units: F (6,) force then torque, N and N m, in ``ft_sensor`` (the
configuration's ``sensor_frame``) about its origin; q rad, dq rad/s, t s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from com_core.robot.model import RobotModel
from com_core.sensing.sensor_profiles import SensorProfile

if TYPE_CHECKING:
    from wrench_sim.physics import ArmWorld

__all__ = ["JointTorqueEstimate", "profile_joint_torques", "wrench_in"]

_MAX_STEP = 0.1  # s: readings further apart give no acceleration (the stream restarted)


class JointTorqueEstimate:
    """The error of a wrench estimated from the joint torques (module), reading by reading:
    ``error(t, q, dq)`` of the arm joints ``arm_joints`` of the URDF ``urdf``."""

    def __init__(
        self,
        urdf: str,
        sensor_frame: str,
        arm_joints: Sequence[str],
        link_model_error: float,
        joint_torque_offset: float,
        rng: np.random.Generator,
    ) -> None:
        import pinocchio

        self._pin = pinocchio
        robot = RobotModel(urdf, sensor_frame)
        self._model, self._data = robot.model, robot.data
        model = self._model
        ids = [model.getJointId(name) for name in arm_joints]
        self._v = np.array([model.idx_vs[j] for j in ids])
        self._q_at = np.array([model.idx_qs[j] for j in ids])
        self._sensor = model.getFrameId(sensor_frame)
        self._q0 = pinocchio.neutral(model)  # the fingers and any other joint at 0
        self.parameter_error = np.zeros(10 * (model.njoints - 1))
        for j in ids:
            pi = model.inertias[j].toDynamicParameters()
            noise = rng.standard_normal(10)
            self.parameter_error[10 * (j - 1) : 10 * j] = link_model_error * np.abs(pi) * noise
        self.torque_offset = joint_torque_offset * rng.standard_normal(len(ids))
        self._last: tuple[float, NDArray[np.float64]] | None = None

    def error(self, t: float, q: Sequence[float], dq: Sequence[float]) -> NDArray[np.float64]:
        """F^ - F (6,) at sim time ``t`` with the arm joints at ``q``, moving at ``dq``."""
        pin, model, data = self._pin, self._model, self._data
        velocity = np.asarray(dq, dtype=np.float64)
        acceleration = np.zeros_like(velocity)
        if self._last is not None and 0.0 < t - self._last[0] <= _MAX_STEP:
            acceleration = (velocity - self._last[1]) / (t - self._last[0])
        self._last = (t, velocity)
        x = self._q0.copy()
        x[self._q_at] = q
        v, a = np.zeros(model.nv), np.zeros(model.nv)
        v[self._v], a[self._v] = velocity, acceleration
        regressor = pin.computeJointTorqueRegressor(model, data, x, v, a)
        torque = (regressor @ self.parameter_error)[self._v] + self.torque_offset
        jacobian = pin.computeFrameJacobian(model, data, x, self._sensor, pin.LOCAL)[:, self._v]
        return np.linalg.lstsq(jacobian.T, torque, rcond=None)[0]


def profile_joint_torques(
    profile: SensorProfile, world: ArmWorld, rng: np.random.Generator
) -> JointTorqueEstimate | None:
    """``profile``'s model error of the wrench ``world``'s arm estimates from its joint
    torques, drawn from ``rng`` (the serial's stream); None for a wrist sensor (both
    parts 0)."""
    p = profile
    if not p.joint_torque_estimate:
        return None
    robot = world.config.robot
    return JointTorqueEstimate(
        world.urdf_text, robot.sensor_frame, robot.arm_joints, p.link_model_error,
        p.joint_torque_offset, rng,
    )  # fmt: skip


def wrench_in(world: ArmWorld, estimate: JointTorqueEstimate | None) -> NDArray[np.float64]:
    """What the sensor's stage takes now (6,; N, N m, ``ft_sensor``): the load's true
    wrench, plus ``estimate``'s error when the arm estimates it from its joint torques."""
    if estimate is None:
        return world.wrench
    return world.wrench + estimate.error(world.time, *world.arm_motion())
