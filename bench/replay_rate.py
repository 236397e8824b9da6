"""Offline replay rate against merely reading the same bag.

    source ./env.sh && python bench/replay_rate.py [--dwell 5]

Writes a synthetic exploration (tare and object pass, 5 poses, ``--dwell`` s per
window at 1 kHz) to a rosbag2 directory (MCAP), then times, best of 3: (a) reading every
message of /ft_sensor/wrench and /exploration_sequencer/pose with rosbags, doing
nothing else; (b) the replay console script's work on the same bag: read, decode,
window, tare, estimate, consistency test (``com_estimator.replay.main``). Target:
replay >= 0.5x the rate of (a).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from com_core.bags.cdr import encode_header, encode_wrench_stamped
from com_core.bags.reader import read_raw
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import POSE_TOPIC, WRENCH_TOPIC
from com_core.paper.synthetic import Load, exploration_stream
from com_core.planning.planner import Plan
from com_estimator.replay import main as replay_main


def write_bag(path: Path, dwell: float) -> int:
    stream = exploration_stream(
        Plan(dwell=dwell, gravity_home=(0, 0, 1)),
        Load(0.1, (0.01, -0.02, 0.1)),
        Load(0.73, (0, 0, 0.04)),
        np.random.default_rng(0),
    )
    labels = iter(sorted(stream.labels))
    label = next(labels, None)
    with CrashSafeBagWriter(path) as bag:
        for stamp, wrench in zip(stream.stamps.tolist(), stream.wrenches, strict=True):
            while label is not None and label[0] <= stamp:
                bag.write(POSE_TOPIC, "std_msgs/msg/Header", label[0], encode_header(*label))
                label = next(labels, None)
            bag.write(
                WRENCH_TOPIC,
                "geometry_msgs/msg/WrenchStamped",
                stamp,
                encode_wrench_stamped(stamp, "ft_sensor", wrench),
            )
        if label is not None:
            bag.write(POSE_TOPIC, "std_msgs/msg/Header", label[0], encode_header(*label))
        return sum(bag.counts.values())


def best_of(runs: int, fn) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dwell", type=float, default=5.0, help="s per window")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "run"
        n = write_bag(bag, args.dwell)

        def read_only() -> None:
            for _ in read_raw(bag, (WRENCH_TOPIC, POSE_TOPIC)):
                pass

        def replay() -> None:
            with contextlib.redirect_stdout(io.StringIO()):
                replay_main([str(bag), "--json"])

        t_read, t_replay = best_of(3, read_only), best_of(3, replay)
    print(f"bag: {n} messages")
    print(f"read only : {t_read:.3f} s  ({n / t_read:,.0f} msg/s)")
    print(f"replay    : {t_replay:.3f} s  ({n / t_replay:,.0f} msg/s)")
    print(f"replay / read = {t_read / t_replay:.2f} (target >= 0.5)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
