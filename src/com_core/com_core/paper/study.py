"""Monte Carlo reproduction of the paper's Tables I and II, beside our estimator and the CRLB.

Run ``python -m com_core.paper.study [--trials N] [--seed S] [--json] [--out DIR]``.

Object: the paper's 0.1 kg, COM p = (10, -20, -60) mm in the sensor frame, top grasp
(gravity along the sensor's -z at home, as in the paper). Two settings per cell:

- ``paper``: one sample per pose, two poses (home, one tilt about x), the hand's
  wrench known exactly: the data the paper's method was given.
- ``ours``: windows of 1 s at 1 kHz (1000 samples) per pose, the default plan (home,
  tilt +-theta about x and y: 5 poses), hand wrench known exactly (as the paper).

Both methods (``two_pose``: the paper's equations; ``ml``), and ``ml`` with each pose's
orientation known (``kinematics``: the information the robot's joint angles add), see the
same windows in every trial, with the tilt check off (``min_tilt_sigmas=0``) so that
every trial gives a number, as in the paper; ``refused`` is the share of trials the
default check would refuse. Spreads are sample standard deviations of the error in
mm, with a robust one (1.4826 x median absolute deviation) beside it because the
two-pose z at small tilts is heavy-tailed (a ratio of noisy numbers).

Table I: noise sigma on every force (N) and torque (N m) axis per sample. The paper's
table is labelled mm but is in metres (sigma_x = 0.0102 for noise 0.01 on a 0.98 N load
is 10.2 mm = 0.01 / 0.98 m); its numbers are shown converted to mm. Its 4th row is
labelled noise 0.01 again; the grid's missing cell is (0.05, 0.1), where it is shown,
though its x and y (11 mm) fit noise 0.01. With 20 trials per cell its z column is
dominated by a few outliers.

Table II: the COM moves by N(0, s^2 I) per axis at each tilted pose (s = 0.1, 10,
30 mm). In the ``paper`` setting the data are noise-free, as in the paper, and the
error is taken against the COM at the last (tilted) pose; the paper's printed values
fit this reading (sigma_z ~ s cot(theta)). In ``ours`` the sensor has the reference
noise (0.1 N, 0.005 N m per sample) and the error is taken against the COM at home;
``flagged`` is the share of runs the consistency test marks as moved.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.estimators import (
    MIN_TILT_SIGMAS,
    Estimate,
    check_consistency,
    check_windows,
    crlb,
    ml,
)
from com_core.estimation.fits.estimators import two_pose as two_pose_estimate
from com_core.estimation.fits.known_gravity import Observation, kinematic_ml
from com_core.estimation.fits.windows import Window
from com_core.paper.synthetic import Load, object_windows
from com_core.planning.planner import Plan
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.wrench_model import SensorModel, gravity_wrench

__all__ = ["PAPER_LOAD", "Cell", "main", "run_cell", "table_cells"]

PAPER_LOAD = Load(mass=0.1, com=(0.010, -0.020, -0.060))
THETAS = (0.05, math.pi / 6, math.pi / 3)
THETA_NAMES = {0.05: "0.05", math.pi / 6: "pi/6", math.pi / 3: "pi/3"}
REFERENCE_SENSOR = (0.1, 0.005)  # sigma_f N, sigma_tau N m per sample (docs/design.md)

# The paper's Table I as printed (labelled mm, in metres): (theta, noise) -> (x, y, z).
PAPER_TABLE_I = {
    (0.05, 0.01): (0.0102, 0.0109, 12.86),
    (math.pi / 6, 0.01): (0.0105, 0.0089, 0.0785),
    (math.pi / 3, 0.01): (0.0112, 0.0007, 0.0221),
    (0.05, 0.1): (0.0112, 0.0097, 810.0087),
    (math.pi / 6, 0.1): (0.1151, 0.0988, 11.3458),
    (math.pi / 3, 0.1): (0.0947, 0.1038, 6.5022),
}
# The paper's Table II (mm): (theta, shift sigma mm) -> sigma_z.
PAPER_TABLE_II = {
    (0.05, 0.1): 2.0073,
    (math.pi / 6, 0.1): 0.1548,
    (math.pi / 3, 0.1): 0.0523,
    (0.05, 10.0): 180.5769,
    (math.pi / 6, 10.0): 17.5137,
    (math.pi / 3, 10.0): 5.6429,
    (0.05, 30.0): 624.5318,
    (math.pi / 6, 30.0): 53.4869,
    (math.pi / 3, 30.0): 17.3761,
}

Method = Callable[..., Estimate]
METHODS: dict[str, Method] = {"two_pose": two_pose_estimate, "ml": ml}
KINEMATICS = "kinematics"
"""``ml`` with each pose's orientation known (``known_gravity.kinematic_ml``) on the same
windows: the information the robot's joint angles add."""
ESTIMATORS = (*METHODS, KINEMATICS)


@dataclass(frozen=True)
class Cell:
    """One cell of a table in one setting."""

    table: str  # "I" or "II"
    setting: str  # "paper" or "ours"
    theta: float  # rad
    noise: float  # per-sample sigma on every axis (Table I), N and N m
    shift_mm: float = 0.0  # Table II COM shift sigma, mm

    def plan(self) -> Plan:
        if self.table == "I":
            sensor = SensorModel.from_scalars(self.noise, self.noise)
        else:
            sensor = SensorModel.from_scalars(*REFERENCE_SENSOR)
        common = dict(
            tilt=self.theta,
            tare_dwell=math.inf,
            sensor=sensor,
            mass_guess=PAPER_LOAD.mass,
            com_guess=PAPER_LOAD.com,
        )
        if self.setting == "paper":
            return Plan(axes=("x",), both_directions=False, dwell=1.0 / sensor.rate_hz, **common)
        return Plan(dwell=1.0, **common)

    @property
    def noisy(self) -> bool:
        """Table II's paper setting is noise-free, as in the paper."""
        return not (self.table == "II" and self.setting == "paper")


def table_cells() -> list[Cell]:
    cells = [Cell("I", s, t, n) for n in (0.01, 0.1) for t in THETAS for s in ("paper", "ours")]
    cells += [
        Cell("II", s, t, 0.0, shift)
        for shift in (0.1, 10.0, 30.0)
        for t in THETAS
        for s in ("paper", "ours")
    ]
    return cells


def _robust_sd(x: NDArray[np.float64]) -> float:
    x = x[np.isfinite(x)]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else math.nan


def _sd(x: NDArray[np.float64]) -> float:
    x = x[np.isfinite(x)]
    return float(np.std(x, ddof=1)) if x.size > 1 else math.nan


def _orientations(plan: Plan) -> list[NDArray[np.float64]]:
    """R_base_sensor per pose of ``plan``: home with gravity along the sensor's -z (the
    paper's top grasp) as the base's, each tilt its rotation from home."""
    return [rotation for _, rotation in plan.poses()]


def _load_wrenches(rotations: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The paper's load's wrench (n, 6) at each orientation, N and N m."""
    gravities = np.array([r.T @ np.asarray(DEFAULT_GRAVITY) for r in rotations])
    return gravity_wrench(PAPER_LOAD.mass, PAPER_LOAD.com, gravities)


def run_cell(cell: Cell, trials: int, seed: int, keep_z: bool = False) -> dict:
    """Run ``trials`` explorations of ``cell``; return its record (lengths in metres).

    Record keys: the cell's fields, samples_per_pose, plan, n_poses, trials, and per
    estimator (``ESTIMATORS``) {sd: [x, y, z], robust_sd: [...], sd_mass, failed};
    crlb {mass, com [x, y, z]} (the wrenches' bound) and kinematics_bound (the kinematic
    fit's); refused, flagged (shares of trials); with ``keep_z``, the z errors per
    estimator.
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, *_cell_key(cell)]))
    plan = cell.plan()
    rotations = _orientations(plan)
    errors = {name: np.full((trials, 4), np.nan) for name in ESTIMATORS}
    refused = flagged = 0
    truth_idx = -1 if cell.setting == "paper" and cell.table == "II" else 0
    for t in range(trials):
        windows, coms = object_windows(
            plan, PAPER_LOAD, rng, shift_sigma=cell.shift_mm * 1e-3, noise=cell.noisy
        )
        truth = np.concatenate([[PAPER_LOAD.mass], coms[truth_idx]])
        for name, method in METHODS.items():
            try:
                est = method(windows, min_tilt_sigmas=0.0)
            except EstimationError:
                continue
            errors[name][t] = np.concatenate([[est.mass], est.com]) - truth
        with contextlib.suppress(EstimationError):
            est = kinematic_ml(
                [Observation(w, r) for w, r in zip(windows, rotations, strict=True)]
            ).estimate
            errors[KINEMATICS][t] = np.concatenate([[est.mass], est.com]) - truth
        try:
            check_windows(windows, MIN_TILT_SIGMAS)
        except EstimationError:
            refused += 1
        if cell.noisy:
            with contextlib.suppress(EstimationError):
                flagged += not check_consistency(windows, locate=False).consistent
    record: dict = asdict(cell) | {
        "theta_name": THETA_NAMES[cell.theta],
        "samples_per_pose": plan.samples_per_window(),
        "n_poses": len(plan.poses()),
        "plan": ", ".join(name for name, _ in plan.poses()),
        "trials": trials,
        "refused": refused / trials,
        "flagged": flagged / trials if cell.noisy else None,
    }
    for name, err in errors.items():
        record[name] = {
            "sd": [_sd(err[:, k]) for k in (1, 2, 3)],
            "robust_sd": [_robust_sd(err[:, k]) for k in (1, 2, 3)],
            "sd_mass": _sd(err[:, 0]),
            "failed": float(np.mean(np.isnan(err[:, 0]))),
        }
        if keep_z:
            record[name]["z_errors"] = err[:, 3].tolist()
    if cell.noisy:
        n = record["n_poses"]
        bound = crlb(
            PAPER_LOAD.mass,
            PAPER_LOAD.com,
            plan.gravity_directions(),
            np.repeat(plan.window_cov()[None], n, axis=0),
        )
        sd = np.sqrt(np.diag(bound))
        record["crlb"] = {"mass": float(sd[0]), "com": sd[1:].tolist()}
        noise_free = [  # the fit's covariance there is its bound at the truth
            Observation(Window(f"p{i}", wrench, plan.window_cov(), 1), r)
            for i, (wrench, r) in enumerate(zip(_load_wrenches(rotations), rotations, strict=True))
        ]
        sd = np.sqrt(np.diag(kinematic_ml(noise_free).estimate.cov))
        record["kinematics_bound"] = {"mass": float(sd[0]), "com": sd[1:].tolist()}
    else:
        record["crlb"] = record["kinematics_bound"] = None
    return record


def _cell_key(cell: Cell) -> tuple[int, ...]:
    return (
        1 if cell.table == "I" else 2,
        1 if cell.setting == "paper" else 2,
        round(cell.theta * 1e6),
        round(cell.noise * 1e6),
        round(cell.shift_mm * 1e3),
    )


def run_study(cells: Sequence[Cell], trials: int, seed: int, workers: int) -> list[dict]:
    """Records of all cells, computed in ``workers`` processes (deterministic per seed)."""
    args = [(c, trials, seed, c.table == "I" and c.noise == 0.1) for c in cells]
    if workers <= 1:
        return [run_cell(*a) for a in args]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(run_cell, *zip(*args, strict=True)))


def _mm(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x * 1e3:.4g}"


def format_tables(records: Sequence[dict]) -> str:
    """Human-readable Tables I and II, paper beside ours, all in mm."""
    lines = [
        f"Object: m = {PAPER_LOAD.mass} kg, COM = {tuple(c * 1e3 for c in PAPER_LOAD.com)} mm"
        " (sensor frame); spreads are sd of the error in mm (robust sd in brackets).",
        "",
        "Table I: COM spread vs tilt theta (rad) and per-sample noise (N and N m, every axis)",
        f"{'setting':7} {'theta':>5} {'noise':>5} {'axis':>4} {'paper':>9} {'two_pose':>22} "
        f"{'ml':>22} {'CRLB':>9} {'ml/CRLB':>7} {'2p/CRLB':>7} {'refused':>7} {'flagged':>7}",
    ]
    for r in (r for r in records if r["table"] == "I"):
        paper = PAPER_TABLE_I[(r["theta"], r["noise"])] if r["setting"] == "paper" else None
        for k, axis in enumerate("xyz"):
            tp, mlr, bound = r["two_pose"], r["ml"], r["crlb"]["com"][k]
            lines.append(
                f"{r['setting']:7} {r['theta_name']:>5} {r['noise']:>5} {axis:>4} "
                f"{_mm(paper[k]) if paper else '':>9} "
                f"{_mm(tp['sd'][k]):>10} [{_mm(tp['robust_sd'][k]):>9}] "
                f"{_mm(mlr['sd'][k]):>10} [{_mm(mlr['robust_sd'][k]):>9}] {_mm(bound):>9} "
                f"{mlr['sd'][k] / bound:7.3f} {tp['sd'][k] / bound:7.3f} "
                f"{r['refused']:7.1%} {r['flagged']:7.1%}"
            )
    lines += [
        "",
        "Table I, the information the joint angles add (hand known exactly): ml and the fit",
        "with each pose's orientation known (kinematics), each over its own bound, and the",
        "kinematic bound over the wrenches'",
        f"{'setting':7} {'theta':>5} {'noise':>5} {'axis':>4} {'ml':>10} {'kinematics':>10} "
        f"{'ml/CRLB':>7} {'kin/bnd':>7} {'bnd/CRLB':>8}",
    ]
    for r in (r for r in records if r["table"] == "I"):
        for k, axis in enumerate("xyz"):
            mlr, kin = r["ml"]["sd"][k], r[KINEMATICS]["sd"][k]
            bound, kin_bound = r["crlb"]["com"][k], r["kinematics_bound"]["com"][k]
            lines.append(
                f"{r['setting']:7} {r['theta_name']:>5} {r['noise']:>5} {axis:>4} "
                f"{_mm(mlr):>10} {_mm(kin):>10} {mlr / bound:7.3f} {kin / kin_bound:7.3f} "
                f"{kin_bound / bound:8.3f}"
            )
    lines += [
        "",
        "Table II: COM z spread when the object moves by N(0, s^2) per axis at each tilt",
        f"{'setting':7} {'theta':>5} {'s_mm':>5} {'paper':>9} {'two_pose':>22} {'ml':>22} "
        f"{'flagged':>7}",
    ]
    for r in (r for r in records if r["table"] == "II"):
        paper = PAPER_TABLE_II[(r["theta"], r["shift_mm"])] if r["setting"] == "paper" else None
        tp, mlr = r["two_pose"], r["ml"]
        flagged = "" if r["flagged"] is None else f"{r['flagged']:.1%}"
        lines.append(
            f"{r['setting']:7} {r['theta_name']:>5} {r['shift_mm']:>5g} "
            f"{paper if paper is not None else '':>9} "
            f"{_mm(tp['sd'][2]):>10} [{_mm(tp['robust_sd'][2]):>9}] "
            f"{_mm(mlr['sd'][2]):>10} [{_mm(mlr['robust_sd'][2]):>9}] {flagged:>7}"
        )
    return "\n".join(lines)


def write_figures(records: Sequence[dict], out_dir: Path) -> list[Path]:
    """Histograms of the z error, like the paper's Figs. 3-5 (Table I, noise 0.1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    chosen = [r for r in records if r["table"] == "I" and r["noise"] == 0.1]
    for fig_no, theta in enumerate(THETAS, start=3):
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
        for ax, setting in zip(axes, ("paper", "ours"), strict=True):
            r = next(x for x in chosen if x["theta"] == theta and x["setting"] == setting)
            for name in METHODS:
                z = np.asarray(r[name].get("z_errors", []), dtype=float) * 1e3
                z = z[np.isfinite(z)]
                if z.size == 0:
                    continue
                half = 5 * max(_robust_sd(z), 1e-12)
                ax.hist(
                    np.clip(z, -half, half),
                    bins=60,
                    range=(-half, half),
                    alpha=0.55,
                    label=f"{name} (sd {_sd(z):.3g} mm)",
                )
            ax.set_title(
                f"{setting}: {r['samples_per_pose']} sample(s)/pose, {r['n_poses']} poses"
            )
            ax.set_xlabel("z error (mm), clipped at 5 robust sd")
            ax.legend(fontsize=8)
        fig.suptitle(f"Fig. {fig_no}: COM z, theta = {THETA_NAMES[theta]} rad, noise 0.1")
        fig.tight_layout()
        path = out_dir / f"fig{fig_no}_z_theta_{THETA_NAMES[theta].replace('/', '_')}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m com_core.paper.study", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument(
        "--trials", type=int, default=2000, help="trials per cell (2000: sd to ~1.6%%, two digits)"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument("--json", action="store_true", help="print one JSON record per cell")
    parser.add_argument("--out", type=Path, default=Path("out/study"), help="figure directory")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--no-figures", action="store_true")
    args = parser.parse_args(argv)
    if args.trials < 2:
        parser.error("--trials must be >= 2")
    records = run_study(table_cells(), args.trials, args.seed, args.workers)
    paths = [] if args.no_figures else write_figures(records, args.out)
    for r in records:
        for name in ESTIMATORS:
            r[name].pop("z_errors", None)
    if args.json:
        for r in records:
            print(json.dumps(r))
    else:
        print(format_tables(records))
        for path in paths:
            print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
