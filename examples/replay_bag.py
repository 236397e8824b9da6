"""A recorded run (rosbag2, MCAP) replayed to the estimator node's estimate without ROS,
as the ``replay`` command does (``com_core.estimation``); the sample run by default::

    python examples/replay_bag.py [BAG]
"""

import sys
from pathlib import Path

from com_core.bags import BagReading
from com_core.estimation.runs import (
    BAG_TARE_FILE,
    defaults,
    exploration_from,
    feed_bag,
    format_solution,
    robot_from,
    use_cached_tares,
)
from com_core.report import read_run
from com_core.robot import BAG_ROBOT_FILE, read_robot_config

bag = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parents[1] / "bags/sample")

# the node's default settings, with the frames of the run's robot configuration
settings = defaults()
robot = read_robot_config(str(bag / BAG_ROBOT_FILE))
settings |= {"sensor_frame": robot.sensor_frame, "base_frame": robot.base_frame}

exploration = exploration_from(settings)
use_cached_tares(exploration, bag / BAG_TARE_FILE)  # a reused tare pass, if the run had one
reading = BagReading()  # collects the URDF the run published
wrenches, labels = feed_bag(bag, exploration, reading=reading)
exploration.robot, _ = robot_from(settings, reading.robot_description)
print(f"{bag.name}: {wrenches} wrenches, {labels} pose labels")
print(f"replayed: {format_solution(exploration.solve())}")
print(f"the node: {read_run(bag).diagnostic['message']}")
