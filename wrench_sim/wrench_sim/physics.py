"""The pybullet world: a fixed-base Franka Panda with a wrist F/T sensor and a graspable object.

ROS-free; the node (``sim_node``) is a thin adapter around ``PandaWorld`` and tests drive it
directly.

Sensor frame and sign convention
--------------------------------
Frame ``ft_sensor`` has the axes of the fixed joint ``panda_hand_joint`` (the axes of link
``panda_hand``) and its origin at that joint, the flange/hand interface. The published wrench
is the wrench the load beyond the sensor (hand, fingers and a grasped object) exerts on the
sensor, expressed in ``ft_sensor``: a static load of mass m with COM p gives f = m g_s,
tau = p x f (docs/design.md, Conventions).

pybullet's joint force/torque sensor on ``panda_hand_joint`` reports (F, M), the wrench the
flange (parent) applies to the hand (child), in the hand's axes. In the default feedback mode M
is taken about the hand's centre of mass (0, 0, 0.04 m), so the load on the sensor would be
f = -F, tau = -(M + d x F) with d = (0, 0, 0.04). This world sets
``jointFeedbackMode=JOINT_FEEDBACK_IN_JOINT_FRAME``, in which M is already taken about the
joint origin, so the conversion is just f = -F, tau = -M (both checked to agree to 1e-9).

Exactness
---------
- The solver runs a fixed number of iterations (``solverResidualThreshold=0``). With pybullet's
  default early exit the held arm settles into a 2- or 3-step limit cycle of up to 0.013 N on
  the sensor; with the fixed count a held pose reads the static wrench to ~2e-4 N.
- Each step's true wrench (``wrench``) is the mean of the last two steps' readings (a 2-tap
  anti-alias filter, a zero at 500 Hz): it removes any remaining two-step oscillation and
  delays the signal by half a step.
- Bullet feeds the prismatic finger joints' motor, limit and coupling forces into the hand
  joint's reading as a false wrench. In ``rigid`` grasp mode the fingers are fixed joints of a
  generated copy of the URDF (drawn open at 0.04 m; ``/joint_states`` reports a virtual
  finger opening), and the reading equals the gravity wrench of hand + object to 2e-4 N and
  1e-5 N m at any orientation. In ``friction`` mode the fingers are the real prismatic joints,
  coupled by a gear constraint (the URDF's mimic), and the static error is ~0.11 kg times the
  gravity component along the finger axis (1.05 N, 0.10 N m with gravity along it; <= 0.06 N,
  0.011 N m with gravity across it), measured by ``test/test_sim_physics.py``.

Pushes
------
``apply_wrench`` pushes the held object: a force (N) at its COM and a pure couple (N m), given
in ``world`` (a fixed direction) or in ``ft_sensor`` (turning with the hand), for a duration
from a start time. Each step it is converted to the world frame and applied with pybullet's
``applyExternalForce``/``applyExternalTorque`` in ``WORLD_FRAME`` (pybullet clears external
forces after every step; its ``LINK_FRAME`` torque on a base has been swapped with the world
frame in some versions, so it is not used). ``applied_wrench`` is the push as the sensor reads
it, about the sensor origin in ``ft_sensor``: f = R^T F, tau = R^T (T + (c - o) x F) for a push
(F, T) in the world, R = R_world_sensor, c the object's COM, o the sensor origin. The held arm
gives way to a push and recovers within ~0.1 s (its joints are position controlled); from then
on the reading changes by ``applied_wrench`` to 1.2e-5 N and 1.8e-6 N m in rigid mode, and
within 0.1 s of the push's end it is back to 4e-10 N (measured by ``test/test_sim_physics.py``).
"""

from __future__ import annotations

import functools
import math
import os
import re
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet
import pybullet_data
from numpy.typing import NDArray
from pybullet_utils.bullet_client import BulletClient

from com_core.contract import ARM_JOINTS, FINGER_JOINTS, FINGER_OPEN
from com_core.wrench_model import STANDARD_GRAVITY
from wrench_sim.objects import SHAPES, ObjectSpec, create_object_body, object_spec
from wrench_sim.sensor import random_streams
from wrench_sim.trajectory import JointLimits, QuinticTrajectory, trajectory_from_command

__all__ = [
    "GRASP_MODES",
    "HOME_JOINTS",
    "PICK_JOINTS",
    "PUSH_FRAMES",
    "SENSOR_FRAME",
    "STEP_NS",
    "TIME_STEP",
    "WORLD_FRAME",
    "PandaWorld",
    "SimConfig",
]

TIME_STEP = 1e-3
"""s; physics step (1 kHz)."""
STEP_NS = 1_000_000
GRASP_MODES = ("rigid", "friction")
HOME_JOINTS = (0.0, -0.1559, 0.0, -2.1983, 0.0, 2.0424, 0.7854)
"""rad; hand at (0.5, 0, 0.45) m in the world, pointing down (hand z = -world z, hand x =
world x), 0.2 m above the pick pose. At this pose joint 5 tilts about hand x, joint 6 about hand
y (the finger axis) and joint 7 turns about hand z."""
PICK_JOINTS = (0.0, 0.1591, 0.0, -2.3988, 0.0, 2.5578, 0.7854)
"""rad; hand at (0.5, 0, 0.25) m, pointing down: the object on the stand is between the
fingers, its top 0.075 m below the flange; closing the fingers grasps it."""
WORLD_FRAME = "world"
SENSOR_FRAME = "ft_sensor"
PUSH_FRAMES = (WORLD_FRAME, SENSOR_FRAME)
"""The frames a push (``PandaWorld.apply_wrench``) may be given in."""

_ARM = list(range(7))
_HAND = 8  # joint panda_hand_joint and link panda_hand
_FINGERS = (9, 10)
_LOAD_LINKS = (8, 9, 10, 11)  # hand, fingers, grasp target: everything beyond the sensor
_PICK_POSITION = np.array([0.5, 0.0, 0.25])
_OBJECT_TOP_BELOW_FLANGE = 0.075  # m along hand z
_STAND_HALF_WIDTH = 0.03
_SOLVER_ITERATIONS = {"rigid": 20, "friction": 50}  # finger contacts need more
_POSITION_GAIN = 0.1
_VELOCITY_GAIN = 1.0
_FINGER_SPEED = 0.1  # m/s
_GEAR_FORCE = 50.0  # N
_FINGER_PAD_Z = (0.085, 0.11)  # m; span of the finger pads along hand z
_GRASP_CENTRE_TOLERANCE = 0.02  # m; object centre off the hand axis still grasped
_BOOKKEEPING_STEPS = 10  # grasp, settle and slip checks every 10 ms
_SETTLE_SPEED = 2e-3  # rad/s; arm at rest below this joint speed...
_SETTLE_STEPS = 20  # ...for this many steps
_NEW_TILT_ANGLE = 0.02  # rad; hand rotation since the last shift that makes a new tilt
_WARM_UP_STEPS = 200


@dataclass
class _Push:
    """A push on the held object: force (N) at its COM and couple (N m), in the world or in
    ``ft_sensor``, acting on the physics steps ``start_step <= k < end_step`` (step k runs from
    k to k + 1 ms)."""

    force: NDArray[np.float64]
    torque: NDArray[np.float64]
    frame: str
    start_step: int
    end_step: int
    started: bool = False


@dataclass(frozen=True)
class SimConfig:
    """The scene: object, grasp mode and hand.

    Attributes
    ----------
    object_shape : 'box', 'cylinder' or 'mug'.
    object_mass : kg.
    object_com_offset : m, object frame, COM minus geometric centre, inside
        ``objects.holdable_com_range(object_shape)`` (``PandaWorld`` refuses others with a
        ValueError stating the range); None draws it from ``seed`` (uniform inside the body's
        inner half, which lies in that range).
    seed : seeds the COM draw, the sensor noise and the grasp shifts (separate streams).
    grasp_mode : 'rigid' (a fixed constraint; the paper's immobilised object) or 'friction'
        (finger contact; the object may slip).
    slip_sigma : m; rigid mode only: at each new tilt the object is re-attached shifted by a
        N(0, slip_sigma^2 I) vector in ``ft_sensor`` (the paper's reconfiguration).
    hand_mass : kg; total mass of hand and fingers, 0 = the URDF's 1.01 kg. Scales the masses
        of the hand and both fingers alike, so the hand's COM is unchanged.
    grip_force : N; friction mode: force limit of each finger's position controller.
    home_joints : rad; the arm's initial joint positions (panda_joint1..7).
    gui : open pybullet's window instead of running headless (DIRECT).
    """

    object_shape: str = "box"
    object_mass: float = 0.1
    object_com_offset: tuple[float, float, float] | None = None
    seed: int = 0
    grasp_mode: str = "rigid"
    slip_sigma: float = 0.0
    hand_mass: float = 0.0
    grip_force: float = 5.0
    home_joints: tuple[float, ...] = HOME_JOINTS
    gui: bool = False

    def __post_init__(self) -> None:
        if self.object_shape not in SHAPES:
            raise ValueError(f"object must be one of {sorted(SHAPES)}, got {self.object_shape!r}")
        if self.grasp_mode not in GRASP_MODES:
            raise ValueError(f"grasp_mode must be one of {GRASP_MODES}, got {self.grasp_mode!r}")
        if not (np.isfinite(self.slip_sigma) and self.slip_sigma >= 0.0):
            raise ValueError(f"slip_sigma must be >= 0 m, got {self.slip_sigma}")
        if self.slip_sigma > 0.0 and self.grasp_mode != "rigid":
            raise ValueError("slip_sigma applies to grasp_mode 'rigid' (friction mode slips)")
        if not (np.isfinite(self.hand_mass) and self.hand_mass >= 0.0):
            raise ValueError(
                f"hand_mass must be >= 0 kg (0 = from the URDF), got {self.hand_mass}"
            )
        if not (np.isfinite(self.grip_force) and self.grip_force > 0.0):
            raise ValueError(f"grip_force must be > 0 N, got {self.grip_force}")
        if len(self.home_joints) != 7 or not np.all(np.isfinite(self.home_joints)):
            raise ValueError(f"home_joints must be 7 finite values (rad), got {self.home_joints}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")


def _panda_urdf_with_fixed_fingers(opening: float) -> str:
    """Text of pybullet_data's panda.urdf with the finger joints fixed at ``opening`` (m)."""
    directory = os.path.join(pybullet_data.getDataPath(), "franka_panda")
    with open(os.path.join(directory, "panda.urdf"), encoding="utf-8") as stream:
        text = stream.read()
    text = text.replace("package://meshes/", os.path.join(directory, "meshes") + "/")

    def fixed_joint(match: re.Match[str]) -> str:
        name, child = match.group(1), match.group(2)
        side = 1.0 if name.endswith("1") else -1.0
        return (
            f'<joint name="{name}" type="fixed"><parent link="panda_hand"/>'
            f'<child link="{child}"/><origin rpy="0 0 0" xyz="0 {side * opening} 0.0584"/>'
            "</joint>"
        )

    pattern = (
        r'<joint name="(panda_finger_joint[12])" type="prismatic">.*?'
        r'<child link="(\w+)"/>.*?</joint>'
    )
    text, count = re.subn(pattern, fixed_joint, text, flags=re.S)
    if count != 2:
        raise RuntimeError("panda.urdf changed: could not find the two prismatic finger joints")
    return text


class PandaWorld:
    """A Panda on a fixed base, a stand with an object, stepped at 1 kHz.

    Parameters
    ----------
    config : the scene.

    Notes
    -----
    After construction the world has run 0.2 s of warm-up (not counted in ``time_ns``) so the
    arm holds ``home_joints`` and the object rests on its stand.
    """

    def __init__(self, config: SimConfig | None = None) -> None:
        self.config = config or SimConfig()
        streams = random_streams(self.config.seed)
        self.object: ObjectSpec = object_spec(
            self.config.object_shape,
            self.config.object_mass,
            self.config.object_com_offset,
            streams["object"],
        )
        self._slip_rng = streams["slip"]
        self._slip_sigma = self.config.slip_sigma
        self._rigid = self.config.grasp_mode == "rigid"
        self._client = BulletClient(pybullet.GUI if self.config.gui else pybullet.DIRECT)
        c = self._client
        # Bound once: BulletClient looks the function up on every call (~2 us), hot paths here.
        self._step_simulation = functools.partial(
            pybullet.stepSimulation, physicsClientId=c._client
        )
        self._get_joint_state = functools.partial(
            pybullet.getJointState, physicsClientId=c._client
        )
        self._set_motors = functools.partial(
            pybullet.setJointMotorControlArray, physicsClientId=c._client
        )
        c.setAdditionalSearchPath(pybullet_data.getDataPath())
        c.setGravity(0.0, 0.0, -STANDARD_GRAVITY)
        c.setTimeStep(TIME_STEP)
        c.setPhysicsEngineParameter(
            numSolverIterations=_SOLVER_ITERATIONS[self.config.grasp_mode],
            solverResidualThreshold=0.0,
            jointFeedbackMode=pybullet.JOINT_FEEDBACK_IN_JOINT_FRAME,
        )
        if self.config.gui:
            c.configureDebugVisualizer(pybullet.COV_ENABLE_GUI, 0)
            c.resetDebugVisualizerCamera(1.2, 60.0, -25.0, [0.4, 0.0, 0.3])
        self.robot = self._load_robot()
        self._limits = JointLimits(
            ARM_JOINTS,
            np.array([c.getJointInfo(self.robot, j)[8] for j in _ARM]),
            np.array([c.getJointInfo(self.robot, j)[9] for j in _ARM]),
            np.array([c.getJointInfo(self.robot, j)[11] for j in _ARM]),
        )
        self._efforts = [c.getJointInfo(self.robot, j)[10] for j in _ARM]
        home = np.asarray(self.config.home_joints, dtype=np.float64)
        if np.any(home < self._limits.lower) or np.any(home > self._limits.upper):
            raise ValueError(f"home_joints {home.tolist()} outside the joint limits")
        self._scale_hand_mass()
        c.loadURDF("plane.urdf")
        self.object_body = self._load_stand_and_object()
        self._constraint: int | None = None
        self._hand_truth: tuple[float, NDArray[np.float64]] | None = None
        self.events: list[str] = []
        self._steps = 0
        self._trajectory: QuinticTrajectory | None = None
        self._queued: QuinticTrajectory | None = None  # starts later (command_arm)
        self._set_point = (home.copy(), np.zeros(7), np.zeros(7))
        self._finger_target = FINGER_OPEN
        self._finger_opening = FINGER_OPEN  # rigid mode: the virtual fingers
        self._held = False
        self._pushes: list[_Push] = []
        # the last step's pushes: world force and torque, then ft_sensor force and torque
        self._applied: tuple[NDArray[np.float64], ...] | None = None
        self._still_steps = 0
        self._R_at_shift: NDArray[np.float64] | None = None
        for joint, q in zip(_ARM, home, strict=True):
            c.resetJointState(self.robot, joint, q)
        self._hold_arm(home, np.zeros(7))
        if not self._rigid:
            for joint in _FINGERS:
                c.resetJointState(self.robot, joint, FINGER_OPEN)
            # The real gripper's fingers are coupled (the URDF's mimic tag, which pybullet
            # ignores): without the gear, both fingers pushing at their force limit would let
            # fingers and object slide together along the finger axis to one finger's limit.
            gear = c.createConstraint(
                self.robot,
                _FINGERS[0],
                self.robot,
                _FINGERS[1],
                pybullet.JOINT_GEAR,
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
            )
            c.changeConstraint(gear, gearRatio=-1.0, erp=0.1, maxForce=_GEAR_FORCE)
            self._drive_fingers([FINGER_OPEN] * 2)
        c.enableJointForceTorqueSensor(self.robot, _HAND, True)
        self._raw = np.zeros(6)
        self._previous_raw = np.zeros(6)
        for _ in range(_WARM_UP_STEPS):
            self._physics_step()
        self._previous_raw = self._raw.copy()
        self.events.clear()

    # ----------------------------------------------------------------- construction
    def _load_robot(self) -> int:
        """Load the Panda (rigid mode: the fixed-finger copy); ``urdf_text`` is what was
        loaded, as ``/robot_description`` publishes it."""
        c = self._client
        if not self._rigid:
            path = os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf")
            with open(path, encoding="utf-8") as stream:
                self.urdf_text = stream.read()
            return c.loadURDF(path, useFixedBase=True)
        text = self.urdf_text = _panda_urdf_with_fixed_fingers(FINGER_OPEN)
        with tempfile.TemporaryDirectory(prefix="wrench_sim_") as directory:
            path = os.path.join(directory, "panda_fixed_fingers.urdf")
            with open(path, "w", encoding="utf-8") as stream:
                stream.write(text)
            return c.loadURDF(path, useFixedBase=True)

    def _scale_hand_mass(self) -> None:
        if self.config.hand_mass <= 0.0:
            return
        c = self._client
        urdf_mass = sum(c.getDynamicsInfo(self.robot, link)[0] for link in _LOAD_LINKS)
        factor = self.config.hand_mass / urdf_mass
        for link in _LOAD_LINKS:
            info = c.getDynamicsInfo(self.robot, link)
            if info[0] > 0.0:
                c.changeDynamics(
                    self.robot,
                    link,
                    mass=info[0] * factor,
                    localInertiaDiagonal=[i * factor for i in info[2]],
                )

    def _load_stand_and_object(self) -> int:
        c = self._client
        height = self.object.geometry.height
        top = _PICK_POSITION[2] - _OBJECT_TOP_BELOW_FLANGE - height
        half = [_STAND_HALF_WIDTH, _STAND_HALF_WIDTH, top / 2.0]
        stand = c.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half),
            baseVisualShapeIndex=c.createVisualShape(
                pybullet.GEOM_BOX, halfExtents=half, rgbaColor=[0.5, 0.5, 0.55, 1.0]
            ),
            basePosition=[_PICK_POSITION[0], _PICK_POSITION[1], top / 2.0],
        )
        c.changeDynamics(stand, -1, lateralFriction=1.0)
        centre = [_PICK_POSITION[0], _PICK_POSITION[1], top + height / 2.0]
        return create_object_body(c, self.object, centre)

    # ----------------------------------------------------------------- stepping
    @property
    def time_ns(self) -> int:
        """Simulated time since start, integer ns."""
        return self._steps * STEP_NS

    @property
    def time(self) -> float:
        """Simulated time since start, s."""
        return self._steps * TIME_STEP

    def step(self) -> None:
        """Advance the world by one 1 ms physics step and read the sensor."""
        if self._queued is not None and self.time >= self._queued.start_time:
            self._trajectory, self._queued = self._queued, None
        if self._trajectory is not None:
            self._follow_trajectory()
        if self._finger_opening != self._finger_target and self._rigid:
            self._move_virtual_fingers()
        if self._pushes:
            self._apply_pushes()
        self._physics_step()
        self._steps += 1
        if self._steps % _BOOKKEEPING_STEPS == 0:
            self._bookkeeping()

    def run(self, duration: float) -> None:
        """Step for ``duration`` s of simulated time."""
        for _ in range(round(duration / TIME_STEP)):
            self.step()

    def _physics_step(self) -> None:
        self._step_simulation()
        self._previous_raw = self._raw
        # (F, M): the flange's wrench on the hand, hand axes, M about the joint origin.
        self._raw = np.negative(self._get_joint_state(self.robot, _HAND)[2])

    @property
    def wrench(self) -> NDArray[np.float64]:
        """True wrench (6,) the load exerts on the sensor, 2-tap mean; N, N m; ft_sensor."""
        return 0.5 * (self._raw + self._previous_raw)

    @property
    def raw_wrench(self) -> NDArray[np.float64]:
        """The last step's single reading (6,), unfiltered; N, N m; ft_sensor."""
        return self._raw.copy()

    # ----------------------------------------------------------------- arm
    def command_arm(
        self,
        joint_names: Sequence[str],
        times: Sequence[float],
        positions: Sequence[Sequence[float]],
        start_time: float = 0.0,
    ) -> float:
        """Follow a joint trajectory from ``start_time`` (replacing any running or queued
        one; a running one goes on until then).

        Parameters
        ----------
        joint_names : subset of panda_joint1..7, any order.
        times : s from the start, strictly increasing.
        positions : rad, one row per time, one value per name.
        start_time : s, simulated; now if earlier than now (the JointTrajectory header
            stamp's convention, with 0 for now).

        Returns
        -------
        s; simulated time at which the last waypoint is reached.

        Raises
        ------
        ValueError if the command is malformed or unreachable; the arm then keeps its
        current motion.
        """
        start = max(start_time, self.time)
        running = self._trajectory
        state = running.sample(start) if running and start > self.time else self._set_point
        trajectory = trajectory_from_command(
            joint_names, times, positions, self._limits, start, state
        )
        if start > self.time:
            self._queued = trajectory
        else:
            self._trajectory, self._queued = trajectory, None
        self._still_steps = 0
        return trajectory.end_time

    def move_arm(self, positions: Sequence[float], duration: float) -> None:
        """Move all 7 joints to ``positions`` (rad) in ``duration`` s and wait until settled."""
        self.command_arm(ARM_JOINTS, [duration], [positions])
        self.run(duration)
        while not self.arm_settled:
            self.step()

    @property
    def arm_idle(self) -> bool:
        """No trajectory is running or queued."""
        return self._trajectory is None and self._queued is None

    @property
    def arm_settled(self) -> bool:
        """No trajectory is running and the joints have been still for 20 ms."""
        return self.arm_idle and self._still_steps >= _SETTLE_STEPS

    def _follow_trajectory(self) -> None:
        assert self._trajectory is not None
        t = self.time
        position, velocity, acceleration = self._trajectory.sample(t)
        self._set_point = (position, velocity, acceleration)
        self._hold_arm(position, velocity)
        if t >= self._trajectory.end_time:
            self._trajectory = None

    def _hold_arm(self, position: NDArray[np.float64], velocity: NDArray[np.float64]) -> None:
        self._set_motors(
            self.robot,
            _ARM,
            pybullet.POSITION_CONTROL,
            targetPositions=position.tolist(),
            targetVelocities=velocity.tolist(),
            forces=self._efforts,
            positionGains=[_POSITION_GAIN] * 7,
            velocityGains=[_VELOCITY_GAIN] * 7,
        )

    # ----------------------------------------------------------------- gripper
    def command_gripper(self, opening: float) -> None:
        """Move each finger to ``opening`` m from the hand's centre line (0 closed, 0.04 open).

        Closing on the object grasps it; opening releases it. Raises ValueError for a value
        outside [0, 0.04] or not finite.
        """
        if not (np.isfinite(opening) and 0.0 <= opening <= FINGER_OPEN):
            raise ValueError(f"finger opening must be in [0, {FINGER_OPEN}] m, got {opening}")
        self._finger_target = float(opening)
        if not self._rigid:
            self._drive_fingers([self._finger_target] * 2)

    def _drive_fingers(self, openings: Sequence[float]) -> None:
        for joint, opening in zip(_FINGERS, openings, strict=True):
            self._client.setJointMotorControl2(
                self.robot,
                joint,
                pybullet.POSITION_CONTROL,
                targetPosition=opening,
                force=self.config.grip_force,
                maxVelocity=_FINGER_SPEED,
            )

    def _move_virtual_fingers(self) -> None:
        """Rigid mode: the fingers are drawn, not simulated; grasp when they reach the object."""
        step = _FINGER_SPEED * TIME_STEP
        target, opening = self._finger_target, self._finger_opening
        opening = min(target, opening + step) if target > opening else max(target, opening - step)
        width = self.object.geometry.grasp_half_width
        if self._held:
            if opening > width + 1e-3:
                self._release()
            else:
                opening = max(opening, width)
        elif self._finger_opening > width >= opening and self._object_between_fingers():
            opening = width
            self._attach()
        self._finger_opening = opening

    def _object_between_fingers(self) -> bool:
        centre = self._object_centre_in_sensor()
        z_half = self.object.geometry.half_extents[2]
        return (
            abs(centre[0]) <= _GRASP_CENTRE_TOLERANCE
            and abs(centre[1]) <= _GRASP_CENTRE_TOLERANCE
            and centre[2] - z_half < _FINGER_PAD_Z[1]
            and centre[2] + z_half > _FINGER_PAD_Z[0]
        )

    def _attach(self) -> None:
        c = self._client
        hand_position, hand_orientation = c.getLinkState(self.robot, _HAND)[:2]
        object_position, object_orientation = c.getBasePositionAndOrientation(self.object_body)
        inverse = c.invertTransform(hand_position, hand_orientation)
        relative = c.multiplyTransforms(*inverse, object_position, object_orientation)
        for link in _LOAD_LINKS:
            c.setCollisionFilterPair(self.robot, self.object_body, link, -1, 0)
        self._constraint = c.createConstraint(
            self.robot,
            _HAND,
            self.object_body,
            -1,
            pybullet.JOINT_FIXED,
            [0.0, 0.0, 0.0],
            parentFramePosition=relative[0],
            childFramePosition=[0.0, 0.0, 0.0],
            parentFrameOrientation=relative[1],
            childFrameOrientation=[0.0, 0.0, 0.0, 1.0],
        )
        if not self._held:
            self._held = True
            self._R_at_shift = self.sensor_pose()[1]
            self._event(f"grasped the {self.object.shape} (rigid constraint)")

    def _release(self) -> None:
        c = self._client
        if self._constraint is not None:
            c.removeConstraint(self._constraint)
            self._constraint = None
        for link in _LOAD_LINKS:
            c.setCollisionFilterPair(self.robot, self.object_body, link, -1, 1)
        self._held = False
        self._event(f"released the {self.object.shape}")

    def set_slip_sigma(self, sigma: float) -> None:
        """Change the grasp-shift sigma (m) of the rigid mode from now on."""
        if not (np.isfinite(sigma) and sigma >= 0.0):
            raise ValueError(f"slip_sigma must be >= 0 m, got {sigma}")
        if sigma > 0.0 and not self._rigid:
            raise ValueError("slip_sigma applies to grasp_mode 'rigid' (friction mode slips)")
        self._slip_sigma = float(sigma)

    def _event(self, text: str) -> None:
        """Record something a user cares about, with the sim time, for the node to log."""
        self.events.append(f"t = {self.time:.3f} s: {text}")

    @property
    def object_held(self) -> bool:
        """The object is in the hand (rigid: attached; friction: touched by both fingers)."""
        return self._held

    # ----------------------------------------------------------------- pushes
    def apply_wrench(
        self,
        force: Sequence[float],
        torque: Sequence[float],
        frame: str = WORLD_FRAME,
        start_time: float = 0.0,
        duration: float = 1.0,
    ) -> tuple[float, float]:
        """Push the held object from ``start_time`` for ``duration`` s of simulated time.

        Pushes add up: one given while another acts or waits acts on top of it.

        Parameters
        ----------
        force : N, shape (3,); applied at the object's COM.
        torque : N m, shape (3,); a pure couple on the object.
        frame : 'world' (the push keeps its direction in the world) or 'ft_sensor' (the push
            turns with the hand; the URDF's sensor frame ``panda_hand``).
        start_time : s, simulated; now if earlier than now (0 = now), else the first 1 ms step
            starting at or after it.
        duration : s, > 0; rounded to whole 1 ms steps (at least one).

        Returns
        -------
        (start, end) in s, simulated: the push acts on the steps between them, so the readings
        stamped in (start, end] carry it. Its start and end are recorded in ``events``; a push
        acting when the object is released ends then, and one whose start comes after the
        release is dropped.

        Raises
        ------
        ValueError if the frame is neither, a value is not finite, ``duration`` is not > 0, or
        no object is held.
        """
        if frame not in PUSH_FRAMES:
            raise ValueError(f"frame must be one of {list(PUSH_FRAMES)}, got {frame!r}")
        force_array = np.array(force, dtype=np.float64).reshape(3)
        torque_array = np.array(torque, dtype=np.float64).reshape(3)
        if not (np.all(np.isfinite(force_array)) and np.all(np.isfinite(torque_array))):
            raise ValueError("force and torque must be finite")
        if not math.isfinite(start_time):
            raise ValueError(f"start_time must be finite, got {start_time}")
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"duration must be > 0 s, got {duration}")
        if not self._held:
            raise ValueError("no object is held")
        start_step = max(self._steps, math.ceil(start_time / TIME_STEP - 1e-6))
        end_step = start_step + max(1, round(duration / TIME_STEP))
        self._pushes.append(_Push(force_array, torque_array, frame, start_step, end_step))
        return start_step * TIME_STEP, end_step * TIME_STEP

    @property
    def push_active(self) -> bool:
        """A push acted on the object during the last step."""
        return self._applied is not None

    @property
    def push_scheduled(self) -> bool:
        """A push is acting or waiting for its start time."""
        return bool(self._pushes)

    def applied_wrench(self) -> NDArray[np.float64]:
        """The pushes of the last step as the sensor reads them (6,); N, N m; ``ft_sensor``.

        The wrench the pushes add to the load on the sensor once the arm holds still, about the
        sensor origin: f = F_s, tau = T_s + p x F_s, with (F_s, T_s) the pushes in ``ft_sensor``
        at the current pose (a world push (F, T): F_s = R^T F, T_s = R^T T, R = R_world_sensor)
        and p the object's COM in ``ft_sensor``. Zero when no push acted.
        """
        if self._applied is None:
            return np.zeros(6)
        force_world, torque_world, force, torque = self._applied
        origin, R = self.sensor_pose()
        com = np.array(self._client.getBasePositionAndOrientation(self.object_body)[0])
        force = force + R.T @ force_world
        torque = torque + R.T @ torque_world
        return np.concatenate([force, torque + np.cross(R.T @ (com - origin), force)])

    def _apply_pushes(self) -> None:
        """Apply the sum of the pushes acting on the coming step, converted to the world."""
        step = self._steps
        # world pushes, then sensor-frame pushes, summed per frame
        sums = {WORLD_FRAME: (np.zeros(3), np.zeros(3)), SENSOR_FRAME: (np.zeros(3), np.zeros(3))}
        active = False
        for push in list(self._pushes):
            if step < push.start_step:
                continue
            if step >= push.end_step or not self._held:
                self._pushes.remove(push)
                name = f"push from t = {push.start_step * TIME_STEP:.3f} s"
                if not push.started:
                    self._event(f"{name} dropped: no object held at its start")
                elif self._held:
                    self._event(f"{name} ended")
                else:
                    self._event(f"{name} ended early: the object was released")
                continue
            if not push.started:
                push.started = True
                self._event(f"push started, until t = {push.end_step * TIME_STEP:.3f} s")
            force, torque = sums[push.frame]
            force += push.force
            torque += push.torque
            active = True
        if not active:
            self._applied = None
            return
        force_world, torque_world = sums[WORLD_FRAME]
        force_sensor, torque_sensor = sums[SENSOR_FRAME]
        force, torque = force_world, torque_world
        if force_sensor.any() or torque_sensor.any():
            R = self.sensor_pose()[1]
            force, torque = force + R @ force_sensor, torque + R @ torque_sensor
        c = self._client
        com = c.getBasePositionAndOrientation(self.object_body)[0]
        c.applyExternalForce(self.object_body, -1, force.tolist(), com, pybullet.WORLD_FRAME)
        c.applyExternalTorque(self.object_body, -1, torque.tolist(), pybullet.WORLD_FRAME)
        self._applied = (force_world, torque_world, force_sensor, torque_sensor)

    # ----------------------------------------------------------------- bookkeeping
    def _bookkeeping(self) -> None:
        """Every 10 ms: friction grasp state, arm settling and the rigid grasp's shifts."""
        c = self._client
        if not self._rigid:
            touching = all(
                c.getContactPoints(self.robot, self.object_body, finger, -1) for finger in _FINGERS
            )
            if touching != self._held:
                self._held = touching
                state = "grasped (finger contact)" if touching else "released (no finger contact)"
                self._event(f"{self.object.shape} {state}")
        speeds = [abs(state[1]) for state in c.getJointStates(self.robot, _ARM)]
        if self._trajectory is None and max(speeds) < _SETTLE_SPEED:
            self._still_steps += _BOOKKEEPING_STEPS
        else:
            self._still_steps = 0
        if self._rigid and self._held and self._slip_sigma > 0.0 and self.arm_settled:
            R = self.sensor_pose()[1]
            assert self._R_at_shift is not None
            cos_angle = (np.trace(self._R_at_shift.T @ R) - 1.0) / 2.0
            if np.arccos(np.clip(cos_angle, -1.0, 1.0)) > _NEW_TILT_ANGLE:
                self._shift_object(R)

    def _shift_object(self, R_world_sensor: NDArray[np.float64]) -> None:
        """Re-attach the object shifted by N(0, slip_sigma^2 I) in ft_sensor (a new tilt)."""
        c = self._client
        shift = self._slip_rng.normal(0.0, self._slip_sigma, 3)
        assert self._constraint is not None
        c.removeConstraint(self._constraint)
        position, orientation = c.getBasePositionAndOrientation(self.object_body)
        c.resetBasePositionAndOrientation(
            self.object_body, (np.asarray(position) + R_world_sensor @ shift).tolist(), orientation
        )
        self._attach()
        self._R_at_shift = R_world_sensor
        self._event(
            f"{self.object.shape} shifted in the grasp by "
            f"({', '.join(f'{1e3 * s:.2f}' for s in shift)}) mm in ft_sensor (new tilt)"
        )

    # ----------------------------------------------------------------- state and truth
    def sensor_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Origin (3,) in m and rotation R_world_sensor (3, 3) of ``ft_sensor`` in the world."""
        state = self._client.getLinkState(self.robot, _HAND, computeForwardKinematics=True)
        R = np.array(self._client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        return np.array(state[4]), R

    def gravity_in_sensor(self) -> NDArray[np.float64]:
        """Gravity (3,) in m/s^2 expressed in ``ft_sensor``."""
        return self.sensor_pose()[1].T @ np.array([0.0, 0.0, -STANDARD_GRAVITY])

    def hand_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of hand and fingers (URDF inertials).

        Constant in rigid mode (fixed fingers); in friction mode it follows the fingers.
        """
        if self._hand_truth is None or not self._rigid:
            self._hand_truth = self._hand_ground_truth()
        return self._hand_truth[0], self._hand_truth[1].copy()

    def _hand_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        c = self._client
        origin, R = self.sensor_pose()
        mass, moment = 0.0, np.zeros(3)
        for link in _LOAD_LINKS:
            link_mass = c.getDynamicsInfo(self.robot, link)[0]
            com_world = np.array(
                c.getLinkState(self.robot, link, computeForwardKinematics=True)[0]
            )
            mass += link_mass
            moment += link_mass * (R.T @ (com_world - origin))
        return mass, moment / mass

    def object_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the object, wherever it is."""
        origin, R = self.sensor_pose()
        com_world = np.array(self._client.getBasePositionAndOrientation(self.object_body)[0])
        return self.object.mass, R.T @ (com_world - origin)

    def _object_centre_in_sensor(self) -> NDArray[np.float64]:
        origin, R = self.sensor_pose()
        com_world, orientation = self._client.getBasePositionAndOrientation(self.object_body)
        R_object = np.array(self._client.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        centre_world = np.asarray(com_world) - R_object @ np.asarray(self.object.com_offset)
        return R.T @ (centre_world - origin)

    def joint_state(
        self,
    ) -> tuple[tuple[str, ...], list[float], list[float], list[float]]:
        """Names, positions (rad, m), velocities and efforts (N m, N) of arm and fingers.

        In rigid mode the fingers are fixed links; their reported position is the virtual
        opening (stopping at the object's half width when it is grasped).
        """
        states = self._client.getJointStates(self.robot, _ARM)
        positions = [s[0] for s in states]
        velocities = [s[1] for s in states]
        efforts = [s[3] for s in states]
        if self._rigid:
            moving = self._finger_opening != self._finger_target
            speed = np.sign(self._finger_target - self._finger_opening) * _FINGER_SPEED
            positions += [self._finger_opening] * 2
            velocities += [float(speed) if moving else 0.0] * 2
            efforts += [0.0, 0.0]
        else:
            fingers = self._client.getJointStates(self.robot, list(_FINGERS))
            positions += [s[0] for s in fingers]
            velocities += [s[1] for s in fingers]
            efforts += [s[3] for s in fingers]
        return ARM_JOINTS + FINGER_JOINTS, positions, velocities, efforts

    def close(self) -> None:
        """Disconnect from pybullet."""
        if self._client._client >= 0:
            self._client.disconnect()
