"""The pybullet world: a fixed-base arm with a wrist F/T sensor, its gripper and a graspable
object on a stand.

ROS-free; the node (``sim_node``) is a thin adapter around ``ArmWorld`` and tests drive it
directly. The arm is the one a robot configuration (``com_core.robot.config``) describes: its
URDF, sensor frame, joints, gripper and poses. Two ship with com_core: the Franka Emika Panda
with its hand (``panda``, the default) and the UFACTORY xArm6 with its gripper (``xarm6``).

Sensor frame and sign convention
--------------------------------
Frame ``ft_sensor`` has the axes and origin of the configuration's ``sensor_frame`` (Panda:
``panda_hand``; xArm6: ``xarm_gripper_base_link``), the child link of the fixed joint at the
flange (``panda_hand_joint``; ``gripper_fix``). The published wrench is the wrench the load
beyond the sensor (every link after that joint: hand or gripper base, fingers, and a grasped
object) exerts on the sensor, expressed in ``ft_sensor``: a static load of mass m with COM p
gives f = m g_s, tau = p x f (docs/design.md, Conventions).

pybullet's joint force/torque sensor on that joint reports (F, M), the wrench the flange
(parent) applies to the child link, in the child's axes. In the default feedback mode M is
taken about the child link's centre of mass d (the Panda hand's: (0, 0, 0.04) m), so the load
on the sensor would be f = -F, tau = -(M + d x F). This world sets
``jointFeedbackMode=JOINT_FEEDBACK_IN_JOINT_FRAME``, in which M is already taken about the
joint origin, so the conversion is just f = -F, tau = -M (both checked to agree to 1e-9).

Scene
-----
A stand carries the object upright. At the configuration's ``pick_joints`` the object's
geometric centre lies on the grasp centre (``com_core.robot.config.grasp_point``) across the
sensor's z, and its top 0.04 m before the grasp centre along it (Panda: grasp centre 0.115 m
from the flange, the top 0.075 m); the object's axes are the world's.

Gripper
-------
In ``rigid`` grasp mode every movable joint beyond the sensor is a fixed joint of a generated
copy of the URDF, at its open position (the gripper joints at ``gripper_open``, a mimic joint
at multiplier * position + offset of the joint it mimics, others at 0), and the gripper is
virtual: its position (the gripper command's units, m or rad) runs between ``gripper_open``
and ``gripper_closed`` in 0.4 s, each pad's distance from the grasp centre is linear in it
(``finger_gap``), and the pads span 0.03 to 0.005 m before the grasp centre along the sensor's
z. An object between the pads is grasped (attached by a fixed constraint) when the pads reach
its ``grasp_half_width`` and released when they open beyond it. ``/joint_states`` reports each
gripper joint at the virtual position. ``friction`` mode simulates the gripper: it needs two
prismatic fingers, which a gear constraint couples as the URDF's mimic does (the Panda's
hand), and refuses other grippers.

Exactness
---------
- The solver runs a fixed number of iterations (``solverResidualThreshold=0``). With pybullet's
  default early exit the held arm settles into a 2- or 3-step limit cycle of up to 0.013 N on
  the sensor; with the fixed count a held pose reads the static wrench to ~2e-4 N.
- Each step's true wrench (``wrench``) is the mean of the last two steps' readings (a 2-tap
  anti-alias filter, a zero at 500 Hz): it removes any remaining two-step oscillation and
  delays the signal by half a step.
- Bullet feeds the motor, limit and coupling forces of movable joints beyond the sensor into
  the sensor joint's reading as a false wrench. In ``rigid`` mode there are none, and the
  reading equals the gravity wrench of hand + object to 2e-4 N and 1e-5 N m at any orientation
  (both robots). In ``friction`` mode the Panda's fingers are the real prismatic joints and the
  static error is ~0.11 kg times the gravity component along the finger axis (1.05 N,
  0.10 N m with gravity along it; <= 0.06 N, 0.011 N m with gravity across it), measured by
  ``test/test_sim_physics.py``.

Collisions
----------
Every 10 ms the world looks up the contacts of the arm's moving links with the ground and the
stand, and of a held object with the ground. Each contact that begins is an event
``collision: ... touches ...`` (counted by ``collisions``); its end is an event ``... no longer
touches ...``. The object on its stand and the fingers on the object are not looked up.

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
within 0.1 s of the push's end it is back to 4e-10 N (measured by ``test/test_sim_physics.py``
on the Panda).
"""

from __future__ import annotations

import functools
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio
import pybullet
import pybullet_data
from numpy.typing import NDArray
from pybullet_utils.bullet_client import BulletClient

from com_core.robot.config import (
    RobotConfig,
    default_robot_config,
    grasp_point,
    robot_problems,
    urdf_file,
)
from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.wrench_model import STANDARD_GRAVITY
from wrench_sim.objects import SHAPES, ObjectSpec, create_object_body, object_spec
from wrench_sim.sensor import random_streams
from wrench_sim.trajectory import JointLimits, QuinticTrajectory, trajectory_from_command
from wrench_sim.vibration import Vibration

__all__ = [
    "GRASP_MODES",
    "PUSH_FRAMES",
    "SENSOR_FRAME",
    "STEP_NS",
    "TIME_STEP",
    "WORLD_FRAME",
    "ArmWorld",
    "SimConfig",
]

TIME_STEP = 1e-3
"""s; physics step (1 kHz)."""
STEP_NS = 1_000_000
GRASP_MODES = ("rigid", "friction")
WORLD_FRAME = "world"
SENSOR_FRAME = "ft_sensor"
PUSH_FRAMES = (WORLD_FRAME, SENSOR_FRAME)
"""The frames a push (``ArmWorld.apply_wrench``) may be given in."""

_MOVABLE = ("revolute", "continuous", "prismatic")
_OBJECT_TOP = -0.04  # m along sensor z from the grasp centre: the object's top at pick
_PAD_SPAN = (-0.03, -0.005)  # m along sensor z from the grasp centre: the finger pads
_STAND_HALF_WIDTH = 0.03
_SOLVER_ITERATIONS = {"rigid": 20, "friction": 50}  # finger contacts need more
_POSITION_GAIN = 0.1
_VELOCITY_GAIN = 1.0
_GRIPPER_STROKE_TIME = 0.4  # s from open to closed
_GEAR_FORCE = 50.0  # N
_GRASP_CENTRE_TOLERANCE = 0.02  # m; object centre off the grasp centre across sensor z
_RELEASE_GAP = 1e-3  # m; pads this far beyond the object's half width release it
_BOOKKEEPING_STEPS = 10  # grasp, settle, slip and collision checks every 10 ms
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
    """The scene: robot, object, grasp mode and hand.

    Attributes
    ----------
    robot : the arm (``com_core.robot.config``); default the Panda's configuration.
    object_shape : 'box', 'cylinder' or 'mug'.
    object_mass : kg.
    object_com_offset : m, object frame, COM minus geometric centre, inside
        ``objects.holdable_com_range(object_shape)`` (``ArmWorld`` refuses others with a
        ValueError stating the range); None draws it from ``seed`` (uniform inside the body's
        inner half, which lies in that range).
    seed : seeds the COM draw, the sensor noise and the grasp shifts (separate streams).
    grasp_mode : 'rigid' (a fixed constraint; the paper's immobilised object) or 'friction'
        (finger contact; the object may slip; two prismatic fingers only, the Panda's).
    slip_sigma : m; rigid mode only: at each new tilt the object is re-attached shifted by a
        N(0, slip_sigma^2 I) vector in ``ft_sensor`` (the paper's reconfiguration).
    hand_mass : kg; total mass of the links beyond the sensor (hand or gripper, fingers),
        0 = the URDF's (Panda 1.01 kg). Scales their masses alike, so their COM is unchanged.
    grip_force : N; friction mode: force limit of each finger's position controller.
    home_joints : rad; the arm's initial joint positions, one per ``robot.arm_joints``;
        None = ``robot.home_joints``.
    gui : open pybullet's window instead of running headless (DIRECT).
    vibration : the arm's structural modes, (frequency Hz, damping ratio) each
        (``wrench_sim.vibration``); empty: a rigid arm. vibration_gain : their participation.
    """

    robot: RobotConfig = field(default_factory=default_robot_config)
    object_shape: str = "box"
    object_mass: float = 0.1
    object_com_offset: tuple[float, float, float] | None = None
    seed: int = 0
    grasp_mode: str = "rigid"
    slip_sigma: float = 0.0
    hand_mass: float = 0.0
    grip_force: float = 5.0
    home_joints: tuple[float, ...] | None = None
    gui: bool = False
    vibration: tuple[tuple[float, float], ...] = ()
    vibration_gain: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.robot, RobotConfig):
            raise ValueError(f"robot must be a RobotConfig, got {type(self.robot).__name__}")
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
        joints = len(self.robot.arm_joints)
        if self.home_joints is not None and (
            len(self.home_joints) != joints or not np.all(np.isfinite(self.home_joints))
        ):
            raise ValueError(
                f"home_joints must be {joints} finite values (rad, "
                f"{', '.join(self.robot.arm_joints)}), got {self.home_joints}"
            )
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")

    @property
    def home(self) -> tuple[float, ...]:
        """rad; the arm's initial joint positions (``home_joints`` or the robot's)."""
        return self.robot.home_joints if self.home_joints is None else tuple(self.home_joints)


# ----------------------------------------------------------------- the URDF
def _read_urdf(robot: RobotConfig) -> ET.Element:
    """The root element of the configuration's URDF (``robot_config.urdf_file``), its mesh
    files made absolute: ``package://<path>`` and relative paths are taken from the URDF's
    directory, where pybullet looks for them."""
    path = urdf_file(robot)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as error:
        raise ValueError(f"urdf {robot.urdf!r}: cannot read it ({error})") from error
    directory = os.path.dirname(os.path.abspath(path))
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "").removeprefix("package://")
        if filename and not os.path.isabs(filename) and "://" not in filename:
            mesh.set("filename", os.path.join(directory, filename))
    return root


def _joints_beyond(root: ET.Element, sensor_frame: str) -> tuple[ET.Element, list[ET.Element]]:
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
        raise ValueError(f"sensor_frame {sensor_frame!r} is no joint's child link in the URDF")
    beyond, links = [], [sensor_frame]
    while links:
        for joint in children.get(links.pop(), []):
            beyond.append(joint)
            links.append(joint.find("child").get("link"))
    return sensor, beyond


def _open_positions(joints: list[ET.Element], robot: RobotConfig) -> dict[str, float]:
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


def _fix_joint(joint: ET.Element, position: float) -> None:
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


class ArmWorld:
    """An arm on a fixed base with its gripper, a stand with an object, stepped at 1 kHz.

    Parameters
    ----------
    config : the scene.

    Raises
    ------
    ValueError naming what does not serve: a URDF that cannot be read, a frame or joint of
    the robot configuration it lacks, home (or pick) joints outside the joint limits,
    ``friction`` mode with a gripper other than two prismatic fingers, a COM offset the stand
    cannot hold.

    Notes
    -----
    After construction the world has run 0.2 s of warm-up (not counted in ``time_ns``) so the
    arm holds its home joints and the object rests on its stand.
    """

    def __init__(self, config: SimConfig | None = None) -> None:
        self.config = config or SimConfig()
        robot = self.config.robot
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
        home = np.asarray(self.config.home, dtype=np.float64)
        urdf = self._checked_urdf(home)
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
        self.robot_body = self._load_robot(urdf)
        self._limits = JointLimits(
            robot.arm_joints,
            np.array([c.getJointInfo(self.robot_body, j)[8] for j in self._arm]),
            np.array([c.getJointInfo(self.robot_body, j)[9] for j in self._arm]),
            np.array([c.getJointInfo(self.robot_body, j)[11] for j in self._arm]),
        )
        self._efforts = [c.getJointInfo(self.robot_body, j)[10] for j in self._arm]
        self._scale_hand_mass()
        self._plane = c.loadURDF("plane.urdf")
        self._stand, self.object_body = self._load_stand_and_object()
        self._constraint: int | None = None
        self._hand_truth: tuple[float, NDArray[np.float64]] | None = None
        self.events: list[str] = []
        self._touching: set[tuple[str, str]] = set()  # (what, obstacle) in contact
        self._collisions = 0
        self._steps = 0
        self._trajectory: QuinticTrajectory | None = None
        self._queued: QuinticTrajectory | None = None  # starts later (command_arm)
        zeros = np.zeros(len(self._arm))
        self._set_point = (home.copy(), zeros, zeros)
        # the virtual gripper (rigid mode): 0 open .. 1 closed
        self._closure = self._closure_target = 0.0
        self._closure_step = TIME_STEP / _GRIPPER_STROKE_TIME
        gap_open, gap_closed = robot.finger_gap
        self._held_closure = (gap_open - self.object.geometry.grasp_half_width) / (
            gap_open - gap_closed
        )  # the pads on the object
        self._held = False
        self._joint_names = robot.arm_joints + robot.gripper_joints
        self._pushes: list[_Push] = []
        # the last step's pushes: world force and torque, then ft_sensor force and torque
        self._applied: tuple[NDArray[np.float64], ...] | None = None
        self._still_steps = 0
        self._R_at_shift: NDArray[np.float64] | None = None
        for joint, q in zip(self._arm, home, strict=True):
            c.resetJointState(self.robot_body, joint, q)
        self._hold_arm(home, zeros)
        if not self._rigid:
            for joint in self._fingers:
                c.resetJointState(self.robot_body, joint, robot.gripper_open)
            # The real gripper's fingers are coupled (the URDF's mimic tag, which pybullet
            # ignores): without the gear, both fingers pushing at their force limit would let
            # fingers and object slide together along the finger axis to one finger's limit.
            gear = c.createConstraint(
                self.robot_body,
                self._fingers[0],
                self.robot_body,
                self._fingers[1],
                pybullet.JOINT_GEAR,
                c.getJointInfo(self.robot_body, self._fingers[0])[13],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
            )
            c.changeConstraint(gear, gearRatio=-1.0, erp=0.1, maxForce=_GEAR_FORCE)
            self._drive_fingers(robot.gripper_open)
        c.enableJointForceTorqueSensor(self.robot_body, self._sensor, True)
        self._raw = np.zeros(6)
        self._previous_raw = np.zeros(6)
        modes = self.config.vibration
        gain = self.config.vibration_gain
        self._vibration = Vibration(modes, TIME_STEP, gain) if modes else None
        self._load = self._load_now() if modes else (0.0, np.zeros(3))
        for _ in range(_WARM_UP_STEPS):
            self._physics_step()
        self._previous_raw = self._raw.copy()
        self.events.clear()

    # ----------------------------------------------------------------- construction
    def _checked_urdf(self, home: NDArray[np.float64]) -> ET.Element:
        """The configuration's URDF, checked against it: its frames and joints, home and pick
        within the joint limits, and in friction mode two prismatic fingers. Sets the grasp
        centre ``_grasp`` (m, ft_sensor), the sensor joint ``_sensor_joint`` and the joints
        beyond it ``_beyond``."""
        robot = self.config.robot
        root = _read_urdf(robot)
        try:
            model = RobotModel(ET.tostring(root, encoding="unicode"), robot.sensor_frame)
            problems = robot_problems(replace(robot, home_joints=tuple(home.tolist())), model)
        except KinematicsError as error:
            problems = [str(error)]
        if problems:
            raise ValueError(f"robot {robot.robot} ({robot.urdf}): {'; '.join(problems)}")
        self._grasp = grasp_point(robot, model)
        self._sensor_joint, self._beyond = _joints_beyond(root, robot.sensor_frame)
        if self._sensor_joint.get("type") != "fixed":
            raise ValueError(
                f"robot {robot.robot}: the joint before sensor_frame {robot.sensor_frame!r} "
                f"({self._sensor_joint.get('name')}) is {self._sensor_joint.get('type')}: the "
                "sensor reads a fixed joint"
            )
        if beyond := set(robot.arm_joints) & {j.get("name") for j in self._beyond}:
            raise ValueError(
                f"robot {robot.robot}: arm_joints {', '.join(sorted(beyond))} lie beyond "
                f"sensor_frame {robot.sensor_frame!r}"
            )
        if not self._rigid:
            types = {j.get("name"): j.get("type") for j in self._beyond}
            fingers = [types.get(name) for name in robot.gripper_joints]
            if fingers != ["prismatic", "prismatic"]:
                raise ValueError(
                    f"grasp_mode 'friction' needs two prismatic finger joints (the Panda's "
                    f"hand); robot {robot.robot} has gripper_joints "
                    f"{', '.join(robot.gripper_joints)}: use grasp_mode 'rigid'"
                )
        return root

    def _load_robot(self, root: ET.Element) -> int:
        """Load the robot (rigid mode: the movable joints beyond the sensor fixed open);
        ``urdf_text`` is what was loaded, as ``/robot_description`` publishes it."""
        c, robot = self._client, self.config.robot
        if self._rigid:
            positions = _open_positions(self._beyond, robot)
            for joint in self._beyond:
                if joint.get("type") in _MOVABLE:
                    _fix_joint(joint, positions.get(joint.get("name"), 0.0))
        self.urdf_text = ET.tostring(root, encoding="unicode")
        with tempfile.TemporaryDirectory(prefix="wrench_sim_") as directory:
            path = os.path.join(directory, f"{robot.robot}.urdf")
            with open(path, "w", encoding="utf-8") as stream:
                stream.write(self.urdf_text)
            body = c.loadURDF(path, useFixedBase=True)
        infos = [c.getJointInfo(body, j) for j in range(c.getNumJoints(body))]
        joints = {info[1].decode(): info[0] for info in infos}
        links = {info[12].decode(): info[0] for info in infos}
        self._link_names = {index: name for name, index in links.items()}
        self._arm = [joints[name] for name in robot.arm_joints]
        self._sensor = joints[self._sensor_joint.get("name")]  # also its child link's index
        beyond = [links[j.find("child").get("link")] for j in self._beyond]
        self._load_links = (self._sensor, *beyond)
        self._fingers = () if self._rigid else tuple(joints[n] for n in robot.gripper_joints)
        # links fixed to the base: they never move, their contact with the ground is expected
        self._base_links = {-1}
        for info in infos:
            if info[2] == pybullet.JOINT_FIXED and info[16] in self._base_links:
                self._base_links.add(info[0])
        return body

    def _scale_hand_mass(self) -> None:
        if self.config.hand_mass <= 0.0:
            return
        c, body = self._client, self.robot_body
        urdf_mass = sum(c.getDynamicsInfo(body, link)[0] for link in self._load_links)
        factor = self.config.hand_mass / urdf_mass
        for link in self._load_links:
            info = c.getDynamicsInfo(body, link)
            if info[0] > 0.0:
                c.changeDynamics(
                    body,
                    link,
                    mass=info[0] * factor,
                    localInertiaDiagonal=[i * factor for i in info[2]],
                )

    def _load_stand_and_object(self) -> tuple[int, int]:
        """The stand and the object on it (see module, Scene); the arm is at pick_joints
        meanwhile. Returns their pybullet body ids."""
        c = self._client
        for joint, q in zip(self._arm, self.config.robot.pick_joints, strict=True):
            c.resetJointState(self.robot_body, joint, q)
        origin, R = self.sensor_pose()
        grasp = origin + R @ self._grasp  # m, world
        if R[2, 2] > -0.99:
            raise ValueError(
                f"pick_joints {list(self.config.robot.pick_joints)}: the sensor's z must point "
                f"down at pick (it is {np.degrees(np.arccos(-R[2, 2])):.1f} deg off)"
            )
        top_z = (
            grasp[2] + _OBJECT_TOP * R[2, 2]
        )  # the top on the sensor's z through the grasp centre
        height = self.object.geometry.height
        bottom_z = top_z - height
        if bottom_z <= 0.0:
            raise ValueError(
                f"pick_joints {list(self.config.robot.pick_joints)}: the grasp centre is "
                f"{grasp[2]:.3f} m above the ground, too low for a {height:.3f} m object"
            )
        half = [_STAND_HALF_WIDTH, _STAND_HALF_WIDTH, bottom_z / 2.0]
        stand = c.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half),
            baseVisualShapeIndex=c.createVisualShape(
                pybullet.GEOM_BOX, halfExtents=half, rgbaColor=[0.5, 0.5, 0.55, 1.0]
            ),
            basePosition=[grasp[0], grasp[1], bottom_z / 2.0],
        )
        c.changeDynamics(stand, -1, lateralFriction=1.0)
        centre = [grasp[0], grasp[1], bottom_z + height / 2.0]
        return stand, create_object_body(c, self.object, centre)

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
        if self._rigid and self._closure != self._closure_target:
            self._move_virtual_gripper()
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
        self._raw = np.negative(self._get_joint_state(self.robot_body, self._sensor)[2])
        if self._vibration is not None:
            self._raw = self._raw + self._ringing()

    def _ringing(self) -> NDArray[np.float64]:
        """The wrench (6,) the load's reaction to the structure's vibration adds to the
        reading (``wrench_sim.vibration``); N, N m; ft_sensor."""
        state = self._client.getLinkState(
            self.robot_body, self._sensor, computeLinkVelocity=1, computeForwardKinematics=1
        )
        R = np.array(self._client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        assert self._vibration is not None
        moving = self._trajectory is not None
        accel = R.T @ self._vibration.step(np.array(state[6]), moving)
        mass, com = self._load
        force = -mass * accel
        return np.concatenate([force, np.cross(com, force)])

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
        joint_names : a subset of the robot's ``arm_joints``, any order.
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
        """Move every arm joint to ``positions`` (rad, ``arm_joints`` order) in ``duration`` s
        and wait until settled."""
        self.command_arm(self.config.robot.arm_joints, [duration], [positions])
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
            self.robot_body,
            self._arm,
            pybullet.POSITION_CONTROL,
            targetPositions=position.tolist(),
            targetVelocities=velocity.tolist(),
            forces=self._efforts,
            positionGains=[_POSITION_GAIN] * len(self._arm),
            velocityGains=[_VELOCITY_GAIN] * len(self._arm),
        )

    # ----------------------------------------------------------------- gripper
    def command_gripper(self, position: float) -> None:
        """Move the gripper to ``position``, in its command's units (m or rad): from the
        configuration's ``gripper_open`` to ``gripper_closed``.

        Closing on the object grasps it; opening releases it. Raises ValueError for a value
        outside that range or not finite.
        """
        robot = self.config.robot
        low, high = sorted((robot.gripper_open, robot.gripper_closed))
        if not (np.isfinite(position) and low <= position <= high):
            raise ValueError(
                f"gripper position must be in [{low}, {high}] (open {robot.gripper_open}, "
                f"closed {robot.gripper_closed}), got {position}"
            )
        self._closure_target = robot.gripper_closed_fraction(float(position))
        if not self._rigid:
            self._drive_fingers(float(position))

    def _drive_fingers(self, position: float) -> None:
        """Friction mode: both finger joints to ``position`` (m) at the gripper's speed."""
        robot = self.config.robot
        speed = abs(robot.gripper_closed - robot.gripper_open) / _GRIPPER_STROKE_TIME
        for joint in self._fingers:
            self._client.setJointMotorControl2(
                self.robot_body,
                joint,
                pybullet.POSITION_CONTROL,
                targetPosition=position,
                force=self.config.grip_force,
                maxVelocity=speed,
            )

    def _gap(self, closure: float) -> float:
        """m; each pad's distance from the grasp centre at ``closure`` (0 open, 1 closed)."""
        gap_open, gap_closed = self.config.robot.finger_gap
        return gap_open + closure * (gap_closed - gap_open)

    def _move_virtual_gripper(self) -> None:
        """Rigid mode: the gripper is drawn, not simulated; grasp when its pads reach the
        object, release when they open beyond it."""
        step, target, closure = self._closure_step, self._closure_target, self._closure
        closure = min(target, closure + step) if target > closure else max(target, closure - step)
        width = self.object.geometry.grasp_half_width
        if self._held:
            if self._gap(closure) > width + _RELEASE_GAP:
                self._release()
            else:
                closure = min(closure, self._held_closure)
        elif (
            self._gap(self._closure) > width >= self._gap(closure) and self._object_between_pads()
        ):
            closure = self._held_closure
            self._attach()
        self._closure = closure

    def _object_between_pads(self) -> bool:
        centre = self._object_centre_in_sensor() - self._grasp
        z_half = self.object.geometry.half_extents[2]
        return (
            abs(centre[0]) <= _GRASP_CENTRE_TOLERANCE
            and abs(centre[1]) <= _GRASP_CENTRE_TOLERANCE
            and centre[2] - z_half < _PAD_SPAN[1]
            and centre[2] + z_half > _PAD_SPAN[0]
        )

    def _attach(self) -> None:
        c = self._client
        hand_position, hand_orientation = c.getLinkState(self.robot_body, self._sensor)[:2]
        object_position, object_orientation = c.getBasePositionAndOrientation(self.object_body)
        inverse = c.invertTransform(hand_position, hand_orientation)
        relative = c.multiplyTransforms(*inverse, object_position, object_orientation)
        for link in self._load_links:
            c.setCollisionFilterPair(self.robot_body, self.object_body, link, -1, 0)
        self._constraint = c.createConstraint(
            self.robot_body,
            self._sensor,
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
        for link in self._load_links:
            c.setCollisionFilterPair(self.robot_body, self.object_body, link, -1, 1)
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
        """The object is in the gripper (rigid: attached; friction: touched by both
        fingers)."""
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
            turns with the hand; the configuration's ``sensor_frame``).
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
        """Every 10 ms: friction grasp state, arm settling, the rigid grasp's shifts and
        collisions."""
        c = self._client
        if not self._rigid:
            touching = all(
                c.getContactPoints(self.robot_body, self.object_body, finger, -1)
                for finger in self._fingers
            )
            if touching != self._held:
                self._held = touching
                state = "grasped (finger contact)" if touching else "released (no finger contact)"
                self._event(f"{self.object.shape} {state}")
        speeds = [abs(state[1]) for state in c.getJointStates(self.robot_body, self._arm)]
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
        self._look_for_collisions()
        if self._vibration is not None:
            self._load = self._load_now()

    def _load_now(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (m, ft_sensor) of everything beyond the sensor: the hand and a
        held object."""
        mass, com = self.hand_ground_truth()
        if self.object_held:
            m, c = self.object_ground_truth()
            com, mass = (mass * com + m * c) / (mass + m), mass + m
        return mass, com

    def _look_for_collisions(self) -> None:
        """Record each contact of a moving arm link with the ground or the stand, and of the
        held object with the ground, when it begins and when it ends (see module)."""
        c, body = self._client, self.robot_body
        touching = set()
        for obstacle, name in ((self._plane, "the ground"), (self._stand, "the stand")):
            for point in c.getContactPoints(body, obstacle):
                if point[3] not in self._base_links:
                    touching.add((f"link {self._link_names[point[3]]}", name))
        if self._held and c.getContactPoints(self.object_body, self._plane):
            touching.add((f"the held {self.object.shape}", "the ground"))
        if touching == self._touching:
            return
        for what, obstacle in sorted(touching - self._touching):
            self._collisions += 1
            self._event(f"collision: {what} touches {obstacle}")
        for what, obstacle in sorted(self._touching - touching):
            self._event(f"{what} no longer touches {obstacle}")
        self._touching = touching

    @property
    def collisions(self) -> int:
        """How many contacts of the arm with the ground or the stand, or of the held object
        with the ground, have begun since the start (see module, Collisions)."""
        return self._collisions

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
        state = self._client.getLinkState(
            self.robot_body, self._sensor, computeForwardKinematics=True
        )
        R = np.array(self._client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        return np.array(state[4]), R

    def gravity_in_sensor(self) -> NDArray[np.float64]:
        """Gravity (3,) in m/s^2 expressed in ``ft_sensor``."""
        return self.sensor_pose()[1].T @ np.array([0.0, 0.0, -STANDARD_GRAVITY])

    def hand_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the links beyond the sensor (hand or
        gripper, fingers; URDF inertials, scaled by ``hand_mass``).

        Constant in rigid mode (fixed fingers); in friction mode it follows the fingers.
        """
        if self._hand_truth is None or not self._rigid:
            self._hand_truth = self._hand_ground_truth()
        return self._hand_truth[0], self._hand_truth[1].copy()

    def _hand_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        c = self._client
        origin, R = self.sensor_pose()
        mass, moment = 0.0, np.zeros(3)
        for link in self._load_links:
            link_mass = c.getDynamicsInfo(self.robot_body, link)[0]
            com_world = np.array(
                c.getLinkState(self.robot_body, link, computeForwardKinematics=True)[0]
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
        """Names (the configuration's ``arm_joints`` then ``gripper_joints``), positions
        (rad, m), velocities and efforts (N m, N) of arm and gripper.

        In rigid mode the gripper's links are fixed; each gripper joint reports the virtual
        gripper's position (stopping where the pads meet the object when it is grasped).
        """
        states = self._client.getJointStates(self.robot_body, self._arm)
        positions = [s[0] for s in states]
        velocities = [s[1] for s in states]
        efforts = [s[3] for s in states]
        if self._rigid:
            robot = self.config.robot
            stroke = robot.gripper_closed - robot.gripper_open
            count = len(robot.gripper_joints)
            target, closure = self._closure_target, self._closure
            on_object = self._held and closure == self._held_closure < target
            speed = float(np.sign(target - closure)) * stroke / _GRIPPER_STROKE_TIME
            positions += [robot.gripper_open + closure * stroke] * count
            velocities += [0.0 if closure == target or on_object else speed] * count
            efforts += [0.0] * count
        else:
            fingers = self._client.getJointStates(self.robot_body, list(self._fingers))
            positions += [s[0] for s in fingers]
            velocities += [s[1] for s in fingers]
            efforts += [s[3] for s in fingers]
        return self._joint_names, positions, velocities, efforts

    def close(self) -> None:
        """Disconnect from pybullet."""
        if self._client._client >= 0:
            self._client.disconnect()
