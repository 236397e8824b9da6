"""Planner predictions against Monte Carlo spreads, its inversion, and the study CLI."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from com_core.estimators import ml
from com_core.planner import Plan, dwell_for_target, predict
from com_core.study import Cell, run_cell
from com_core.synthetic import Load, exploration_samples, object_windows
from com_core.windows import pose_of_label, reduce_window, subtract_tare
from com_core.wrench_model import SensorModel

LOAD = Load(0.1, (0.01, -0.02, 0.08))
HAND = Load(0.7, (0.0, 0.0, 0.04))
SENSOR = SensorModel.from_scalars(0.1, 0.005)


def spread(runs: int, make_windows) -> np.ndarray:
    """Monte Carlo sd of (mass, com) of ``ml`` over ``runs`` explorations."""
    est = np.array([(lambda e: [e.mass, *e.com])(ml(make_windows())) for _ in range(runs)])
    return est.std(axis=0, ddof=1)


# 900 runs: the measured sd has relative sd 1/sqrt(2 * 899) = 2.4 %, so 10 % is 4 sd
RUNS = 900


def test_prediction_is_within_10_percent_of_raw_sample_runs():
    """Raw samples through the whole core: sensor model, windows, per-pose tare, ML."""
    plan = Plan(dwell=0.1, sensor=SENSOR, com_guess=LOAD.com, gravity_home=(0, 0, 1))
    rng = np.random.default_rng(21)

    def windows():
        reduced = [
            (pose_of_label(label)[0], reduce_window(pose_of_label(label)[1], x, SENSOR))
            for label, x in exploration_samples(plan, LOAD, HAND, rng)
        ]
        tares = [w for kind, w in reduced if kind == "tare"]
        return subtract_tare([w for kind, w in reduced if kind == "object"], tares)

    measured = spread(RUNS, windows)
    pred = predict(plan)
    np.testing.assert_allclose(measured, [pred.sigma_mass, *pred.sigma_com], rtol=0.10)


@pytest.mark.parametrize(("tilt", "target"), [(0.05, 3e-3), (math.pi / 6, 0.3e-3)])
def test_dwell_for_a_target_meets_it_within_10_percent(tilt, target):
    plan = Plan(tilt=tilt, sensor=SENSOR, com_guess=LOAD.com, tare_dwell=5.0)
    advice = dwell_for_target(plan, target_com_sigma=target)
    assert advice.feasible, advice.reason
    assert advice.prediction.sigma_com.max() <= target
    rng = np.random.default_rng(22)
    measured = spread(RUNS, lambda: object_windows(advice.plan, LOAD, rng)[0])
    assert measured[1:].max() == pytest.approx(target, rel=0.10)


def test_small_tilt_needs_about_100_times_the_dwell_and_says_so():
    plan = Plan(sensor=SENSOR, com_guess=LOAD.com)
    big = dwell_for_target(plan, 0.3e-3, max_tilt=math.pi / 6)
    small = dwell_for_target(plan, 0.3e-3, max_tilt=0.05)
    ratio = small.plan.dwell / big.plan.dwell
    assert 80 < ratio < 125  # sin^2(pi/6) / sin^2(0.05) = 100
    limited = dwell_for_target(plan, 0.3e-3, max_tilt=0.05, max_time=10.0)
    assert not limited.feasible
    assert "needs" in limited.reason and "> limit 10 s" in limited.reason
    assert limited.plan.duration() == pytest.approx(10.0)
    tare_bound = dwell_for_target(Plan(sensor=SENSOR, tare_dwell=0.01), 0.05e-3)
    assert not tare_bound.feasible and "longer tare" in tare_bound.reason


def test_plan_validation():
    with pytest.raises(ValueError, match="tilt"):
        Plan(tilt=0.0)
    with pytest.raises(ValueError, match="axes"):
        Plan(axes=("q",))
    assert [name for name, _ in Plan(axes=("x",), both_directions=False).poses()] == [
        "home",
        "tilt_x+",
    ]


def test_study_cells_are_deterministic_and_reproduce_table_ii_reading():
    cell = Cell("II", "paper", math.pi / 6, 0.0, 10.0)
    a, b = run_cell(cell, 400, seed=1), run_cell(cell, 400, seed=1)
    assert a == b
    expected = 10.0e-3 / math.tan(math.pi / 6)  # the paper's reading: s cot(theta)
    assert a["two_pose"]["sd"][2] == pytest.approx(expected, rel=4 / math.sqrt(800))


def test_study_cli_json_and_figures(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "com_core.study",
            "--trials",
            "12",
            "--json",
            "--workers",
            "2",
            "--out",
            str(tmp_path),
        ],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    records = [json.loads(line) for line in out.splitlines()]
    assert len(records) == 30
    for r in records:
        assert {"theta", "noise", "samples_per_pose", "plan", "crlb"} <= r.keys()
        assert len(r["ml"]["sd"]) == 3 and len(r["two_pose"]["sd"]) == 3
    assert {r["samples_per_pose"] for r in records} == {1, 1000}
    assert len(list(tmp_path.glob("fig*_z_theta_*.png"))) == 3
