"""The robot's kinematics from its URDF (pinocchio): the sensor frame's orientation and
gravity in the sensor frame from joint positions.

``RobotModel`` parses a URDF text (what ``/robot_description`` carries), checks that the
sensor and base frames exist, and maps joint positions (rad, m; by joint name, as
``sensor_msgs/JointState`` gives them) to R_base_sensor, the sensor frame's axes in the
base frame, and to g_s = R_base_sensor^T g_base, gravity in the sensor frame (m/s^2),
the direction the wrench model's f = m g_s needs (docs/estimation.md, Conventions). Joints of
the URDF that are not given hold their neutral position only if ``neutral_ok``; else a
missing joint is an error that names it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from com_core.sensing.wrench_model import STANDARD_GRAVITY, gravity_in_sensor

__all__ = ["DEFAULT_GRAVITY", "KinematicsError", "RobotModel"]

DEFAULT_GRAVITY = (0.0, 0.0, -STANDARD_GRAVITY)
"""m/s^2 in the base frame: a base standing upright (REP-103: z up)."""


class KinematicsError(ValueError):
    """The robot model cannot serve: a URDF that does not parse, a frame it lacks, joint
    names that do not match; the message names what."""


class RobotModel:
    """Forward kinematics of one URDF from its base frame to its sensor frame.

    ``joint_names`` are every joint with a position; ``chain_names`` those of them that move
    the sensor or the base frame, which joint positions must give (a gripper's fingers beyond
    the sensor do not change its kinematics; their driver publishes them on its own).

        urdf : the URDF text. sensor_frame, base_frame : frames (links or joints) of the URDF;
        base_frame None is the URDF's root link. gravity : m/s^2 in the base frame (a tilted or
        wall-mounted base gives its own).
    """

    def __init__(
        self,
        urdf: str,
        sensor_frame: str,
        base_frame: str | None = None,
        gravity: Sequence[float] = DEFAULT_GRAVITY,
    ) -> None:
        import pinocchio

        self._pin = pinocchio
        try:
            self.model = pinocchio.buildModelFromXML(urdf)
        except (RuntimeError, ValueError) as error:
            raise KinematicsError(f"the URDF does not parse: {error}") from error
        self.data = self.model.createData()
        self.urdf_sha256 = hashlib.sha256(urdf.encode()).hexdigest()  # what the model is of
        frames = [frame.name for frame in self.model.frames]
        root = next((f.name for f in self.model.frames if f.type == pinocchio.FrameType.BODY), "")
        base_frame = base_frame or root or frames[0]  # the root link, a TF frame
        for role, name in (("sensor_frame", sensor_frame), ("base_frame", base_frame)):
            if not self.model.existFrame(name):
                raise KinematicsError(
                    f"{role} {name!r} is not a frame of the URDF (robot "
                    f"{self.model.name!r}; frames: {', '.join(frames[:40])})"
                )
        self.sensor_frame, self.base_frame = sensor_frame, base_frame
        self._sensor_id = self.model.getFrameId(sensor_frame)
        self._base_id = self.model.getFrameId(base_frame)
        self.gravity = np.asarray(gravity, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(self.gravity)) or not np.linalg.norm(self.gravity) > 0:
            raise KinematicsError(f"gravity must be a finite non-zero vector, got {gravity}")
        # joints with a configuration (universe and fixed joints have none)
        self.joint_names = tuple(
            self.model.names[j] for j in range(1, self.model.njoints) if self.model.nqs[j] > 0
        )
        # the joints that move the sensor or the base frame: what a joint state must give
        model = self.model
        chain = {j for frame in (self._sensor_id, self._base_id)
                 for j in model.supports[model.frames[frame].parentJoint]}  # fmt: skip
        self.chain_names = tuple(n for n in self.joint_names if model.getJointId(n) in chain)
        # (index in q, 1 or 2 coordinates) per joint of joint_names
        self._slots = [
            (self.model.idx_qs[jid], self.model.nqs[jid])
            for jid in map(self.model.getJointId, self.joint_names)
        ]
        # each joint's index in a velocity vector, in joint_names order
        self._velocity_index = np.array(
            [self.model.idx_vs[self.model.getJointId(name)] for name in self.joint_names]
        )

    def missing_joints(self, names: Iterable[str]) -> list[str]:
        """The joints of ``chain_names`` (those that move the sensor or the base frame)
        that ``names`` (e.g. a JointState's) lacks, in model order. The others (a gripper's
        fingers beyond the sensor) may be missing: they hold 0."""
        given = set(names)
        return [name for name in self.chain_names if name not in given]

    def configuration(self, joints: Mapping[str, float]) -> NDArray[np.float64]:
        """The pinocchio configuration q for joint positions by name (rad, m); a revolute
        joint without limits (continuous) is set by its angle as (cos, sin). Every joint of
        ``chain_names`` must be given; the others hold 0 when not."""
        missing = self.missing_joints(joints)
        if missing:
            raise KinematicsError(f"no position for joint(s) {', '.join(missing)}")
        return self._configuration([joints.get(name, 0.0) for name in self.joint_names])

    def _configuration(self, positions: Sequence[float]) -> NDArray[np.float64]:
        q = self._pin.neutral(self.model)
        for (at, nq), value in zip(self._slots, positions, strict=True):
            q[at : at + nq] = [np.cos(value), np.sin(value)] if nq == 2 else [value]
        return q

    def joint_limits(self) -> dict[str, tuple[float, float, float]]:
        """(lower, upper, velocity) of each joint of ``joint_names`` from the URDF: rad and
        rad/s (m and m/s for a prismatic joint); a continuous joint's are +-inf."""
        model, limits = self.model, {}
        for name, (at, nq) in zip(self.joint_names, self._slots, strict=True):
            velocity = float(model.velocityLimit[model.idx_vs[model.getJointId(name)]])
            if nq == 2:
                limits[name] = (-np.inf, np.inf, velocity)
            else:
                lower, upper = model.lowerPositionLimit[at], model.upperPositionLimit[at]
                limits[name] = (float(lower), float(upper), velocity)
        return limits

    def frame_in_sensor(self, frame: str, joints: Mapping[str, float]) -> NDArray[np.float64]:
        """T_sensor_frame (4, 4): ``frame``'s pose in the sensor frame (m) at these joint
        positions; joints not given hold 0."""
        if not self.model.existFrame(frame):
            raise KinematicsError(f"{frame!r} is not a frame of the URDF")
        q = self._configuration([joints.get(name, 0.0) for name in self.joint_names])
        self._pin.framesForwardKinematics(self.model, self.data, q)
        sensor = self.data.oMf[self._sensor_id]
        return (sensor.actInv(self.data.oMf[self.model.getFrameId(frame)])).homogeneous

    def sensor_rotation(self, joints: Mapping[str, float]) -> NDArray[np.float64]:
        """R_base_sensor (3, 3): the sensor frame's axes in the base frame."""
        return self._rotation_at(self.configuration(joints))

    def sensor_rotation_of(self, positions: Sequence[float]) -> NDArray[np.float64]:
        """R_base_sensor (3, 3) at joint ``positions`` in ``joint_names`` order."""
        return self._rotation_at(self._configuration(positions))

    def _rotation_at(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        pin, model, data = self._pin, self.model, self.data
        pin.framesForwardKinematics(model, data, q)
        return data.oMf[self._base_id].rotation.T @ data.oMf[self._sensor_id].rotation

    def gravity_in_sensor(self, joints: Mapping[str, float]) -> NDArray[np.float64]:
        """g_s (3,), m/s^2: gravity in the sensor frame at these joint positions
        (``wrench_model.gravity_in_sensor`` of R_base_sensor and the base's gravity)."""
        return gravity_in_sensor(self.sensor_rotation(joints), self.gravity)
