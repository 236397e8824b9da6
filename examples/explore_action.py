"""One exploration through the Explore action: its progress as it runs, its result, and
Ctrl-C to cancel it (the arm puts the object back and goes home).

With the three nodes running and ``source ./env.sh``::

    python examples/explore_action.py [TARGET_COM_SIGMA_M] [--wait S]

Without the nodes, or when the sequencer goes away mid-run, it gives up after --wait s
(30) and says what it waited for.
"""

import argparse
import sys
import time

import rclpy
from rclpy.action import ActionClient
from rclpy.signals import SignalHandlerOptions

from com_interfaces.action import Explore

ACTION = "/exploration_sequencer/explore"
parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("target_com_sigma", nargs="?", type=float, default=0.0, help="m; 0: none")
parser.add_argument("--wait", type=float, default=30.0, help="s for the sequencer, then give up")
args = parser.parse_args()

rclpy.init(signal_handler_options=SignalHandlerOptions.NO)  # Ctrl-C here cancels the goal
node = rclpy.create_node("explore_client")
client = ActionClient(node, Explore, ACTION)
print(f"waiting up to {args.wait:g} s for the action server {ACTION}", flush=True)
if not client.wait_for_server(timeout_sec=args.wait):
    rclpy.shutdown()
    sys.exit(f"no action server {ACTION} after {args.wait:g} s: are the nodes running "
             "(make demo runs them), on this ROS_DOMAIN_ID?")  # fmt: skip


def progress(message) -> None:
    f = message.feedback
    print(f"{f.progress:4.0%} {f.phase}, {f.time_remaining:.0f} s left", flush=True)


def wait(future) -> None:
    """Spin until ``future`` is done; exit once the sequencer has been gone for --wait s."""
    seen = time.monotonic()
    while not future.done():
        rclpy.spin_until_future_complete(node, future, timeout_sec=1.0)
        if client.server_is_ready():
            seen = time.monotonic()
        elif time.monotonic() - seen > args.wait and not future.done():
            rclpy.shutdown()
            sys.exit(f"the action server {ACTION} went away for {args.wait:g} s: no answer")


sent = client.send_goal_async(Explore.Goal(target_com_sigma=args.target_com_sigma),
                              feedback_callback=progress)  # fmt: skip
wait(sent)
result = sent.result().get_result_async()
try:
    wait(result)
except KeyboardInterrupt:
    sent.result().cancel_goal_async()
    wait(result)
answer = result.result().result
print(f"{answer.status}: mass {answer.estimate.inertia.m:.4f} kg; {answer.message}")
rclpy.shutdown()
