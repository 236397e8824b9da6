"""pybullet simulation of an arm with a wrist F/T sensor (the Panda, the xArm6, or any arm a
robot configuration describes).

Publishes wrenches, joint states and sim time; see ``physics`` (ROS-free) and ``sim_node``.
"""
