"""Subscriptions to a high-rate stream with the reliability its publishers offer.

A best-effort subscription loses what the transport drops while its process is starved
(on two loaded cores, up to a second of a 1 kHz sensor); a reliable one has DDS repair
it from the publisher's history, but matches no best-effort publisher. So, as
``ros2 bag record`` adapts its QoS, ``subscribe_adapted`` waits for the stream's first
publisher and subscribes reliable when every publisher of it is reliable (the
simulator's, and ros2_control's broadcasters, which publish with the system default
QoS), else best effort. ``STREAM_DEPTH`` holds ``WORST_STALL`` s of a stream at
``STREAM_RATE``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

__all__ = ["STREAM_DEPTH", "STREAM_RATE", "WORST_STALL", "stream_qos", "subscribe_adapted"]

STREAM_RATE = 5000.0
"""Hz (wall): a 1 kHz sensor in a simulator 3x faster than real time, and more."""
WORST_STALL = 2.0
"""s (wall): the longest a process was starved here, two cores loaded by two busy
processes beside the simulator and the nodes."""
STREAM_DEPTH = round(STREAM_RATE * WORST_STALL)
DISCOVERY_PERIOD = 0.2  # s between looks for the first publisher


def stream_qos(reliable: bool, depth: int = STREAM_DEPTH) -> QoSProfile:
    """Keep-last ``depth``, reliable or best effort, volatile."""
    policy = ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT
    return QoSProfile(depth=depth, reliability=policy)


def subscribe_adapted(
    node: Node,
    msg_type: type,
    topic: str,
    callback: Callable[[Any], None],
    depth: int = STREAM_DEPTH,
    on_subscribed: Callable[[QoSProfile], None] | None = None,
    **options: Any,
) -> None:
    """Subscribe ``callback`` to ``topic`` once a publisher of it is seen (now, or on a
    timer of ``node``), reliable when all its publishers are; ``options`` pass on to
    ``create_subscription`` (``raw``, ``event_callbacks``); ``on_subscribed`` is told
    the QoS chosen. The node logs the choice."""
    timer = None

    def look() -> None:
        infos = node.get_publishers_info_by_topic(topic)
        if not infos:
            return
        if timer is not None:
            timer.cancel()
            node.destroy_timer(timer)
        reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
        qos = stream_qos(reliable, depth)
        node.create_subscription(msg_type, topic, callback, qos, **options)
        node.get_logger().info(
            f"{topic}: {'reliable' if reliable else 'best effort'}, depth {depth}, as its "
            f"{len(infos)} publisher(s) offer"
        )
        if on_subscribed is not None:
            on_subscribed(qos)

    if node.get_publishers_info_by_topic(topic):
        look()
    else:
        timer = node.create_timer(DISCOVERY_PERIOD, look)
