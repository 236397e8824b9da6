"""The load beyond the sensor: the wrench it exerts on the sensor as pybullet's joint sensor
reads it, and its ground truth (mass, COM, inertia and the inertial parameters in
``ft_sensor``, the frame ``wrench_sim.sensor`` defines).

pybullet's joint force/torque sensor on the sensor's joint reports (F, M), the wrench the
flange (parent) applies to the child link, in the child's axes. In the default feedback mode
M is taken about the child link's centre of mass d (the Panda hand's: (0, 0, 0.04) m), so the
load on the sensor would be f = -F, tau = -(M + d x F). The scene sets
``jointFeedbackMode=JOINT_FEEDBACK_IN_JOINT_FRAME``, in which M is already taken about the
joint origin, so the conversion is just f = -F, tau = -M (the two agree, bench/README.md,
Simulation rate).

In motion Bullet's reading carries velocity terms it counts twice; ``read`` takes them off
(``wrench_sim.feedback``), so the reading is the inverse dynamics of the load.

Each step's true wrench (``LoadWrench.wrench``) is the mean of the last two steps' readings
(a 2-tap anti-alias filter, a zero at 500 Hz): it removes any remaining two-step oscillation
and delays the signal by half a step.

Bullet feeds the motor, limit and coupling forces of movable joints beyond the sensor into
the sensor joint's reading as a false wrench. In ``rigid`` mode there are none, and the
reading equals the gravity wrench of hand + object at any orientation; in ``friction`` mode
the fingers are real prismatic joints and the static error grows with the gravity component
along the finger axis (figures: docs/design.md, The simulated sensor; bench/README.md,
Simulation rate).
"""

from __future__ import annotations

import functools

import numpy as np
import pybullet
from numpy.typing import NDArray

from com_core.robot.dynamics import inertial_parameters, load_of
from com_core.sensing.wrench_model import skew
from wrench_sim.feedback import CountedTwice
from wrench_sim.scene import Scene
from wrench_sim.vibration import Vibration

__all__ = ["GroundTruth", "LoadWrench"]

_STILL = 0.01
"""rad/s, m/s: below this on every joint the wrench counted twice (which grows as the
speeds squared, 0.05 N at 2 rad/s) is under 2e-6 N, and is not computed."""


class GroundTruth:
    """Mass and COM of the hand and of the object, from the scene's bodies."""

    def __init__(self, scene: Scene) -> None:
        self._scene = scene
        self._hand: tuple[float, NDArray[np.float64]] | None = None

    def hand(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the links beyond the sensor (hand or
        gripper, fingers; URDF inertials, scaled by ``hand_mass``).

        Constant in rigid mode (fixed fingers): computed once; in friction mode it follows the
        fingers.
        """
        if self._hand is None or not self._scene.rigid:
            self._hand = self._hand_now()
        return self._hand[0], self._hand[1].copy()

    def _hand_now(self) -> tuple[float, NDArray[np.float64]]:
        scene = self._scene
        c = scene.client
        origin, R = scene.sensor_pose()
        mass, moment = 0.0, np.zeros(3)
        for link in scene.load_links:
            link_mass = c.getDynamicsInfo(scene.robot_body, link)[0]
            com_world = np.array(
                c.getLinkState(scene.robot_body, link, computeForwardKinematics=True)[0]
            )
            mass += link_mass
            moment += link_mass * (R.T @ (com_world - origin))
        return mass, moment / mass

    def object(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the object, wherever it is."""
        scene = self._scene
        origin, R = scene.sensor_pose()
        com_world = np.array(scene.client.getBasePositionAndOrientation(scene.object_body)[0])
        return scene.object.mass, R.T @ (com_world - origin)

    def inertial_parameters(self, held: bool) -> NDArray[np.float64]:
        """pi (10,) of everything beyond the sensor (the hand's links and, when ``held``, the
        object), as pybullet simulates them: mass, first moment and inertia about the sensor
        origin in ``ft_sensor`` (``com_core.robot.dynamics``' order)."""
        scene = self._scene
        pi = sum(self._body_parameters(scene.robot_body, link) for link in scene.load_links)
        return pi + self._body_parameters(scene.object_body, -1) if held else pi

    def inertias(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The inertias (3, 3) about their COMs in ``ft_sensor`` axes, kg m^2, of the hand
        (its links beyond the sensor together) and of the object."""
        scene = self._scene
        obj = self._body_parameters(scene.object_body, -1)
        return load_of(self.inertial_parameters(False))[2], load_of(obj)[2]

    def _body_parameters(self, body: int, link: int) -> NDArray[np.float64]:
        """pi (10,) of one body's link (-1: its base) in ``ft_sensor``, about its origin."""
        c = self._scene.client
        origin, R = self._scene.sensor_pose()
        if link == -1:
            position, orientation = c.getBasePositionAndOrientation(body)
        else:  # the link's inertial frame: its COM and principal axes
            position, orientation = c.getLinkState(body, link, computeForwardKinematics=True)[:2]
        info = c.getDynamicsInfo(body, link)
        axes = R.T @ np.array(c.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        inertia = axes @ np.diag(info[2]) @ axes.T  # about the COM, sensor axes
        return inertial_parameters(info[0], R.T @ (np.array(position) - origin), inertia)

    def load(self, held: bool) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (m, ``ft_sensor``) of everything beyond the sensor: the hand and,
        when ``held``, the object."""
        mass, com = self.hand()
        if held:
            m, c = self.object()
            com, mass = (mass * com + m * c) / (mass + m), mass + m
        return mass, com


class LoadWrench:
    """The wrench the load exerts on the sensor, read after each physics step (see module).

    Enables pybullet's joint sensor on the sensor's joint.

    Parameters
    ----------
    scene : the scene.
    truth : the load's ground truth, for the ringing.
    vibration : the arm's structural modes (``wrench_sim.vibration``); None: a rigid arm.
    """

    def __init__(self, scene: Scene, truth: GroundTruth, vibration: Vibration | None) -> None:
        self._scene = scene
        self._truth = truth
        c = scene.client
        # Bound once: BulletClient looks the function up on every call, a hot path here.
        client = {"physicsClientId": c._client}
        self._get_joint_states = functools.partial(pybullet.getJointStates, **client)
        self._get_link_state = functools.partial(pybullet.getLinkState, **client)
        self._matrix_from_quaternion = functools.partial(
            pybullet.getMatrixFromQuaternion, **client
        )
        c.enableJointForceTorqueSensor(scene.robot_body, scene.sensor, True)
        self._counted_twice = CountedTwice(
            c, scene.robot_body, scene.urdf_text, scene.sensor, scene.load_links
        )
        # read each step in one call: the sensor's joint, then the joints counted twice
        self._read_joints = [scene.sensor, *self._counted_twice.joints]
        self._raw = np.zeros(6)
        self._previous_raw = np.zeros(6)
        self._vibration = vibration
        self._load = (0.0, np.zeros((3, 3)))  # mass, skew(COM): tau = COM x f, without np.cross
        self.update_load(False)

    def read(self, moving: bool) -> None:
        """Take the reading of the step just run; ``moving``: a trajectory is running."""
        self._previous_raw = self._raw
        sensor, *states = self._get_joint_states(self._scene.robot_body, self._read_joints)
        # (F, M): the flange's wrench on the hand, hand axes, M about the joint origin.
        self._raw = np.negative(sensor[2])
        velocities = [state[1] for state in states]
        if max(map(abs, velocities)) > _STILL:
            positions = [state[0] for state in states]
            self._raw -= self._counted_twice.wrench(positions, velocities)
        if self._vibration is not None:
            self._raw = self._raw + self._ringing(moving)

    def restart_filter(self) -> None:
        """Fill the 2-tap filter with the last reading (after the warm-up)."""
        self._previous_raw = self._raw.copy()

    def update_load(self, held: bool) -> None:
        """Take the load's mass and COM anew for the ringing (the object ``held`` or not)."""
        if self._vibration is not None:
            mass, com = self._truth.load(held)
            self._load = (mass, skew(com))

    def _ringing(self, moving: bool) -> NDArray[np.float64]:
        """The wrench (6,) the load's reaction to the structure's vibration adds to the
        reading (``wrench_sim.vibration``); N, N m; ft_sensor."""
        scene = self._scene
        state = self._get_link_state(
            scene.robot_body, scene.sensor, computeLinkVelocity=1, computeForwardKinematics=1
        )
        R = np.array(self._matrix_from_quaternion(state[5])).reshape(3, 3)
        assert self._vibration is not None
        accel = R.T @ self._vibration.step(np.array(state[6]), moving)
        mass, com_cross = self._load
        force = -mass * accel
        return np.concatenate([force, com_cross @ force])

    @property
    def wrench(self) -> NDArray[np.float64]:
        """True wrench (6,) the load exerts on the sensor, 2-tap mean; N, N m; ft_sensor."""
        return 0.5 * (self._raw + self._previous_raw)

    @property
    def raw_wrench(self) -> NDArray[np.float64]:
        """The last step's single reading (6,), unfiltered; N, N m; ft_sensor."""
        return self._raw.copy()
