"""The simulator driven from a script, without ROS: the grasp and an excitation read
through a sensor, and a whole exploration in motion, as offline studies
(``bench/motion.py``, ``bench/motion_check.py``) and tests run them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from com_core.contract import DONE, MOTION_OBJECT, MOTION_TARE, MOTION_VERIFY, MOVING
from com_core.estimation.exploration import Exploration
from com_core.estimation.inbox import Inbox
from com_core.estimation.settings import exploration_from
from com_core.estimation.solution import Solution
from com_core.planning.excitation import Excitation, design_excitation
from com_core.robot.model import RobotModel
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.config import SimConfig
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import WrenchSensor, profile_sensor

__all__ = [
    "MotionRun",
    "explore_in_motion",
    "feed",
    "grasp",
    "hold_still",
    "record_until",
    "run_excitation",
]


def grasp(world: ArmWorld, seconds: float = 3.0) -> None:
    """Pick the object from its stand and lift it to the home pose, each move in
    ``seconds``; RuntimeError when the gripper does not hold it."""
    robot = world.config.robot
    world.move_arm(robot.pick_joints, seconds)
    world.command_gripper(robot.gripper_closed)
    world.run(0.5)
    if not world.object_held:
        raise RuntimeError(f"the grasp failed: {world.events}")
    world.move_arm(robot.home_joints, seconds)


def run_excitation(
    world: ArmWorld, excitation: Excitation, sensor: WrenchSensor, joint_every: int = 1
) -> tuple[NDArray[np.float64], ...]:
    """Run ``excitation`` from home now, and 0.3 s at rest after it: ``record_until``
    its end."""
    robot = world.config.robot
    times, q, dq, ddq = excitation.waypoints(robot.arm_joints)
    end = world.command_arm(robot.arm_joints, times, q, 0.0, dq, ddq)
    return record_until(world, sensor, end + 0.3, joint_every)


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
        readings.append(sensor.read(world.wrench, world.time))
    stamps = np.array(stamps)
    return stamps[::joint_every], np.array(positions), stamps, np.array(readings)


def feed(
    inbox: Inbox, world: ArmWorld, label: str, recorded: tuple[NDArray[np.float64], ...]
) -> None:
    """Give ``inbox`` (an exploration's) what ``hold_still`` or ``run_excitation`` just
    ``recorded``, labelled ``label`` from its first sample and ``moving`` after its last,
    stamped in ns as the nodes stamp them."""
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


def explore_in_motion(calibration_accuracy: float, seed: int, joint_every: int = 10) -> MotionRun:
    """As the sequencer runs ``excitation: motion`` on the Panda with a 0.5 kg box: the
    empty hand at rest and along the D-optimal 3 s excitation, the grasp, the object along
    it and along another design; through the realistic sensor of serial ``seed`` with
    ``calibration_accuracy``, joint states every ``joint_every`` steps (10: 100 Hz);
    solved from its labels (``Exploration.solve``). The caller closes ``MotionRun.world``."""
    profile = PROFILES["realistic"].with_overrides(calibration_accuracy=calibration_accuracy)
    sensor = profile_sensor(profile, seed=seed, serial=seed)
    world = ArmWorld(SimConfig(object_mass=0.5, seed=3))
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    wrist = robot.arm_joints[-3:]
    excitation = design_excitation(model, robot.home_joints, wrist, period=3.0, iterations=40)
    other = design_excitation(model, robot.home_joints, wrist, period=3.0, iterations=40, seed=5)
    settings = {"information": "kinematics", "accuracy": calibration_accuracy}
    exploration = exploration_from(settings, world.urdf_text)
    world.move_arm(robot.home_joints, 1.0)
    feed(exploration, world, "tare/home", hold_still(world, sensor, 2.0, joint_every))
    feed(exploration, world, MOTION_TARE, run_excitation(world, excitation, sensor, joint_every))
    grasp(world)
    feed(exploration, world, MOTION_OBJECT, run_excitation(world, excitation, sensor, joint_every))
    feed(exploration, world, MOTION_VERIFY, run_excitation(world, other, sensor, joint_every))
    exploration.add_label(round(world.time * 1e9), DONE)
    return MotionRun(world, sensor, model, exploration, exploration.solve())
