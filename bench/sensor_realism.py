"""Honest error bars under a real sensor: runs recorded with a noise-free sensor, replayed
with each part of a real sensor added afterwards, the noise unknown to the estimator.

    python bench/sensor_realism.py BAGS_DIR [--copies 1] [--times 0,1,2,5,20] [--parts ...]

BAGS_DIR holds runs recorded with the ``ideal`` sensor profile, one object each
(``python bench/exploration.py --sensor-profile ideal --runs 50 --bag-dir DIR`` records
them under DIR/panda). Each run's messages are read once; then for every case and copy
its wrenches are read through a real sensor's parts, added afterwards:

- ``noise``: 0.1 N and 0.005 N m per sample through a first-order low-pass of
  correlation time T (AR(1) at the sample rate, coefficient exp(-1 / (rate T)); T = 0:
  white), for each T of ``--times``;
- ``vibration``: after every move (each window label follows the arm's rest by the
  sequencer's 0.3 s settle) the load rings at the realistic profile's two modes (12 and
  27 Hz, damping 0.03 and 0.02), 0.2 N at the move's end in a random direction and the
  torque of that force at 60 mm;
- ``drift``: the realistic profile's warm-up (0.3 N, 0.015 N m per axis toward a final
  offset, time constant 600 s, from sim time 0) and random walk (2e-4 N/sqrt(s),
  1e-5 N m/sqrt(s));
- ``calibration``: a calibration error of the realistic profile's accuracy (1 %,
  ``com_core.sensing.calibration``), the estimator told that accuracy (else it is told 0).

Each copy is solved by the same ``Exploration`` as the node's, with the estimator's
defaults (its noise learnt from the windows). Seeds: copy k of run b in case c draws
from SeedSequence((seed, c, b, k)).

Printed per case: rms(error / sigma) of mass and COM x, y, z against the ground truth in
the bag (goal 0.8-1.2), the share within 2 sigma (goal >= 93 %), runs flagged (not OK;
goal <= 5 %), false slip alarms ("moved in the grasp"), runs without an estimate, sigma
over the bound for that noise (the same fit with the true noise model instead of the
learnt one; goal <= 1.2), and the object pass the planner needs for a COM error of 1 mm
at the 95th percentile (worst-axis sigma 0.36 mm) with the noise learnt, median. Then
the detection power, with white noise and under every realistic part (T = 5 ms): a real
slip (the COM moved by 1, 2 or 5 mm from the second tilt on) and a real motion (a 0.5 N
slide through one object window).
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from com_core.bags.reader import BagReading
from com_core.contract import OBJECT_PREFIX
from com_core.estimation.runs.feed import feed_bag
from com_core.estimation.runs.settings import (
    CALIBRATION_ACCURACY,
    FULL_SCALE,
    exploration_from,
    robot_from,
    use_cached_tares,
)
from com_core.estimation.runs.tare_cache import BAG_TARE_FILE
from com_core.planning.dwell import dwell_for_target
from com_core.planning.planner import Plan
from com_core.report.run import read_run
from com_core.robot.config import BAG_ROBOT_FILE, read_robot_config
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import ar1_noise
from com_core.sensing.wrench_model import calibration_matrix

SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # N, N m per sample (the demo's)
RATE = 1000.0
MODES = ((12.0, 0.03), (27.0, 0.02))  # Hz, damping ratio
RINGING_F, RINGING_LEVER = 0.2, 0.06  # N at the move's end; m
SETTLE = 0.3  # s: the sequencer's wait after the arm rests
WARMUP = np.array([0.3, 0.3, 0.3, 0.015, 0.015, 0.015])  # N, N m
WARMUP_TIME = 600.0  # s
RANDOM_WALK = np.array([2e-4, 2e-4, 2e-4, 1e-5, 1e-5, 1e-5])  # per sqrt(s)
HELD_AFTER_SLIP = ("object/tilt_y-", "object/tilt_x+", "object/tilt_x-", "verify/diagonal")
TARGET_P95 = 1e-3  # m: the COM error at the 95th percentile
TARGET_SIGMA = TARGET_P95 / 2.8  # worst-axis sigma: p95 of |e| of a 3-D Gaussian


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
        self.labels.append((int(stamp), label))

    def add_joint_state(self, stamp, names, positions) -> None:
        self.joints.append((stamp, names, positions))

    def count_dropped(self, *_args, **_kwargs) -> None:
        pass


def ar1(n: int, tau: float, rng: np.random.Generator) -> np.ndarray:
    """(n, 6) stationary AR(1) noise of std SIGMA per sample, correlation time tau (s)."""
    e = rng.standard_normal((n, 6)) * SIGMA
    if tau <= 0:
        return e
    phi = math.exp(-1.0 / (RATE * tau))
    out = np.empty_like(e)
    out[0] = e[0]
    scale = math.sqrt(1.0 - phi * phi)
    for t in range(1, n):
        out[t] = phi * out[t - 1] + scale * e[t]
    return out


def ringing(t: np.ndarray, labels: list[tuple[int, str]], rng: np.random.Generator):
    """(n, 6): the load's ringing after every move, at sample times ``t`` (s)."""
    out = np.zeros((len(t), 6))
    for stamp, label in labels:
        if "/" not in label:
            continue
        end = stamp * 1e-9 - SETTLE  # the move's end
        direction = rng.standard_normal(3)
        force = RINGING_F * direction / np.linalg.norm(direction)
        torque = np.cross([0.0, 0.0, RINGING_LEVER], force)
        after = t >= end
        dt = t[after] - end
        shape = np.zeros(len(dt))
        for hz, zeta in MODES:
            w = 2 * math.pi * hz
            shape += np.exp(-zeta * w * dt) * np.sin(w * math.sqrt(1 - zeta**2) * dt)
        out[after] += np.outer(shape / len(MODES), np.concatenate([force, torque]))
    return out


def drift(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(n, 6): warm-up toward a final offset plus a random walk, from sim time 0."""
    final = rng.standard_normal(6) * WARMUP
    steps = rng.standard_normal((len(t), 6)) * RANDOM_WALK * math.sqrt(1.0 / RATE)
    return final * (1.0 - np.exp(-t[:, None] / WARMUP_TIME)) + np.cumsum(steps, axis=0)


def calibration_error(accuracy: float, rng: np.random.Generator) -> np.ndarray:
    """(6, 6) a sensor's calibration of ``accuracy`` at the estimator's full scale."""
    return calibration_matrix(accuracy, *FULL_SCALE, rng)


class Run:
    """One recorded run: its messages, robot model, truth and settings."""

    def __init__(self, bag: Path) -> None:
        self.bag = bag
        self.rec, reading = _Recording(), BagReading()
        feed_bag(bag, self.rec, reading=reading)
        self.urdf = reading.robot_description
        self.truth = read_run(bag).truth
        robot = read_robot_config(str(bag / BAG_ROBOT_FILE))
        self.settings = {"sensor_frame": robot.sensor_frame, "base_frame": robot.base_frame}
        self.stamps = np.concatenate([s for s, _, _ in self.rec.samples])
        self.wrenches = np.concatenate([w for _, w, _ in self.rec.samples])
        self.frames = np.concatenate(
            [np.broadcast_to(np.asarray(f, dtype=object), len(s)) for s, _, f in self.rec.samples]
        )

    def exploration(self, read: np.ndarray, accuracy: float, c: np.ndarray | None = None):
        """An exploration of the wrenches ``read``; the cached tare pass read through the
        same calibration ``c`` (one sensor), its noise left to be learnt anew (it was the
        noise-free sensor's)."""
        ex = exploration_from(self.settings | {"accuracy": accuracy})
        use_cached_tares(ex, self.bag / BAG_TARE_FILE)
        ex.noise = None
        if c is not None and ex.cached_tare is not None:
            windows = {p: replace(w, mean=c @ w.mean) for p, w in ex.tares.items()}
            ex.cached_tare = replace(ex.cached_tare, windows=windows)
        ex.robot, ex.robot_problem = robot_from(self.settings, self.urdf)
        ex.add_samples(self.stamps, read, self.frames)
        for stamp, label in self.rec.labels:
            ex.add_label(stamp, label)
        for stamp, names, positions in self.rec.joints:
            ex.add_joint_state(stamp, names, positions)
        return ex

    def read(
        self, tau: float, parts: set[str], rng: np.random.Generator, c: np.ndarray
    ) -> np.ndarray:
        """The wrenches read through the case's sensor (calibration ``c``)."""
        t = self.stamps * 1e-9
        w = self.wrenches.copy()
        if "vibration" in parts:
            w += ringing(t, self.rec.labels, rng)
        if "calibration" in parts:
            w = w @ c.T
        if "drift" in parts:
            w += drift(t, rng)
        return w + ar1(len(w), tau, rng)

    def window(self, label: str) -> tuple[int, int]:
        """[start, stop) stamps (ns) of window ``label``."""
        labels = sorted(self.rec.labels)
        k = next(i for i, (_, lbl) in enumerate(labels) if lbl == label)
        return labels[k][0], labels[k + 1][0]


def pass_for_target(solution, accuracy: float) -> float:
    """s of the object pass the planner needs for TARGET_SIGMA with the noise learnt (and
    the calibration's share), at the reference plan's tilt and moves."""
    calibration = Calibration(accuracy, *FULL_SCALE) if accuracy > 0 else None
    plan = Plan(gravity_home=(0.0, 0.0, 1.0), noise=solution.noise, calibration=calibration)
    advice = dwell_for_target(plan, TARGET_SIGMA, max_time=600.0, information="kinematics+mount")
    return advice.plan.duration() if advice.feasible else math.inf


def run_case(runs: list[Run], tau: float, parts: set[str], copies: int, seed: int, case: int):
    accuracy = CALIBRATION_ACCURACY if "calibration" in parts else 0.0
    truth_noise = ar1_noise(SIGMA, tau, RATE)
    ratios, bound_ratios, passes = [], [], []
    flagged, slips, missing = Counter(), 0, 0
    for b, run in enumerate(runs):
        for k in range(copies):
            rng = np.random.default_rng(np.random.SeedSequence((seed, case, b, k)))
            c = calibration_error(CALIBRATION_ACCURACY, rng)
            if "calibration" not in parts:
                c = np.eye(6)
            ex = run.exploration(run.read(tau, parts, rng, c), accuracy, c)
            solution = ex.solve()
            if solution.status != "OK":
                flagged[solution.reason[:60]] += 1
            c = solution.consistency
            slips += c is not None and not c.consistent
            e = solution.estimate
            if e is None:
                missing += 1
                continue
            truth = run.truth
            error = np.array([e.mass - truth.mass, *(e.com - truth.com)])
            sigma = np.array([e.sigma_mass, *e.sigma_com])
            ratios.append(error / sigma)
            ex.noise_model = lambda until_ns=None, m=truth_noise: m  # the true noise
            bound = ex.solve().estimate
            if bound is not None:
                bound_ratios.append(sigma / np.array([bound.sigma_mass, *bound.sigma_com]))
            passes.append(pass_for_target(solution, accuracy))
    return ratios, bound_ratios, passes, flagged, slips, missing


def detection(
    runs: list[Run], copies: int, seed: int, tau: float, parts: set[str], slip: float
) -> tuple[str, str]:
    """How often a real slip (the COM moved by ``slip``, m) and a real motion are caught
    under a sensor of ``tau`` and ``parts``."""
    accuracy = CALIBRATION_ACCURACY if "calibration" in parts else 0.0
    slips = motions = total = 0
    for b, run in enumerate(runs):
        for k in range(copies):
            rng = np.random.default_rng(np.random.SeedSequence((seed, 99, b, k)))
            c = calibration_error(CALIBRATION_ACCURACY, rng) if accuracy else np.eye(6)
            read = run.read(tau, parts, rng, c)
            # the COM moves by SLIP from the second tilt on, while the object is held
            after = np.zeros(len(run.stamps), dtype=bool)
            for label in HELD_AFTER_SLIP:
                a, z = run.window(label)
                after |= (run.stamps >= a) & (run.stamps < z)
            shift = rng.standard_normal(3)
            shift *= slip / np.linalg.norm(shift)
            force = run.wrenches[after, :3]  # along gravity, as the object's
            load = force / np.linalg.norm(force, axis=1, keepdims=True) * run.truth.mass * 9.80665
            slipped = read.copy()
            slipped[after, 3:] += np.cross(shift, load)
            s = run.exploration(slipped, accuracy, c).solve()
            slips += s.consistency is not None and not s.consistency.consistent
            # a 0.5 N slide through the object's tilt_x+ window
            a, z = run.window(OBJECT_PREFIX + "tilt_x+")
            inside = (run.stamps >= a) & (run.stamps < z)
            moved = read.copy()
            moved[inside, 0] += 0.5 * (run.stamps[inside] - a) / (z - a)
            m = run.exploration(moved, accuracy, c).solve()
            motions += any("motion" in note for note in m.notes)
            total += 1
    return f"{slips}/{total}", f"{motions}/{total}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bags", type=Path, help="a directory of runs (ideal sensor)")
    parser.add_argument("--copies", type=int, default=1)
    parser.add_argument("--times", default="0,1,2,5,20", help="correlation times, ms")
    parser.add_argument(
        "--parts",
        default="noise;noise,vibration;noise,drift;noise,vibration,drift,calibration",
        help="cases: sets of parts separated by ';'",
    )
    parser.add_argument("--runs", type=int, default=0, help="use the first N runs (0: all)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    bags = sorted(p.parent for p in args.bags.glob("**/metadata.yaml"))
    runs = [Run(bag) for bag in bags[: args.runs or None]]
    print(f"{len(runs)} runs from {args.bags}, {args.copies} copies each")
    print(
        "| T | parts | rms(error/sigma) m, x, y, z | within 2 sigma | flagged | slip alarms "
        "| no estimate | sigma / bound (median) | pass for 1 mm p95 (median) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    case = 0
    for parts_text in args.parts.split(";"):
        parts = set(parts_text.split(","))
        for tau in [float(t) * 1e-3 for t in args.times.split(",")]:
            case += 1
            ratios, bounds, passes, flagged, slips, missing = run_case(
                runs, tau, parts, args.copies, args.seed, case
            )
            total = len(runs) * args.copies
            r = np.array(ratios).reshape(-1, 4)
            rms = np.sqrt((r**2).mean(axis=0))
            within = (np.abs(r) <= 2).mean(axis=0) * 100
            bound = np.median(np.array(bounds).reshape(-1, 4), axis=0)
            print(
                f"| {tau * 1e3:g} ms | {'+'.join(sorted(parts))} | "
                f"{', '.join(f'{v:.2f}' for v in rms)} | "
                f"{', '.join(f'{v:.0f}' for v in within)} % | {sum(flagged.values())}/{total} | "
                f"{slips}/{total} | {missing}/{total} | {', '.join(f'{v:.2f}' for v in bound)} | "
                f"{np.median(passes):.1f} s |",
                flush=True,
            )
            for reason, count in flagged.most_common(2):
                print(f"|  | {count}x {reason} | | | | | | | |", flush=True)
    print(
        "\n| sensor | slip 1 mm | 2 mm | 5 mm | 0.5 N slide in a window |\n|---|---|---|---|---|"
    )
    for tau, parts in ((0.0, {"noise"}), (0.005, {"noise", "vibration", "drift", "calibration"})):
        caught = [
            detection(runs, args.copies, args.seed, tau, parts, d) for d in (1e-3, 2e-3, 5e-3)
        ]
        name = "white" if tau == 0 else "realistic parts, T = 5 ms"
        print(f"| {name} | {' | '.join(c[0] for c in caught)} | {caught[-1][1]} |", flush=True)


if __name__ == "__main__":
    main()
