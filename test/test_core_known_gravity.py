"""com_core.estimation.fits.known_gravity: the fit of hand, bias and object with each window's
orientation known (from kinematics) is exact without noise, reaches its Cramer-Rao bound, absorbs a
bias drift since the tare, and with ``fit_mount`` finds a sensor mounted off its URDF
frame and a tilted base."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from com_core.estimation.fits.errors import NonPositiveMassError, TooFewPosesError
from com_core.estimation.fits.estimators import crlb
from com_core.estimation.fits.known_gravity import (
    Observation,
    kinematic_ml,
    locate_move,
    mount_rpy,
)
from com_core.estimation.fits.windows import window_from_mean
from com_core.planning.planner import Plan
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    SensorModel,
    gravity_wrench,
    rotation_about,
)

MASS, COM = 0.1, (0.01, -0.02, 0.1)
HAND_MASS, HAND_COM = 1.0, (0.001, -0.002, 0.04)
BASE_GRAVITY = np.array([0.0, 0.0, -STANDARD_GRAVITY])
TARE_BIAS = np.array([0.5, -0.3, 0.2, 0.01, -0.02, 0.005])  # N, N m
# the reference plan: +-30 deg about x and y, 0.9 s windows at 1 kHz, 5 s tare
PLAN = Plan(
    tilt=math.pi / 6,
    dwell=0.9,
    tare_dwell=5.0,
    sensor=SensorModel.from_scalars(0.1, 0.005, rate_hz=1000.0),
    mass_guess=MASS,
    com_guess=COM,
    gravity_home=(0.0, 0.0, 1.0),
)
HOME = np.diag([1.0, -1.0, -1.0])  # R_base_sensor: the hand points down
ROTATIONS = [HOME @ r for _, r in PLAN.poses()]
SAMPLE_COV = PLAN.sensor.sample_covariance()
NO_DRIFT, NO_ROTATION = np.zeros(6), np.eye(3)


def seen_gravity(rotation, mount=NO_ROTATION, base=NO_ROTATION):
    """Gravity the (mounted) sensor sees at ``rotation``, m/s^2."""
    return mount.T @ rotation.T @ base @ BASE_GRAVITY


def observations(
    drift=NO_DRIFT, mount=NO_ROTATION, base=NO_ROTATION, bias_dwell=2.0, rate=NO_DRIFT
):
    """The windows of a run (noise-free means): a cached 5 s tare pass at every pose
    (bias TARE_BIAS, from t = 0 s), and 300 s later this run's empty-hand window at home
    and the object's windows (bias TARE_BIAS + drift); the bias drifts by ``rate`` (N/s,
    N m/s) all along."""
    out = []

    def add(rotation, dwell, load, epoch, time):
        g = seen_gravity(rotation, mount, base)
        bias = TARE_BIAS + (drift if epoch == 0 else 0) + rate * time
        mean = gravity_wrench(HAND_MASS, HAND_COM, g) + bias
        if load:
            mean = mean + gravity_wrench(MASS, COM, g)
        n = round(dwell * 1000)
        window = window_from_mean(f"w{len(out)}", mean, SAMPLE_COV / n, n)
        out.append(Observation(window, rotation, load, epoch, time))

    for k, rotation in enumerate(ROTATIONS):
        add(rotation, 5.0, False, 1, 6.0 * k)
    if bias_dwell:
        add(HOME, bias_dwell, False, 0, 295.0)
    for k, rotation in enumerate(ROTATIONS):
        add(rotation, 0.9, True, 0, 300.0 + 1.8 * k)
    return out


def noisy(obs, rng):
    return [
        Observation(
            window_from_mean(
                o.window.pose,
                o.window.mean + np.linalg.cholesky(o.window.cov) @ rng.standard_normal(6),
                o.window.cov,
                o.window.n,
            ),
            o.rotation,
            o.load,
            o.epoch,
            o.time,
        )
        for o in obs
    ]


def test_hand_bias_and_object_are_exact_without_noise():
    drift = np.array([0.25, -0.1, 0.05, 0.004, 0.002, -0.001])
    fit = kinematic_ml(observations(drift))
    assert fit.estimate.mass == pytest.approx(MASS, rel=1e-9)
    np.testing.assert_allclose(fit.estimate.com, COM, atol=1e-9)
    assert fit.hand.mass == pytest.approx(HAND_MASS, rel=1e-9)
    np.testing.assert_allclose(fit.hand.com, HAND_COM, atol=1e-9)
    np.testing.assert_allclose(fit.bias, [TARE_BIAS + drift, TARE_BIAS], atol=1e-9)
    np.testing.assert_allclose(fit.drift()[0], drift, atol=1e-9)
    assert fit.estimate.chi2 < 1e-12 and fit.estimate.dof == 6 * 11 - (12 + 4 + 4)


@pytest.mark.slow
def test_the_spread_is_the_crlb():
    """2000 runs: the relative standard error of a spread is 1.6 %, so 5 % is > 3 of them.
    The bias of this run is fitted, so a drift since the tare is absorbed (mean error
    within 4 standard errors)."""
    drift = np.array([0.25, 0.0, 0.0, 0.0, 0.0, 0.0])  # 0.05 N/min over 5 min
    truth = observations(drift)
    bound = np.sqrt(np.diag(kinematic_ml(truth).estimate.cov))
    rng = np.random.default_rng(3)
    runs = []
    for _ in range(2000):
        est = kinematic_ml(noisy(truth, rng)).estimate
        runs.append([est.mass, *est.com])
    np.testing.assert_allclose(np.std(runs, axis=0, ddof=1) / bound, 1.0, atol=0.05)
    error = np.mean(runs, axis=0) - [MASS, *COM]
    assert np.all(np.abs(error) < 4 * bound / math.sqrt(len(runs))), error / bound


def test_known_orientations_lower_the_bound_along_gravity():
    """Tare-subtracted windows (hand and bias known exactly): the COM along gravity is
    0.55-0.65x the wrench-only bound. Fitting the bias of each run from a 2 s window
    costs some of it back: the price of absorbing a drift."""
    gravities = np.array([seen_gravity(r) for r in ROTATIONS])
    cov = SAMPLE_COV / 900 + SAMPLE_COV / 5000
    loads = [
        Observation(window_from_mean(f"p{i}", gravity_wrench(MASS, COM, g), cov, 900), r)
        for i, (g, r) in enumerate(zip(gravities, ROTATIONS, strict=True))
    ]
    known = np.sqrt(np.diag(kinematic_ml(loads).estimate.cov))
    wrenches = np.sqrt(np.diag(crlb(MASS, COM, gravities / STANDARD_GRAVITY, [cov] * 5)))
    ratio = known[1:] / wrenches[1:]
    assert np.all(ratio < 0.65) and ratio[2] > 0.55, ratio
    refitted = np.sqrt(np.diag(kinematic_ml(observations()).estimate.cov))
    assert known[3] < refitted[3] < wrenches[3], (known, refitted, wrenches)


def test_one_orientation_does_not_resolve_the_com_along_gravity():
    one = [o for o in observations() if o.rotation is ROTATIONS[0] or o.epoch == 0]
    one = [o for o in one if np.allclose(o.rotation, HOME)]
    with pytest.raises(TooFewPosesError, match="do not resolve"):
        kinematic_ml(one)


def test_a_load_against_gravity_is_refused():
    obs = observations()
    flipped = [
        Observation(
            window_from_mean(
                o.window.pose,
                o.window.mean - 2 * gravity_wrench(MASS, COM, seen_gravity(o.rotation)),
                o.window.cov,
                o.window.n,
            ),
            o.rotation,
            o.load,
            o.epoch,
        )
        if o.load
        else o
        for o in obs
    ]
    with pytest.raises(NonPositiveMassError):
        kinematic_ml(flipped)


@pytest.mark.slow
def test_a_sensor_mounted_off_its_urdf_frame_and_a_tilted_base_are_fitted():
    """3 deg of roll between the URDF's sensor frame and the sensor, and a base tilted
    1 deg: ``kinematics`` misfits them by far; ``kinematics+mount`` finds both and stays
    unbiased, its spread its own bound. 300 runs: a spread's relative standard error is
    4.1 %, so 15 % is more than 3 of them."""
    mount, base = rotation_about("x", math.radians(3.0)), rotation_about("y", math.radians(1.0))
    truth = observations(mount=mount, base=base)
    rng = np.random.default_rng(11)
    first = noisy(truth, rng)
    assert kinematic_ml(first).estimate.p_value < 1e-6  # the misfit is plain
    fit = kinematic_ml(first, fit_mount=True)
    assert abs(math.degrees(mount_rpy(fit.mount)[0]) - 3.0) < 0.5
    tilt = np.degrees(fit.base_tilt)  # a rotation vector in the base frame
    assert np.abs(tilt - [0.0, 1.0, 0.0]).max() < 0.5, tilt
    runs = []
    for _ in range(300):
        f = kinematic_ml(noisy(truth, rng), fit_mount=True)
        runs.append([f.estimate.mass, *f.estimate.com, *f.mount])
    runs = np.array(runs)
    bound = np.sqrt(np.concatenate([np.diag(fit.estimate.cov), np.diag(fit.mount_cov)[:3]]))
    np.testing.assert_allclose(np.std(runs, axis=0) / bound, 1.0, atol=0.15)
    mean_error = runs[:, :4].mean(axis=0) - [MASS, *COM]
    assert np.all(np.abs(mean_error) < 4 * bound[:4] / math.sqrt(len(runs)))  # unbiased


def test_a_drift_within_the_run_is_absorbed_with_a_rate_prior():
    """0.05 N/min (and 0.0025 N m/min) all along, a 5-minute-old tare: with a constant
    bias per epoch the fit is flagged (chi-square); with a rate prior of that size it is
    consistent and within its sigma, and the rate is found. 400 runs."""
    rate = np.array([0.05, -0.05, 0.05, 0.0025, 0.0025, -0.0025]) / 60
    sigma = (0.05 / 60, 0.0025 / 60)
    truth = observations(rate=rate)
    rng = np.random.default_rng(5)
    assert kinematic_ml(noisy(truth, rng)).estimate.p_value < 1e-6
    fit = kinematic_ml(truth, drift_rate_sigma=sigma)
    bound = np.sqrt(np.diag(fit.estimate.cov))
    runs, p_values = [], []
    for _ in range(400):
        f = kinematic_ml(noisy(truth, rng), drift_rate_sigma=sigma)
        runs.append([f.estimate.mass, *f.estimate.com])
        p_values.append(f.estimate.p_value)
    assert np.mean(np.array(p_values) < 1e-3) < 0.02  # consistent: the test's false alarms
    # a rate at the prior's sigma is shrunk towards zero: a bias of a fraction of sigma,
    # so the root-mean-square error stays within the reported sigma
    error = np.array(runs) - [MASS, *COM]
    assert np.all(np.abs(error.mean(axis=0)) < 0.5 * bound), error.mean(axis=0) / bound
    np.testing.assert_allclose(np.sqrt(np.mean(error**2, axis=0)) / bound, 1.0, atol=0.15)
    assert np.all(np.abs(fit.bias_rate - rate) < np.abs(rate))  # found, if shrunk


def test_an_object_that_moved_at_one_window_is_located():
    """The object's COM moves 5 mm in the grasp from the third object window on: the fit
    fails its test, and of the alternatives "from window k on" at k = 2 fits best."""
    obs = observations()
    loads = [i for i, o in enumerate(obs) if o.load]
    moved = []
    for i, o in enumerate(obs):
        if i in loads[2:]:
            g = seen_gravity(o.rotation)
            shift = gravity_wrench(MASS, np.add(COM, [0.005, 0.0, 0.0]), g) - gravity_wrench(
                MASS, COM, g
            )
            o = replace(o, window=replace(o.window, mean=o.window.mean + shift))
        moved.append(o)
    rng = np.random.default_rng(21)
    noisy_moved = noisy(moved, rng)
    assert kinematic_ml(noisy_moved).estimate.p_value < 1e-6
    k, chi2 = locate_move(noisy_moved)
    assert k == 2 and chi2 < kinematic_ml(noisy_moved).estimate.chi2 / 10


@pytest.mark.slow
def test_the_wrench_at_an_unseen_pose_is_predicted_with_its_covariance():
    """A 20 deg tilt about the sensor's diagonal that no window saw, with the sensor
    mounted off its URDF frame, a tilted base and a bias free to drift (a rate prior):
    the prediction is exact without noise, and over 300 noisy runs its spread is its
    covariance (a standard deviation's relative standard error is 4.1 %: 15 % is over 3
    of them)."""
    mount, base = rotation_about("x", math.radians(3.0)), rotation_about("y", math.radians(1.0))
    sigma = (0.05 / 60, 0.0025 / 60)
    truth = observations(mount=mount, base=base)
    diagonal = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    unseen, when = HOME @ rotation_about(diagonal, math.radians(20.0)), 305.0
    g = seen_gravity(unseen, mount, base)
    expected = TARE_BIAS + gravity_wrench(HAND_MASS, HAND_COM, g) + gravity_wrench(MASS, COM, g)
    exact = kinematic_ml(truth, fit_mount=True, drift_rate_sigma=sigma)
    predicted, cov = exact.predict(unseen, when)
    np.testing.assert_allclose(predicted, expected, atol=1e-9)
    empty, _ = exact.predict(unseen, when, load=False)
    np.testing.assert_allclose(predicted - empty, gravity_wrench(MASS, COM, g), atol=1e-9)
    rng = np.random.default_rng(17)
    runs = [
        kinematic_ml(noisy(truth, rng), fit_mount=True, drift_rate_sigma=sigma).predict(
            unseen, when
        )[0]
        for _ in range(300)
    ]
    np.testing.assert_allclose(np.std(runs, axis=0) / np.sqrt(np.diag(cov)), 1.0, atol=0.15)


def test_the_latest_bias_carries_the_fitted_rate_to_the_runs_last_window():
    """With a drift within the run and a rate prior, the bias at the run's last window is
    the epoch's bias moved along the fitted rate: nearer the truth there than the bias at
    the epoch's mean time (noise-free; the prior shrinks the rate a little)."""
    rate = np.array([0.05, -0.05, 0.05, 0.0025, 0.0025, -0.0025]) / 60
    fit = kinematic_ml(observations(rate=rate), drift_rate_sigma=(0.05 / 60, 0.0025 / 60))
    last = max(o.time for o in observations() if o.epoch == 0)
    truth = TARE_BIAS + rate * last
    assert np.all(np.abs(fit.latest_bias() - truth) < 0.5 * np.abs(fit.bias[0] - truth))


def test_a_nuisance_every_window_shares_is_marginalised_not_left_to_pull_the_load():
    """Each load window's mean also holds N_i nu, unknowns nu no fit solves for (a load's
    inertia): marginalised under a wide prior, the load comes out as without them (to 1e-9
    of the mass, 1 nm), and its covariance holds their share; left out, they pull the COM
    off by more than 10 sigma."""
    rng = np.random.default_rng(7)
    nu = np.array([0.3, -0.2])
    shifted, marked = [], []
    for o in observations():
        design = rng.normal(size=(6, 2)) * 0.01 if o.load else np.zeros((6, 2))
        window = replace(o.window, mean=o.window.mean + design @ nu)
        shifted.append(replace(o, window=window))
        marked.append(replace(o, window=window, nuisance=design))
    clean = kinematic_ml(observations(), BASE_GRAVITY)
    left_out = kinematic_ml(shifted, BASE_GRAVITY).estimate
    e = kinematic_ml(marked, BASE_GRAVITY, nuisance_cov=1e4 * np.eye(2)).estimate
    assert e.mass == pytest.approx(MASS, abs=1e-9 * MASS)  # the prior's pull: 1 / its width
    np.testing.assert_allclose(e.com, COM, atol=1e-9)
    assert np.all(np.abs(left_out.com - COM) > 10 * left_out.sigma_com)
    assert (
        np.all(e.sigma_com > clean.estimate.sigma_com) and e.sigma_mass > clean.estimate.sigma_mass
    )
