"""com_core.estimation.fits.windows: a window reduced to its mean and covariance, bad samples
and motion refused, the per-pose tare."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from com_core.estimation.fits.errors import (
    MissingTareError,
    MotionError,
    NonFiniteError,
    SaturationError,
)
from com_core.estimation.fits.estimators import ml
from com_core.estimation.fits.windows import reduce_window, subtract_tare
from com_core.paper.synthetic import Load, exploration_samples
from com_core.planning.planner import Plan
from com_core.sensing.wrench_model import SensorModel, gravity_wrench

SENSOR = SensorModel.from_scalars(0.1, 0.005, limit_f=50.0, limit_tau=5.0)


def test_reduce_window_mean_covariance_and_bad_samples():
    rng = np.random.default_rng(3)
    w_true = gravity_wrench(0.5, (0.01, 0.02, 0.1), [0, 0, -9.8])
    x = SENSOR.measure(np.tile(w_true, (1000, 1)), rng)
    win = reduce_window("home", x, SENSOR)
    assert_allclose(win.mean, x.mean(axis=0))
    assert_allclose(win.cov, np.cov(x, rowvar=False) / 1000)
    x_nan = x.copy()
    x_nan[17, 4] = np.nan
    with pytest.raises(NonFiniteError, match="1 of 1000 samples"):
        reduce_window("home", x_nan, SENSOR)
    x_sat = x.copy()
    x_sat[5, 2] = 50.0
    with pytest.raises(SaturationError, match="fz"):
        reduce_window("home", x_sat, SENSOR)
    with pytest.raises(ValueError, match="too few"):
        reduce_window("home", x[:5])
    assert_allclose(reduce_window("home", x[:5], SENSOR).cov, SENSOR.sample_covariance() / 5)


def test_motion_inside_a_window_is_rejected_and_static_windows_are_not():
    rng = np.random.default_rng(4)
    w_true = gravity_wrench(0.5, (0.01, 0.02, 0.1), [0, 0, -9.8])
    static = [SENSOR.measure(np.tile(w_true, (500, 1)), rng) for _ in range(300)]
    for x in static:
        reduce_window("home", x, SENSOR)  # no false alarm in 300 windows
    drift = static[0] + np.linspace(0.0, 0.2, 500)[:, None] * [1, 0, 0, 0, 0, 0]
    with pytest.raises(MotionError, match="fx drifts"):
        reduce_window("home", drift)
    shake = static[1] + 0.5 * np.sin(np.arange(500) * 0.9)[:, None] * [0, 0, 0, 0, 0.1, 0]
    with pytest.raises(MotionError, match="variance of ty"):
        reduce_window("home", shake, SENSOR)


def test_per_pose_tare_with_a_heavy_off_axis_hand_and_a_constant_tare_is_wrong():
    """A 1.2 kg hand with its COM 36 mm off-axis; the object is 0.1 kg."""
    rng = np.random.default_rng(5)
    plan = Plan(dwell=0.5, sensor=SENSOR, gravity_home=(0.0, 0.0, 1.0))
    load, hand = Load(0.1, (0.005, -0.01, 0.12)), Load(1.2, (0.03, -0.02, 0.06))
    labelled = exploration_samples(plan, load, hand, rng)
    windows = [
        (lbl.split("/", 1), reduce_window(lbl.split("/", 1)[1], x, SENSOR)) for lbl, x in labelled
    ]
    tares = [w for (kind, _), w in windows if kind == "tare"]
    objects = [w for (kind, _), w in windows if kind == "object"]
    est = ml(subtract_tare(objects, tares))
    err = np.abs(est.com - load.com)
    assert np.all(err < 4 * est.sigma_com)
    assert abs(est.mass - load.mass) < 4 * est.sigma_mass
    # the home tare subtracted from every pose leaves the hand's change of wrench in
    constant = ml(subtract_tare(objects, [replace(t, mean=tares[0].mean) for t in tares]))
    assert np.abs(constant.com - load.com).max() > 20 * est.sigma_com.max()
    with pytest.raises(MissingTareError, match="tilt_y-"):
        subtract_tare(objects, tares[:-1])
