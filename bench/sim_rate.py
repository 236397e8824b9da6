"""Real-time factor of wrench_sim, headless, 1 kHz physics, with and without publishing.

Runs the same scenario on the Panda three times in one process: pybullet stepping alone
(``ArmWorld``), the node's loop without DDS publishing, and the node's loop publishing /clock
and /ft_sensor/wrench at 1 kHz plus /joint_states at 100 Hz (sim time). Each real-time factor
(sim s per wall s) is printed with its ratio to the physics-only run. ``--subscriber`` adds a
separate process that takes every wrench (as the estimator would) and reports what it got.

Usage: ``source ./env.sh && python bench/sim_rate.py [--seconds 12] [--subscriber]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import rclpy

from com_core.runtime.rosenv import keep_dds_local
from wrench_sim.physics import ArmWorld, SimConfig
from wrench_sim.sim_node import SimNode

TARGET = 5.0

BARE_SUBSCRIBER = Path(__file__).with_name("bare_subscriber.py")


def scenario(world: ArmWorld, run) -> float:
    """Hold, tilt joint 6 by 0.5 rad in 2 s, hold, tilt back; returns the sim seconds run."""
    robot = world.config.robot
    tilted = np.array(robot.home_joints)
    tilted[5] += 0.5
    run(1.0)
    world.command_arm(robot.arm_joints, [2.0], [tilted.tolist()])
    run(3.0)
    world.command_arm(robot.arm_joints, [2.0], [list(robot.home_joints)])
    run(2.0)
    return 6.0


def timed(repeats: int, world: ArmWorld, run) -> float:
    """Real-time factor of ``repeats`` scenarios."""
    start = time.perf_counter()
    sim = sum(scenario(world, run) for _ in range(repeats))
    return sim / (time.perf_counter() - start)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=12.0, help="sim seconds per run")
    parser.add_argument("--subscriber", action="store_true", help="also run a wrench reader")
    parser.add_argument("--domain-id", type=int, default=None, help="ROS_DOMAIN_ID (else env)")
    options = parser.parse_args()
    if options.domain_id is not None:
        os.environ["ROS_DOMAIN_ID"] = str(options.domain_id)
    keep_dds_local(own_domain=True)
    repeats = max(1, round(options.seconds / 6.0))

    world = ArmWorld(SimConfig())
    physics = timed(repeats, world, world.run)
    world.close()

    rclpy.init(args=["--ros-args", "-p", "sigma_f:=0.1", "-p", "sigma_tau:=0.005"])
    node = SimNode()
    quiet = timed(repeats, node.world, lambda d: node.run(d, publish=False))
    reader = None
    if options.subscriber:
        reader = subprocess.Popen(
            [sys.executable, str(BARE_SUBSCRIBER)],
            stdout=subprocess.PIPE,
            text=True,
            env=os.environ.copy(),
        )
        reader.stdout.readline()
        deadline = time.monotonic() + 30.0  # discovery: wait until the reader is matched
        while node.wrench_publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise RuntimeError("the wrench reader never subscribed")
            time.sleep(0.05)
    published = timed(repeats, node.world, lambda d: node.run(d, publish=True))
    node.close()
    node.destroy_node()
    rclpy.try_shutdown()

    print(f"scenario: hold, tilt 0.5 rad, hold, tilt back; {6.0 * repeats:.0f} s sim per run")
    print(f"physics only (ArmWorld.step)         : real-time factor {physics:6.2f}")
    print(
        f"node loop, no publishing             : real-time factor {quiet:6.2f}"
        f"  ({quiet / physics:.2f} x physics only)"
    )
    print(
        f"node loop, publishing 1 kHz + /clock : real-time factor {published:6.2f}"
        f"  ({published / physics:.2f} x physics only)"
    )
    if reader is not None:
        reader.send_signal(2)
        try:
            received = reader.communicate(timeout=10)[0].split()
        except subprocess.TimeoutExpired:
            reader.kill()
            received = []
        sent = round(6.0 * repeats * 1000)
        got = int(received[-1]) if received else 0  # its last line: "received N"
        print(f"wrench reader (EventsExecutor, raw)  : received {got} of {sent} wrenches")
    verdict = "PASS" if published >= TARGET else "FAIL"
    print(f"target >= {TARGET:.0f}x real time with publishing: {verdict}")
    return 0 if published >= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
