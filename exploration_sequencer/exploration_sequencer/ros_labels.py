"""The pose labels' port (``com_core.sequencing.ports.LabelSink``) over ROS: a
std_msgs/Header on POSE_TOPIC (frame_id = label, stamp = the time from which it applies;
reliable, transient local, depth 1). Each label waits for every reader's acknowledgement
before the next goes out, so a reader that falls behind (a starved process) is late, never
without a label."""

from __future__ import annotations

from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Header

from com_core.contract import POSE_TOPIC

LABEL_ACK_TIMEOUT = 10.0  # s (wall) a pose label waits for its readers' acknowledgement


class PoseLabels:
    """The latched pose label of ``node``."""

    def __init__(self, node: Node) -> None:
        self._log = node.get_logger()
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._pub = node.create_publisher(Header, POSE_TOPIC, latched)

    def publish(self, stamp_ns: int, label: str) -> None:
        header = Header(frame_id=label)
        header.stamp.sec, header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        self._pub.publish(header)
        if not self._pub.wait_for_all_acked(Duration(seconds=LABEL_ACK_TIMEOUT)):
            self._log.warning(
                f"label {label!r} not acknowledged by every reader of {POSE_TOPIC} within "
                f"{LABEL_ACK_TIMEOUT:g} s: a reader that falls this far behind may miss it"
            )
