"""Offline replay: the estimate of a recorded exploration, as the node computed it.

    replay BAG_DIR [--method ml|two_pose] [--json] [...]

Reads /ft_sensor/wrench and /exploration_sequencer/pose from a rosbag2 directory
(MCAP) and feeds them to the same ``com_core.exploration.Exploration`` the node uses,
with the node's defaults, so the same messages give the same numbers to the last bit.

A bag without pose labels is cut into static windows by
``com_core.exploration.label_static_windows`` (blocks of 50 ms whose spread is at the
noise level, joined while their means agree within 6 standard errors, kept when longer
than 0.3 s); with no tare windows the estimate is then of the whole load beyond the
sensor (hand + object), and the output says which it did. Tare windows of poses the bag
has no fresh tare for come from the run's cached tare, BAG/tare.json (``--tare``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from com_core.bagio import POSE_TOPIC, WRENCH_TOPIC, feed_bag
from com_core.exploration import ERROR, Exploration, format_solution, label_static_windows
from com_core.tare_cache import BAG_TARE_FILE, load_tares
from com_core.wrench_model import SensorModel

DEFAULTS = Exploration()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="replay", description=__doc__.split("\n\n")[0])
    parser.add_argument("bag", type=Path, help="rosbag2 directory (MCAP storage)")
    parser.add_argument("--method", choices=("ml", "two_pose"), default=DEFAULTS.method)
    parser.add_argument(
        "--alpha",
        type=float,
        default=DEFAULTS.alpha,
        help="false-alarm rate of the object-moved test",
    )
    parser.add_argument("--expected-frame", default=DEFAULTS.expected_frame)
    parser.add_argument("--sigma-f", type=float, default=0.0, help="N per sample (0: unknown)")
    parser.add_argument("--sigma-tau", type=float, default=0.0, help="N m per sample")
    parser.add_argument("--limit-f", type=float, default=0.0, help="N (0: no check)")
    parser.add_argument("--limit-tau", type=float, default=0.0, help="N m (0: no check)")
    parser.add_argument("--min-tilt-sigmas", type=float, default=DEFAULTS.min_tilt_sigmas)
    parser.add_argument("--wrench-topic", default=WRENCH_TOPIC)
    parser.add_argument("--pose-topic", default=POSE_TOPIC)
    parser.add_argument(
        "--tare",
        type=Path,
        default=None,
        help=f"cached tare windows (default: BAG/{BAG_TARE_FILE} if present)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not (args.bag / "metadata.yaml").exists() and not any(args.bag.glob("*.mcap")):
        print(f"replay: {args.bag} is not a rosbag2 directory", file=sys.stderr)
        return 2
    sensor = None
    if args.sigma_f or args.sigma_tau or args.limit_f or args.limit_tau:
        sensor = SensorModel.from_scalars(
            args.sigma_f,
            args.sigma_tau,
            limit_f=args.limit_f,
            limit_tau=args.limit_tau,
        )
    cache = load_tares(args.tare or args.bag / BAG_TARE_FILE)
    exploration = Exploration(
        method=args.method,
        expected_frame=args.expected_frame,
        sensor=sensor,
        alpha=args.alpha,
        min_tilt_sigmas=args.min_tilt_sigmas,
        tares=cache.windows if cache else {},
    )
    n_wrench, n_label = feed_bag(args.bag, exploration, args.wrench_topic, args.pose_topic)
    if n_label:
        source = f"pose labels from the bag ({n_label})"
    else:
        stamps, wrenches = exploration.samples()
        found = label_static_windows(stamps, wrenches)
        for stamp, label in found:
            exploration.add_label(stamp, label)
        exploration.untared = True
        source = f"no pose labels in the bag: found {len(found) // 2} static windows"
    solution = exploration.solve()
    if args.json:
        print(json.dumps(solution.as_dict() | {"windows_from": source, "messages": n_wrench}))
    else:
        print(f"{args.bag}: {n_wrench} wrenches; windows from {source}")
        print(format_solution(solution))
    return 1 if solution.status == ERROR else 0


if __name__ == "__main__":
    sys.exit(main())
