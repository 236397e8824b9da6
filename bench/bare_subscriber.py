"""The fastest bare rclpy subscriber of WrenchStamped (docs/design.md, Numbers): the reference.

EventsExecutor, raw CDR bytes, the estimator's QoS (best effort, depth 5000); it only
counts. ``~/reset`` (std_srvs/Trigger) answers "cleared N samples" like the estimator.
Prints "ready" once subscribed and "received N" (all messages) when stopped.
"""

from __future__ import annotations

import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from com_core.contract import WRENCH_TOPIC
from com_core.runtime.rosenv import keep_dds_local


def main() -> None:
    keep_dds_local()
    rclpy.init()
    node = rclpy.create_node("bare_subscriber")
    count = [0, 0]  # since the last reset, in all

    def on_wrench(_raw: bytes) -> None:
        count[0] += 1
        count[1] += 1

    def on_reset(_req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
        resp.success, resp.message = True, f"cleared {count[0]} samples"
        count[0] = 0
        return resp

    qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.BEST_EFFORT)
    node.create_subscription(WrenchStamped, WRENCH_TOPIC, on_wrench, qos, raw=True)
    node.create_service(Trigger, "~/reset", on_reset)
    executor = EventsExecutor()
    executor.add_node(node)
    print("ready", flush=True)
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        print(f"received {count[1]}", flush=True)
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
