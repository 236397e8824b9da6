"""One exploration through the Explore action: its progress as it runs, its result, and
Ctrl-C to cancel it (the arm puts the object back and goes home). With the three nodes
running and ``source ./env.sh``::

    python examples/explore_action.py [TARGET_COM_SIGMA_M]
"""

import sys

import rclpy
from rclpy.action import ActionClient
from rclpy.signals import SignalHandlerOptions

from com_interfaces.action import Explore

rclpy.init(signal_handler_options=SignalHandlerOptions.NO)  # Ctrl-C here cancels the goal
node = rclpy.create_node("explore_client")
client = ActionClient(node, Explore, "/exploration_sequencer/explore")
client.wait_for_server()
goal = Explore.Goal(target_com_sigma=float(sys.argv[1]) if len(sys.argv) > 1 else 0.0)


def progress(message) -> None:
    f = message.feedback
    print(f"{f.progress:4.0%} {f.phase}, {f.time_remaining:.0f} s left", flush=True)


sent = client.send_goal_async(goal, feedback_callback=progress)
rclpy.spin_until_future_complete(node, sent)
result = sent.result().get_result_async()
try:
    rclpy.spin_until_future_complete(node, result)
except KeyboardInterrupt:
    sent.result().cancel_goal_async()
    rclpy.spin_until_future_complete(node, result)
answer = result.result().result
print(f"{answer.status}: mass {answer.estimate.inertia.m:.4f} kg; {answer.message}")
rclpy.shutdown()
