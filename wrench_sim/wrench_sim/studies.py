"""The simulator driven from a script, without ROS: the grasp and an excitation read
through a sensor, as offline studies (``bench/motion.py``) and tests run them."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from com_core.planning.excitation import Excitation
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import WrenchSensor

__all__ = ["grasp", "run_excitation"]


def grasp(world: ArmWorld) -> None:
    """Pick the object from its stand and lift it to the home pose; RuntimeError when the
    gripper does not hold it."""
    robot = world.config.robot
    world.move_arm(robot.pick_joints, 3.0)
    world.command_gripper(robot.gripper_closed)
    world.run(0.5)
    if not world.object_held:
        raise RuntimeError(f"the grasp failed: {world.events}")
    world.move_arm(robot.home_joints, 3.0)


def run_excitation(
    world: ArmWorld, excitation: Excitation, sensor: WrenchSensor, joint_every: int = 1
) -> tuple[NDArray[np.float64], ...]:
    """Run ``excitation`` from home now, and 0.3 s at rest after it: (joint stamps s,
    arm joint positions rad) every ``joint_every`` steps, and (wrench stamps s, readings
    N and N m in ``ft_sensor``) of ``sensor`` every step."""
    robot = world.config.robot
    times, q, dq, ddq = excitation.waypoints(robot.arm_joints)
    end = world.command_arm(robot.arm_joints, times, q, 0.0, dq, ddq)
    stamps, positions, readings = [], [], []
    while world.time < end + 0.3:
        world.step()
        stamps.append(world.time)
        positions.append(world.joint_state()[1][: len(robot.arm_joints)])
        readings.append(sensor.read(world.wrench, world.time))
    stamps, positions = np.array(stamps), np.array(positions)
    return stamps[::joint_every], positions[::joint_every], stamps, np.array(readings)
