"""pybullet's joint force/torque reading in motion, and the wrench Bullet counts twice in it.

Bullet's ``btMultiBody`` computes a joint's reaction in two articulated-body passes: the
forces' pass (gravity, joint torques, the velocity terms) and the constraints' pass, which
adds what the constraint forces (motors, welds, contacts) do. The second pass counts two of
the velocity terms once more: each link's Coriolis acceleration (v_parent x S qd) and its
gyroscopic torque (w x I_c w). Pull request bulletphysics/bullet3#4462 (for issue #4451)
took the third, m w x v_c, out of that pass; these two stayed. They vanish at rest; with
the Panda's three wrist joints swinging at up to 2.3 rad/s they are 5 % of the inertial
force and 9 % of its torque (docs/design.md, The simulated sensor in motion).

``CountedTwice`` computes that extra wrench the way the constraints' pass does, with
pinocchio on the sim's own URDF and pybullet's own link inertias: the arm's accelerations
from the velocity terms alone (ABA, gravity and joint torques off, m w x v_c cancelled by an
external force at each link's COM), then the wrench the sensor's joint passes to the bodies
beyond it (RNEA). ``LoadWrench`` takes it off the reading. Measured on the Panda, three
wrist joints together, the reading is then the inverse dynamics to 0.4 % of the inertial
force and 0.2 % of its torque (``test/test_sim_dynamics.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio
import pybullet
from numpy.typing import NDArray

__all__ = ["CountedTwice"]


class CountedTwice:
    """The wrench Bullet's constraints' pass adds to the sensor joint's reading (see module).

    client, body : the pybullet client and the robot's body id. urdf : the URDF pybullet
    loaded. sensor : the sensor joint's index (also its child link's). beyond : pybullet's
    indices of the links beyond the sensor fixed to it (the sensor's link among them).
    """

    def __init__(self, client, body: int, urdf: str, sensor: int, beyond: Sequence[int]) -> None:
        model = pinocchio.buildModelFromXML(urdf)
        model.gravity.linear = np.zeros(3)
        infos = [client.getJointInfo(body, k) for k in range(client.getNumJoints(body))]
        links = {info[12].decode(): info[0] for info in infos}
        frames = {k: model.frames[model.getFrameId(name)] for name, k in links.items()}
        self._sensor_frame = frames[sensor].placement  # in its parent joint's frame
        self._sensor_joint = frames[sensor].parentJoint
        # each link's inertia in its pinocchio joint's frame, as pybullet simulates it, and
        # its mass as a point at its COM (whose bias v x* (P v) is m w x v_c there)
        bodies = [pinocchio.Inertia.Zero() for _ in range(model.njoints)]
        self._points = [pinocchio.Inertia.Zero() for _ in range(model.njoints)]
        self._beyond = pinocchio.Inertia.Zero()  # fixed beyond the sensor
        self._beyond_points = pinocchio.Inertia.Zero()
        for k, frame in frames.items():
            mass, _, diagonal, position, orientation = client.getDynamicsInfo(body, k)[:5]
            j = frame.parentJoint
            if j == 0 or mass <= 0.0:
                continue
            axes = np.array(pybullet.getMatrixFromQuaternion(orientation)).reshape(3, 3)
            inertia = frame.placement.act(
                pinocchio.Inertia(mass, np.array(position), axes @ np.diag(diagonal) @ axes.T)
            )
            point = pinocchio.Inertia(mass, inertia.lever, np.zeros((3, 3)))
            bodies[j] += inertia
            self._points[j] += point
            if k in beyond and j == self._sensor_joint:
                self._beyond += inertia
                self._beyond_points += point
        for j in range(model.njoints):
            model.inertias[j] = bodies[j]
        movable = [info for info in infos if info[2] != pybullet.JOINT_FIXED]
        # joints that move beyond the sensor (friction mode's fingers): their subtrees
        self._children = [model.getJointId(i[1].decode()) for i in movable if i[16] in beyond]
        self.joints = [info[0] for info in movable]  # pybullet's indices, in order
        ids = [model.getJointId(info[1].decode()) for info in movable]
        self._q_at = [(model.idx_qs[j], model.nqs[j] == 2) for j in ids]
        self._v_at = [model.idx_vs[j] for j in ids]
        self._model, self._data = model, model.createData()

    def wrench(
        self, positions: Sequence[float], velocities: Sequence[float]
    ) -> NDArray[np.float64]:
        """The extra wrench (6,) in the reading (``LoadWrench``'s sign: the load's on the
        sensor; N, N m, force first, ``ft_sensor``, about its origin) at these positions
        (rad, m) and velocities (rad/s, m/s) of ``self.joints``."""
        model, data = self._model, self._data
        q, v = pinocchio.neutral(model), np.zeros(model.nv)
        for (at, continuous), position in zip(self._q_at, positions, strict=True):
            if continuous:  # (cos, sin)
                q[at], q[at + 1] = np.cos(position), np.sin(position)
            else:
                q[at] = position
        v[self._v_at] = velocities
        pinocchio.forwardKinematics(model, data, q, v)
        # the external forces that take m w x v_c out of each link's bias
        external = [vj.cross(points * vj) for vj, points in zip(data.v, self._points, strict=True)]
        accelerations = pinocchio.aba(model, data, q, v, np.zeros(model.nv), external)
        pinocchio.rnea(model, data, q, v, accelerations, external)
        j = self._sensor_joint
        a, vj = data.a[j], data.v[j]
        inertia, points = self._beyond, self._beyond_points
        passed = inertia * a + vj.cross(inertia * vj) - vj.cross(points * vj)
        for child in self._children:
            passed += data.liMi[child].act(data.f[child])
        return -self._sensor_frame.actInv(passed).vector
