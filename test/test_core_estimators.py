"""Estimators: exactness, convention, efficiency, consistency test and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from com_core.estimation.fits.errors import (
    IllConditionedError,
    NonFiniteError,
    NonPositiveMassError,
    TooFewPosesError,
)
from com_core.estimation.fits.estimators import check_consistency, crlb, ml, two_pose
from com_core.estimation.fits.windows import window_from_mean
from com_core.paper.synthetic import Load, object_windows
from com_core.planning.planner import Plan
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    SensorModel,
    gravity_in_sensor,
    gravity_wrench,
    rotation_about,
)

G = STANDARD_GRAVITY
COV = np.diag([1e-4] * 3 + [1e-6] * 3)  # a nominal window covariance for weighting
REFERENCE = Plan()  # default plan: home, tilt +-pi/6 about x and y, 1 s at 1 kHz


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    return rotation_about(rng.normal(size=3), rng.uniform(0.0, math.pi))


def exact_windows(mass, com, rotations):
    return [
        window_from_mean(f"p{i}", gravity_wrench(mass, com, gravity_in_sensor(R)), COV)
        for i, R in enumerate(rotations)
    ]


@pytest.mark.parametrize("method", [ml, two_pose])
def test_zero_noise_is_exact_at_random_objects_and_orientations(method):
    rng = np.random.default_rng(7)
    for _ in range(50):
        mass, com = rng.uniform(0.02, 5.0), rng.normal(0.0, 0.08, 3)
        start = random_rotation(rng)
        tilts = [rotation_about(rng.normal(size=3), rng.uniform(0.05, 1.2)) for _ in range(4)]
        est = method(exact_windows(mass, com, [start] + [start @ t for t in tilts]))
        assert abs(est.mass - mass) < 1e-12 * mass
        assert np.abs(est.com - com).max() < 1e-9


def test_two_pose_is_the_papers_equations_for_a_top_grasp():
    """Top grasp (gravity along -z), tilt about x: eqs. 3, 7, 8, 11 under tau = p x f."""
    mass, (x, y, z), theta = 0.1, (0.01, -0.02, -0.06), 0.3
    (f1, t1), (f2, t2) = (
        np.split(gravity_wrench(mass, (x, y, z), gravity_in_sensor(R)), 2)
        for R in (np.eye(3), rotation_about("x", theta))
    )
    assert_allclose(-f1[2] / G, mass)  # eq. 3
    assert_allclose(t1[1] / (mass * G), x)  # eq. 7 (the paper prints -tau_y / mg)
    assert_allclose(-t1[0] / (mass * G), y)  # eq. 8 (the paper prints +tau_x / mg)
    assert_allclose((f2[2] * y - t2[0]) / f2[1], z)  # eq. 11 from eq. 10
    est = two_pose(exact_windows(mass, (x, y, z), [np.eye(3), rotation_about("x", theta)]))
    assert_allclose(est.com, (x, y, z), atol=1e-12)


def test_ml_covariance_matches_monte_carlo_spread_and_the_crlb():
    rng = np.random.default_rng(11)
    load = Load(0.1, (0.01, -0.02, 0.08))
    trials = 600
    est = np.array(
        [
            np.concatenate([[e.mass], e.com])
            for e in (ml(object_windows(REFERENCE, load, rng)[0]) for _ in range(trials))
        ]
    )
    bound = crlb(
        load.mass,
        load.com,
        REFERENCE.gravity_directions(),
        np.repeat(REFERENCE.window_cov()[None], 5, axis=0),
    )
    reported = ml(object_windows(REFERENCE, load, rng)[0]).cov
    # the sd of n Gaussian draws has relative sd 1 / sqrt(2 (n - 1)); allow 4 of them
    tol = 4.0 / math.sqrt(2 * (trials - 1))
    assert_allclose(est.std(axis=0, ddof=1), np.sqrt(np.diag(bound)), rtol=tol)
    assert_allclose(np.sqrt(np.diag(reported)), np.sqrt(np.diag(bound)), rtol=0.02)
    assert np.all(
        np.abs(est.mean(axis=0) - [load.mass, *load.com]) < 4 * est.std(axis=0) / math.sqrt(trials)
    )


def test_ml_beats_the_papers_two_pose_on_the_same_windows():
    rng = np.random.default_rng(3)
    load = Load(0.1, (0.01, -0.02, 0.08))
    runs = [object_windows(REFERENCE, load, rng)[0] for _ in range(300)]
    sd_ml = np.std([ml(w).com for w in runs], axis=0)
    sd_2p = np.std([two_pose(w).com for w in runs], axis=0)
    assert np.all(sd_ml < 0.7 * sd_2p)


@pytest.mark.slow
def test_chi_square_has_its_nominal_false_alarm_rate_on_clean_data():
    rng = np.random.default_rng(5)
    load = Load(0.1, (0.01, -0.02, 0.08))
    alpha, trials = 0.02, 1000
    alarms = sum(
        not check_consistency(object_windows(REFERENCE, load, rng)[0], alpha=alpha).consistent
        for _ in range(trials)
    )
    # binomial(1000, 0.02): mean 20, sd 4.4
    assert 5 <= alarms <= 38


def test_a_10_mm_shift_is_flagged_and_the_moved_pose_named():
    """A shift along gravity moves no torque, so no force sensor sees it: the shifts here
    are 10 mm in random directions perpendicular to gravity at the moved pose."""
    rng = np.random.default_rng(9)
    load = Load(0.1, (0.01, -0.02, 0.08))
    detected = named = 0
    trials = 60
    for t in range(trials):
        windows, _ = object_windows(REFERENCE, load, rng)
        k = 1 + t % 4
        moved = windows[k]
        g_s = REFERENCE.gravity_directions()[k] * G
        direction = np.cross(g_s, rng.normal(size=3))
        shift = 0.010 * direction / np.linalg.norm(direction)
        extra = np.concatenate([np.zeros(3), np.cross(shift, load.mass * g_s)])  # torque only
        windows[k] = window_from_mean(moved.pose, moved.mean + extra, moved.cov, moved.n)
        result = check_consistency(windows)
        detected += not result.consistent
        named += result.suspect_pose == moved.pose
    assert detected == trials
    assert named >= 0.9 * trials


def test_paper_reconfiguration_is_flagged_at_the_default_plan():
    rng = np.random.default_rng(13)
    load = Load(0.1, (0.01, -0.02, 0.08))
    flags = [
        not check_consistency(object_windows(REFERENCE, load, rng, shift_sigma=0.01)[0]).consistent
        for _ in range(40)
    ]
    assert all(flags)


def test_bad_input_gives_its_error():
    w = exact_windows(0.1, (0.0, 0.0, 0.05), [np.eye(3), rotation_about("x", 0.5)])
    for method in (ml, two_pose):
        with pytest.raises(TooFewPosesError):
            method(w[:1])
        with pytest.raises(IllConditionedError, match="too close"):
            method([w[0], window_from_mean("again", w[0].mean, COV)])
        with pytest.raises(NonPositiveMassError, match="no load"):
            method([window_from_mean(p, np.zeros(6), COV) for p in ("a", "b")])
    with pytest.raises(NonFiniteError):
        window_from_mean("nan", np.full(6, np.nan), COV)
    # a tilt below the noise: 0.05 rad seen through one sample of 0.1 N noise
    sensor = SensorModel.from_scalars(0.1, 0.1)
    noisy = [window_from_mean(x.pose, x.mean, sensor.sample_covariance()) for x in w]
    tiny = exact_windows(0.1, (0, 0, 0.05), [np.eye(3), rotation_about("x", 0.05)])
    tiny = [window_from_mean(x.pose, x.mean, sensor.sample_covariance()) for x in tiny]
    with pytest.raises(IllConditionedError, match="sigma of the noise"):
        ml(tiny)
    assert ml(noisy).mass == pytest.approx(0.1)
