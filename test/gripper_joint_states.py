"""A gripper's own /joint_states publisher beside the sim's, as a real set-up has one (a
gripper's broadcaster): the joints named on the command line at ``rate`` Hz of sim time,
stamped with the sim clock, their positions and velocities the latest the sim published.

    python gripper_joint_states.py <rate Hz> <joint> [<joint> ...]

Run with the test's ROS_DOMAIN_ID and localhost discovery; ends on SIGINT with exit 0.
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from com_core.contract import JOINT_STATES_TOPIC


class GripperJointStates(Node):
    """Publishes ``names`` at ``rate`` Hz (sim time) from the sim's latest joint states."""

    def __init__(self, rate: float, names: list[str]) -> None:
        super().__init__(
            "gripper_joint_states", parameter_overrides=[Parameter("use_sim_time", value=True)]
        )
        self.names = names
        self.latest: dict[str, tuple[float, float]] = {}
        # reliable, 2 s of history: what a starved reader needs repaired, as the sim keeps
        qos = QoSProfile(depth=max(1, round(2 * rate)), reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(JointState, JOINT_STATES_TOPIC, qos)
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.heard, 10)
        self.create_timer(1.0 / rate, self.publish)

    def heard(self, msg: JointState) -> None:
        """Keep the gripper's joints of a message that names others too (the sim's, not
        this publisher's own)."""
        if set(msg.name) <= set(self.names):
            return
        velocities = msg.velocity if len(msg.velocity) == len(msg.name) else [0.0] * len(msg.name)
        for name, position, velocity in zip(msg.name, msg.position, velocities, strict=True):
            if name in self.names:
                self.latest[name] = (position, velocity)

    def publish(self) -> None:
        if not all(name in self.latest for name in self.names):
            return
        msg = JointState(name=self.names)
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.position = [self.latest[name][0] for name in self.names]
        msg.velocity = [self.latest[name][1] for name in self.names]
        self.publisher.publish(msg)


def main() -> None:
    rate, names = float(sys.argv[1]), sys.argv[2:]
    rclpy.init()
    node = GripperJointStates(rate, names)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
