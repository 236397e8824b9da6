"""Honest error bars under a real sensor's noise: runs recorded with a noise-free sensor,
replayed with noise added afterwards, the noise unknown to the estimator.

    python bench/correlated_noise.py BAG [BAG ...] [--copies 12] [--times 0,1,2,5,20]

Each BAG is a run recorded with the ``ideal`` sensor profile (``make demo ARGS="--sensor-
profile ideal --seed K"``; ``bench/exploration.py --sensor-profile ideal`` records many).
Its messages are read once; then for every correlation time T and copy k its wrenches get
noise through a first-order low-pass (AR(1) at the sample rate, coefficient
exp(-1 / (rate T)); T = 0: white) of 0.1 N and 0.005 N m per sample and, with
``--calibrated A``, a calibration error of accuracy A drawn per copy
(``com_core.calibration``), and the copy is solved by the same ``Exploration`` as the
node's, with the estimator's defaults (noise unknown: learnt from the windows) but its
``accuracy``: A (0 without ``--calibrated``: the noise's share alone). Seeds: copy k of bag
b draws from SeedSequence((seed, b, k)).

Prints per T: rms(error / sigma) of mass and COM x, y, z against the ground truth in the
bag, the share within 2 sigma, runs not OK (and why), runs without an estimate, and the
COM sigma over the white-noise copies' (the cost of the correlation).
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from pathlib import Path

import numpy as np

from com_core.bags.reader import BagReading, feed_bag
from com_core.bags.run import read_run
from com_core.calibration import Calibration
from com_core.estimator_settings import (
    FULL_SCALE,
    exploration_from,
    robot_from,
    use_cached_tares,
)
from com_core.robot_config import BAG_ROBOT_FILE, read_robot_config
from com_core.tare_cache import BAG_TARE_FILE

SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # N, N m per sample (the demo's)


class _Recording:
    """Stands in for an ``Exploration`` under ``feed_bag``: keeps what it is given."""

    information = "kinematics+mount"

    def __init__(self) -> None:
        self.samples: list[tuple] = []
        self.labels: list[tuple[int, str]] = []
        self.joints: list[tuple] = []

    def add_samples(self, stamps, wrenches, frames) -> int:
        self.samples.append((np.asarray(stamps), np.asarray(wrenches), frames))
        return len(stamps)

    def add_label(self, stamp, label) -> None:
        self.labels.append((stamp, label))

    def add_joint_state(self, stamp, names, positions) -> None:
        self.joints.append((stamp, names, positions))

    def count_dropped(self, *_args, **_kwargs) -> None:
        pass


def ar1(n: int, tau: float, rate: float, rng: np.random.Generator) -> np.ndarray:
    """(n, 6) stationary AR(1) noise of std SIGMA per sample, correlation time tau (s)."""
    e = rng.standard_normal((n, 6)) * SIGMA
    if tau <= 0:
        return e
    phi = math.exp(-1.0 / (rate * tau))
    out = np.empty_like(e)
    out[0] = e[0]
    scale = math.sqrt(1.0 - phi * phi)
    for t in range(1, n):
        out[t] = phi * out[t - 1] + scale * e[t]
    return out


def calibration_error(accuracy: float, rng: np.random.Generator) -> np.ndarray:
    """(6, 6) C = I + S E S^-1, E's elements N(0, (accuracy / 2)^2) (com_core.calibration)."""
    scale = Calibration(accuracy, *FULL_SCALE).scale
    e = rng.standard_normal((6, 6)) * accuracy / 2.0
    return np.eye(6) + scale[:, None] * e / scale[None, :]


def solve_copy(
    bag: Path, rec: _Recording, urdf: str, settings: dict, noise: np.ndarray, c: np.ndarray
):
    exploration = exploration_from(settings)
    use_cached_tares(exploration, bag / BAG_TARE_FILE)
    exploration.robot, exploration.robot_problem = robot_from(settings, urdf)
    start = 0
    for stamps, wrenches, frames in rec.samples:
        read = wrenches @ c.T + noise[start : start + len(stamps)]
        exploration.add_samples(stamps, read, frames)
        start += len(stamps)
    for stamp, label in rec.labels:
        exploration.add_label(stamp, label)
    for stamp, names, positions in rec.joints:
        exploration.add_joint_state(stamp, names, positions)
    return exploration.solve()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bags", type=Path, nargs="+")
    parser.add_argument("--copies", type=int, default=12)
    parser.add_argument("--times", default="0,1,2,5,20", help="correlation times, ms")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--calibrated", type=float, default=0.0, help="accuracy, fraction")
    args = parser.parse_args()
    taus = [float(t) * 1e-3 for t in args.times.split(",")]
    runs = []
    for bag in args.bags:
        rec, reading = _Recording(), BagReading()
        feed_bag(bag, rec, reading=reading)
        truth = read_run(bag).truth
        robot = read_robot_config(str(bag / BAG_ROBOT_FILE))
        settings = {
            "sensor_frame": robot.sensor_frame,
            "base_frame": robot.base_frame,
            "accuracy": args.calibrated,
        }
        runs.append((bag, rec, reading.robot_description, settings, truth))
    white_sigma = None
    print(
        "| correlation time | rms(error/sigma) mass, x, y, z | within 2 sigma | not OK | "
        "no estimate | COM sigma / white's |"
    )
    print("|---|---|---|---|---|---|")
    for tau in taus:
        ratios, sigmas, statuses, missing = [], [], Counter(), 0
        for b, (bag, rec, urdf, settings, truth) in enumerate(runs):
            n = sum(len(s) for s, _, _ in rec.samples)
            for k in range(args.copies):
                rng = np.random.default_rng(np.random.SeedSequence((args.seed, b, k)))
                noise = ar1(n, tau, 1000.0, rng)
                c = calibration_error(args.calibrated, rng)
                solution = solve_copy(bag, rec, urdf, settings, noise, c)
                if solution.status != "OK":
                    statuses[solution.reason[:70]] += 1
                e = solution.estimate
                if e is None:
                    missing += 1
                    continue
                error = np.array([e.mass - truth.mass, *(e.com - truth.com)])
                sigma = np.array([e.sigma_mass, *e.sigma_com])
                ratios.append(error / sigma)
                sigmas.append(e.sigma_com)
        r = np.array(ratios).reshape(-1, 4)
        rms = np.sqrt((r**2).mean(axis=0)) if len(r) else np.full(4, np.nan)
        within = (np.abs(r) <= 2).mean(axis=0) * 100 if len(r) else np.full(4, np.nan)
        mean_sigma = np.mean(sigmas, axis=0) if sigmas else np.full(3, np.nan)
        if white_sigma is None:
            white_sigma = mean_sigma
        total = len(runs) * args.copies
        print(
            f"| {tau * 1e3:g} ms | {', '.join(f'{v:.2f}' for v in rms)} | "
            f"{', '.join(f'{v:.0f}' for v in within)} % | {sum(statuses.values())}/{total} | "
            f"{missing}/{total} | {', '.join(f'{v:.2f}' for v in mean_sigma / white_sigma)} |"
        )
        for reason, count in statuses.most_common(3):
            print(f"|   {count}x: {reason} | | | | | |")


if __name__ == "__main__":
    main()
