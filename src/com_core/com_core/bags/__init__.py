"""rosbag2 (MCAP) bags of exploration runs, without ROS.

- ``cdr``: decoding (and encoding) of the two hot messages, WrenchStamped and Header.
- ``reader``: reads a bag's raw messages, also a copy cut short; feeds an Exploration.
- ``writer``: the crash-safe writer (docs/bag_writer.md).
- ``run``: one run read back and summarised (wrenches, labels, estimate, ground truth).
- ``report``: the PNG report of a run.
"""
