"""The simulator driven from a script, without ROS: the grasp and an excitation read
through a sensor, and a whole exploration in motion, as offline studies
(``bench/motion.py``, ``bench/motion_check.py``) and tests run them."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from com_core.contract import (
    DONE,
    JOINT_STATES_TOPIC,
    MOTION_LEAD,
    MOTION_OBJECT,
    MOTION_REST,
    MOTION_TARE,
    MOTION_VERIFY,
    MOVING,
    ROBOT_DESCRIPTION_TOPIC,
    WRENCH_TOPIC,
)
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.inbox import Inbox
from com_core.estimation.runs.settings import exploration_from
from com_core.estimation.runs.solution import Solution
from com_core.planning.excitation import DEFAULT_ACCELERATION, Excitation, design_excitation
from com_core.robot.config import read_robot_config
from com_core.robot.model import RobotModel
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.config import TIME_STEP, SimConfig
from wrench_sim.joint_torques import wrench_in
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import WrenchSensor, profile_sensor

__all__ = [
    "MotionRun",
    "Way",
    "explore_in_motion",
    "feed",
    "grasp",
    "hold_still",
    "joined",
    "move_arm",
    "record_until",
    "record_wandering",
    "run",
    "run_excitation",
    "without_rest",
    "write_recording_bag",
]


SENSOR_CATCH_UP = 0.3
"""s (sim) a sensor not read through a stretch of the world is read at rest after it,
before a recording: the sim node reads its sensor every step, so its low-pass (5 ms)
follows every change of load, where one read again only after a lift starts from the
load before it (16 N off for 20 ms after lifting 2 kg)."""


Way = tuple[NDArray[np.float64], NDArray[np.float64]]
"""What a sensor read on a way between the readings a study keeps: (stamps s (n,),
readings N and N m (n, 6) in ``ft_sensor``); n = 0 where it was not read (``run``)."""


def grasp(
    world: ArmWorld,
    seconds: float = 3.0,
    sensor: WrenchSensor | None = None,
    catch_up: float = SENSOR_CATCH_UP,
) -> Way:
    """Pick the object from its stand and lift it to the home pose, each move in
    ``seconds``; then, with ``sensor``, read it ``catch_up`` s at home. The ``Way`` there
    (``run``). RuntimeError when the gripper does not hold it."""
    robot = world.config.robot
    ways = [move_arm(world, robot.pick_joints, seconds, sensor)]
    world.command_gripper(robot.gripper_closed)
    ways.append(run(world, 0.5, sensor))
    if not world.object_held:
        raise RuntimeError(f"the grasp failed: {world.events}")
    ways.append(move_arm(world, robot.home_joints, seconds, sensor))
    if sensor is not None and catch_up > 0.0:
        ways.append(hold_still(world, sensor, catch_up)[2:])
    return joined(ways)


def move_arm(
    world: ArmWorld, joints: Sequence[float], seconds: float, sensor: WrenchSensor | None = None
) -> Way:
    """``ArmWorld.move_arm``, the same steps: the ``Way`` (``run``)."""
    world.command_move(joints, seconds)
    ways = [run(world, seconds, sensor)]
    while not world.arm_settled:
        ways.append(run(world, TIME_STEP, sensor))
    return joined(ways)


def run(world: ArmWorld, seconds: float, sensor: WrenchSensor | None = None) -> Way:
    """``ArmWorld.run``, the same steps. A ``sensor`` whose gauges remember the load's
    way (a strain gauge's hysteresis) is read at every step, as the sim node reads it,
    and the ``Way`` is those readings; another is not read (none given: neither), which
    leaves its next readings as they were."""
    stamps, readings = [], []
    reads = sensor is not None and sensor.gauges is not None
    for _ in range(round(seconds / TIME_STEP)):
        world.step()
        if reads:
            stamps.append(world.time)
            readings.append(sensor.read(wrench_in(world, sensor.joint_torques), world.time))
    return np.array(stamps), np.array(readings).reshape(-1, 6)


def joined(ways: Sequence[Way]) -> Way:
    """One ``Way`` of ``ways`` in turn."""
    return np.concatenate([w[0] for w in ways]), np.vstack([w[1] for w in ways])


def run_excitation(
    world: ArmWorld, excitation: Excitation, sensor: WrenchSensor, joint_every: int = 1
) -> tuple[NDArray[np.float64], ...]:
    """Run ``excitation`` from home, as the sequencer sends it: ``MOTION_LEAD`` s from now,
    and ``MOTION_REST`` s at rest after it (``record_until`` then); the wrenches from its
    start (a ``motion/`` span's), the joint states from now."""
    robot = world.config.robot
    times, q, dq, ddq = excitation.waypoints(robot.arm_joints)
    start = world.time + MOTION_LEAD
    end = world.command_arm(robot.arm_joints, times, q, start, dq, ddq)
    joint_times, positions, stamps, readings = record_until(world, sensor, end + MOTION_REST,
                                                            joint_every)  # fmt: skip
    moving = stamps >= start
    return joint_times, positions, stamps[moving], readings[moving]


def without_rest(recorded: tuple[NDArray[np.float64], ...]) -> tuple[NDArray[np.float64], ...]:
    """What the estimator fits of a ``run_excitation`` recording (``motion_solution``):
    its wrenches but the last ``MOTION_REST`` s, the joint states all."""
    joint_times, positions, stamps, readings = recorded
    moving = stamps <= stamps[-1] - MOTION_REST
    return joint_times, positions, stamps[moving], readings[moving]


def hold_still(
    world: ArmWorld, sensor: WrenchSensor, seconds: float, joint_every: int = 1
) -> tuple[NDArray[np.float64], ...]:
    """Hold the arm where it is for ``seconds``: ``record_until`` then."""
    return record_until(world, sensor, world.time + seconds, joint_every)


def record_until(
    world: ArmWorld, sensor: WrenchSensor, end: float, joint_every: int = 1
) -> tuple[NDArray[np.float64], ...]:
    """Step the world until sim time ``end`` (s): (joint stamps s, arm joint positions
    rad) every ``joint_every`` steps, and (wrench stamps s, readings N and N m in
    ``ft_sensor``) of ``sensor`` every step."""
    arm = len(world.config.robot.arm_joints)
    stamps, positions, readings = [], [], []
    while world.time < end:
        world.step()
        if len(stamps) % joint_every == 0:  # the joint states only where they are kept
            positions.append(world.joint_state()[1][:arm])
        stamps.append(world.time)
        readings.append(sensor.read(wrench_in(world, sensor.joint_torques), world.time))
    stamps = np.array(stamps)
    return stamps[::joint_every], np.array(positions), stamps, np.array(readings)


def feed(
    inbox: Inbox,
    world: ArmWorld,
    label: str,
    recorded: tuple[NDArray[np.float64], ...],
    way: Way | None = None,
) -> None:
    """Give ``inbox`` (an exploration's) what ``hold_still`` or ``run_excitation`` just
    ``recorded``, labelled ``label`` from its first sample and ``moving`` after its last,
    stamped in ns as the nodes stamp them; the ``way`` there first, moving."""
    if way is not None and len(way[0]):
        ns = np.rint(np.asarray(way[0]) * 1e9).astype(np.int64)
        inbox.add_samples(ns, way[1], ["ft_sensor"] * len(ns))
    joint_times, positions, times, readings = recorded
    ns = np.rint(np.asarray(times) * 1e9).astype(np.int64)
    inbox.add_label(int(ns[0]) - 1, label)
    inbox.add_samples(ns, readings, ["ft_sensor"] * len(ns))
    names = world.config.robot.arm_joints
    for t, q in zip(joint_times, positions, strict=True):
        inbox.add_joint_state(round(t * 1e9), names, list(q))
    inbox.add_label(int(ns[-1]) + 1, MOVING)


@dataclass
class MotionRun:
    """One exploration in motion in process: the world still holding the object, its
    sensor and robot model, the exploration fed and its solution."""

    world: ArmWorld
    sensor: WrenchSensor
    model: RobotModel
    exploration: Exploration
    solution: Solution


def explore_in_motion(
    calibration_accuracy: float,
    seed: int,
    joint_every: int = 10,
    cycles: int = 1,
    robot: str = "panda",
    mass: float = 0.5,
    shape: str = "box",
    object_seed: int = 3,
    period: float = 3.0,
    acceleration: float | Sequence[float] = DEFAULT_ACCELERATION,
    profile: str = "realistic",
    hand_cycles: int = 1,
) -> MotionRun:
    """As the sequencer runs ``excitation: motion`` on ``robot`` (a shipped configuration)
    with an object of ``mass`` kg and ``shape`` (its COM drawn from ``object_seed``): the
    empty hand at rest and along the D-optimal excitation of ``period`` s and
    ``acceleration`` bound (rad/s^2; ``hand_cycles`` periods, or ``cycles`` if more),
    the grasp, the object along it (``cycles`` periods) and along another design (one
    period); through the
    sensor of ``profile`` (``PROFILES``; the estimator told its datasheet) and serial
    ``seed`` with ``calibration_accuracy``,
    joint states every ``joint_every`` steps (10: 100 Hz); solved from its labels
    (``Exploration.solve``). The caller closes ``MotionRun.world``."""
    world = ArmWorld(SimConfig(robot=read_robot_config(robot), object_shape=shape,
                               object_mass=mass, seed=object_seed))  # fmt: skip
    stated = PROFILES[profile].with_overrides(calibration_accuracy=calibration_accuracy)
    sensor = profile_sensor(stated, seed=seed, serial=seed, world=world)
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    wrist = robot.arm_joints[-3:]
    excitation = design_excitation(model, robot.home_joints, wrist, period, acceleration,
                                   iterations=40)  # fmt: skip
    excitation = replace(excitation, cycles=cycles)
    other = design_excitation(model, robot.home_joints, wrist, period, acceleration,
                              iterations=40, seed=5)  # fmt: skip
    settings = {"accuracy": calibration_accuracy} | stated.datasheet() | {
        "information": "kinematics", "sensor_frame": robot.sensor_frame}  # fmt: skip
    exploration = exploration_from(settings, world.urdf_text)
    move_arm(world, robot.home_joints, 1.0, sensor)
    feed(exploration, world, "tare/home", hold_still(world, sensor, 2.0, joint_every))
    hand = replace(excitation, cycles=max(cycles, hand_cycles))
    feed(exploration, world, MOTION_TARE, run_excitation(world, hand, sensor, joint_every))
    grasp(world, sensor=sensor)
    feed(exploration, world, MOTION_OBJECT, run_excitation(world, excitation, sensor, joint_every))
    feed(exploration, world, MOTION_VERIFY, run_excitation(world, other, sensor, joint_every))
    exploration.add_label(round(world.time * 1e9), DONE)
    return MotionRun(world, sensor, model, exploration, exploration.solve())


def record_wandering(
    world: ArmWorld,
    sensor: WrenchSensor,
    rng: np.random.Generator,
    duration: float = 40.0,
    speed: float = 0.1,
    tilt: float = 0.8,
    joint_every: int = 10,
) -> tuple[NDArray[np.float64], ...]:
    """A teleoperated-like recording from where the arm is (the object held): slow moves
    (the largest joint at ``speed`` rad/s, rest to rest) to random wrist targets, each
    wrist joint within ``tilt`` rad of its start and the others within a tenth of it,
    kept inside the joint limits, with rests of 0.3-3 s between them, for ``duration`` s;
    ``record_until``'s arrays (joint states every ``joint_every`` steps)."""
    robot = world.config.robot
    start = np.array(world.joint_state()[1][: len(robot.arm_joints)])
    limits = RobotModel(world.urdf_text, robot.sensor_frame).joint_limits()
    low = np.array([limits[name][0] for name in robot.arm_joints]) + 0.05
    high = np.array([limits[name][1] for name in robot.arm_joints]) - 0.05
    spread = np.full(len(start), tilt / 10)
    spread[-3:] = tilt
    parts, end = [], world.time + duration
    here = start
    while world.time < end:
        parts.append(hold_still(world, sensor, rng.uniform(0.3, 3.0), joint_every))
        target = np.clip(start + rng.uniform(-1.0, 1.0, len(start)) * spread, low, high)
        seconds = max(float(np.max(np.abs(target - here))) / speed, 0.5)
        move_end = world.command_move(target.tolist(), seconds)
        parts.append(record_until(world, sensor, move_end, joint_every))
        here = target
    return tuple(np.concatenate([part[k] for part in parts]) for k in range(4))


def write_recording_bag(
    path: str,
    recorded: tuple[NDArray[np.float64], ...],
    joint_names: tuple[str, ...],
    urdf: str,
    wrench_every: int = 4,
) -> None:
    """Write ``recorded`` (``record_until``'s arrays) as a rosbag2 (MCAP) of another
    recorder, rosbags': /ft_sensor/wrench (every ``wrench_every``-th reading, frame
    ``ft_sensor``), /joint_states and /robot_description (``urdf``), stamped as a
    driver stamps them (header and log time the same)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    msgs = store.types
    Time, Header = msgs["builtin_interfaces/msg/Time"], msgs["std_msgs/msg/Header"]
    Vector3 = msgs["geometry_msgs/msg/Vector3"]

    def header(t: float, frame: str):
        ns = round(t * 1e9)
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame), ns

    joint_times, positions, times, readings = recorded
    messages = []
    for t, w in zip(times[::wrench_every], readings[::wrench_every], strict=True):
        h, ns = header(t, "ft_sensor")
        wrench = msgs["geometry_msgs/msg/Wrench"](force=Vector3(*w[:3]), torque=Vector3(*w[3:]))
        messages.append(
            (
                ns,
                WRENCH_TOPIC,
                msgs["geometry_msgs/msg/WrenchStamped"](header=h, wrench=wrench),
            )
        )
    for t, q in zip(joint_times, positions, strict=True):
        h, ns = header(t, "")
        state = msgs["sensor_msgs/msg/JointState"](
            header=h,
            name=list(joint_names),
            position=np.asarray(q, dtype=np.float64),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )
        messages.append((ns, JOINT_STATES_TOPIC, state))
    description = msgs["std_msgs/msg/String"](data=urdf)
    messages.append((round(times[0] * 1e9), ROBOT_DESCRIPTION_TOPIC, description))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for _, topic, msg in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msg.__msgtype__, typestore=store)
        for ns, topic, msg in sorted(messages, key=lambda m: m[0]):
            raw = store.serialize_cdr(msg, msg.__msgtype__)
            writer.write(connections[topic], ns, raw)
