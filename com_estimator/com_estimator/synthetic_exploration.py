"""Play a synthetic exploration into the live estimator (for tests and benchmarks).

    synthetic_exploration [--mass 0.1 --com X Y Z] [--speed 2000] [--bag DIR]
                          [--fault nan|frame|order|duplicate|motion|no-tare|one-pose|
                                   no-windows|long-label ...] [--shift-sigma 0.01]
                          [--estimator-timeout 10]

The stream is ``com_core.paper.synthetic.exploration_stream`` (tare pass, then object pass,
motion between poses, then ``done``), published on /ft_sensor/wrench and
/exploration_sequencer/pose with the ground truth on /wrench_sim/ground_truth. With
``--bag`` every published message is also written, serialized as sent, to a rosbag2
directory, so the node's answer can be compared with the offline replay's.

Several faults play one exploration each, in order, each with the same stamps (as a
restarted sensor's), each from its own lead-in.

Each exploration begins with 1 s (sensor time) of the hand at rest, in no window, and plays the
exploration only once the estimator's input status on /diagnostics reports a wrench
of this lead-in (at most ``--estimator-timeout`` s of wall time; 0: do not wait). A
publisher seeing its subscriber does not mean the subscriber has matched the
publisher yet; on a loaded machine that took longer than a whole run, and every
message of it was lost.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import InertiaStamped, WrenchStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import serialize_message
from rclpy.utilities import remove_ros_args
from std_msgs.msg import Header

from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import (
    DIAGNOSTICS_TOPIC,
    DONE,
    MOVING,
    POSE_TOPIC,
    TARE_PREFIX,
    TRUTH_TOPIC,
    WRENCH_TOPIC,
    heard_stamps,
)
from com_core.paper.synthetic import Load, Stream, exploration_stream
from com_core.planning.planner import Plan
from com_core.runtime.rosenv import keep_dds_local
from com_core.sensing.wrench_model import SensorModel

FAULTS = (
    "none",
    "nan",
    "frame",
    "order",
    "duplicate",
    "motion",
    "no-tare",
    "one-pose",
    "no-windows",
    "long-label",
)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="synthetic_exploration", description=__doc__.split("\n\n")[0])
    p.add_argument("--mass", type=float, default=0.1, help="object mass, kg")
    p.add_argument("--com", type=float, nargs=3, default=(0.01, -0.02, 0.10), help="m")
    p.add_argument("--hand-mass", type=float, default=0.73, help="kg")
    p.add_argument("--hand-com", type=float, nargs=3, default=(0.0, 0.0, 0.04), help="m")
    p.add_argument("--tilt", type=float, default=math.pi / 6, help="rad")
    p.add_argument("--dwell", type=float, default=0.5, help="s per pose")
    p.add_argument("--sigma-f", type=float, default=0.1, help="N per sample")
    p.add_argument("--sigma-tau", type=float, default=0.005, help="N m per sample")
    p.add_argument("--rate", type=float, default=1000.0, help="sensor rate, Hz (stamps)")
    p.add_argument(
        "--speed",
        type=float,
        default=2000.0,
        help="wrench messages per wall-clock second (0: as fast as possible)",
    )
    p.add_argument("--shift-sigma", type=float, default=0.0, help="COM shift per tilt, m")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--fault", choices=FAULTS, nargs="+", default=["none"],
                   help="inject a bad input; several: one exploration each, in order")  # fmt: skip
    p.add_argument("--bag", help="also write the published messages to this directory")
    p.add_argument("--frame", default="ft_sensor")
    p.add_argument(
        "--estimator-timeout",
        type=float,
        default=10.0,
        help="s to wait for the estimator to hear the lead-in (0: no estimator, no wait)",
    )
    return p


def inject(stream: Stream, fault: str, dwell: float, rate: float) -> tuple[Stream, list[str]]:
    """The stream with one kind of bad input, and the frame_id of every sample."""
    stamps, wrenches = stream.stamps.copy(), stream.wrenches.copy()
    labels = list(stream.labels)
    frames = [""] * len(stamps)  # "" = the normal frame
    windows = {lbl: s for s, lbl in labels}
    k = int(np.searchsorted(stamps, windows.get("object/tilt_x+", stamps[len(stamps) // 2])))
    if fault == "nan":
        wrenches[k + 10 : k + 15, 2] = np.nan
    elif fault == "frame":
        for i in range(k, k + 100):
            frames[i] = "tool0"
    elif fault == "order":
        stamps[k + 20 : k + 23] = stamps[k - 300 : k - 297]
    elif fault == "duplicate":
        stamps[k + 20 : k + 23] = stamps[k + 19]
    elif fault == "motion":  # the arm creeps through the whole window
        n = int(dwell * rate)
        wrenches[k : k + n, :3] += np.linspace(0.0, 0.5, n)[:, None]
    elif fault == "no-tare":
        labels = [(s, MOVING if lbl.startswith(TARE_PREFIX) else lbl) for s, lbl in labels]
    elif fault == "one-pose":
        labels = [(s, MOVING if "tilt" in lbl else lbl) for s, lbl in labels]
    elif fault == "no-windows":
        labels = [(s, lbl if lbl == DONE else MOVING) for s, lbl in labels]
    elif fault == "long-label":  # a label of 10,000 characters with the window's end
        end = next(i for i, (s, _) in enumerate(labels) if s > windows["object/tilt_x+"])
        labels.insert(end + 1, (labels[end][0], "object/" + "x" * 9993))
    return Stream(stamps, wrenches, labels), frames


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else ["synthetic_exploration", *argv]
    args = build_parser().parse_args(remove_ros_args(argv)[1:])
    rng = np.random.default_rng(args.seed)
    plan = Plan(
        tilt=args.tilt,
        dwell=args.dwell,
        gravity_home=(0.0, 0.0, 1.0),
        sensor=SensorModel.from_scalars(args.sigma_f, args.sigma_tau, rate_hz=args.rate),
    )
    load = Load(args.mass, tuple(args.com))
    stream = exploration_stream(
        plan, load, Load(args.hand_mass, tuple(args.hand_com)), rng, shift_sigma=args.shift_sigma
    )
    keep_dds_local()
    rclpy.init(args=argv)
    node = rclpy.create_node("synthetic_exploration")
    latched = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    wrench_pub = node.create_publisher(WrenchStamped, WRENCH_TOPIC, 1000)
    pose_pub = node.create_publisher(Header, POSE_TOPIC, latched)
    truth_pub = node.create_publisher(InertiaStamped, TRUTH_TOPIC, latched)
    estimator = _EstimatorInput(node) if args.estimator_timeout > 0 else None
    with contextlib.ExitStack() as stack:
        bag = stack.enter_context(CrashSafeBagWriter(args.bag)) if args.bag else None
        pubs = (wrench_pub, pose_pub, truth_pub)
        for fault in args.fault:
            played, frames, lead = _with_lead_in(*inject(stream, fault, args.dwell, args.rate),
                                                 args.rate)  # fmt: skip
            elapsed = _play(args, played, frames, lead, node, pubs, bag, estimator)
            node.get_logger().info(
                f"published {len(played.stamps)} wrenches and {len(played.labels)} labels in "
                f"{elapsed:.2f} s (fault: {fault})" + (f"; bag {args.bag}" if args.bag else "")
            )
    time.sleep(0.5)  # let reliable late messages (labels) be delivered before leaving
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def _with_lead_in(stream: Stream, frames: list[str], rate: float) -> tuple[Stream, list[str], int]:
    """The stream after 1 s (sensor time) of its first sample, as a sensor streams before
    an exploration (see the module; a best-effort reader drops what arrives before it has
    matched); its frames; the lead-in's samples."""
    lead = round(rate)
    lead_stamps = stream.stamps[0] - np.arange(lead, 0, -1) * round(1e9 / rate)
    led = Stream(
        np.concatenate([lead_stamps, stream.stamps]),
        np.concatenate([np.tile(stream.wrenches[0], (lead, 1)), stream.wrenches]),
        stream.labels,
    )
    return led, [""] * lead + frames, lead


class _EstimatorInput:
    """The latest wrench stamp (ns) the estimator's 1 Hz input status reports hearing."""

    def __init__(self, node) -> None:
        self.latest: int | None = None
        node.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self._callback, 10)

    def _callback(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            heard = heard_stamps(status)
            if heard is not None:
                self.latest = heard[0]


def _play(
    args,
    stream: Stream,
    frames: list[str],
    lead: int,
    node,
    pubs,
    bag: CrashSafeBagWriter | None,
    heard: _EstimatorInput | None,
) -> float:
    """Publish (and record) the stream; returns the wall time it took, s. The first
    ``lead`` samples go out slowly until the estimator reports hearing one (module;
    ``heard``: its input status, None: no wait)."""
    wrench_pub, pose_pub, truth_pub = pubs
    estimator = heard
    lead_first = int(stream.stamps[0])

    def send(pub, msg, msgtype: str, stamp: int) -> None:
        pub.publish(msg)
        if bag is not None:
            bag.write(pub.topic_name, msgtype, stamp, serialize_message(msg))

    deadline = time.monotonic() + 10.0
    while wrench_pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    waiting_until = time.monotonic() + args.estimator_timeout
    truth = InertiaStamped(header=_header(int(stream.stamps[0]), args.frame))
    truth.inertia.m = args.mass
    truth.inertia.com.x, truth.inertia.com.y, truth.inertia.com.z = args.com
    send(truth_pub, truth, "geometry_msgs/msg/InertiaStamped", int(stream.stamps[0]))
    labels = sorted(stream.labels)
    next_label = 0
    started = time.monotonic()
    for i, (stamp, wrench) in enumerate(zip(stream.stamps.tolist(), stream.wrenches, strict=True)):
        while next_label < len(labels) and labels[next_label][0] <= stamp:
            s, label = labels[next_label]
            send(pose_pub, _header(s, label), "std_msgs/msg/Header", s)
            next_label += 1
        msg = WrenchStamped(header=_header(stamp, frames[i] or args.frame))
        f, t = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, t.x, t.y, t.z = (float(v) for v in wrench)
        send(wrench_pub, msg, "geometry_msgs/msg/WrenchStamped", stamp)
        if estimator is not None:
            rclpy.spin_once(node, timeout_sec=0.01)  # ~100 lead-in wrenches/s meanwhile
            if lead_first <= (estimator.latest or -1) <= stamp:
                estimator = None
            elif i == lead - 1 or time.monotonic() > waiting_until:
                node.get_logger().warning(
                    f"the estimator did not report hearing the lead-in within "
                    f"{args.estimator_timeout} s; playing on"
                )
                estimator = None
            if estimator is None:  # pace the rest from here
                started = time.monotonic() - (i + 1) / args.speed if args.speed > 0 else 0.0
            continue
        if args.speed > 0 and i % 50 == 49:
            lag = started + (i + 1) / args.speed - time.monotonic()
            if lag > 0:
                time.sleep(lag)
    for s, label in labels[next_label:]:
        send(pose_pub, _header(s, label), "std_msgs/msg/Header", s)
    return time.monotonic() - started


def _header(stamp_ns: int, frame_id: str) -> Header:
    header = Header(frame_id=frame_id)
    header.stamp.sec, header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return header


if __name__ == "__main__":
    sys.exit(main())
