"""ROS-free core: object mass and centre of mass from wrist force/torque wrenches."""
