"""pybullet simulation of a Franka Panda with a wrist F/T sensor.

Publishes wrenches, joint states and sim time; see ``physics`` (ROS-free) and ``sim_node``.
"""
