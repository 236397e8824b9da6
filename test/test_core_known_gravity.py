"""com_core.known_gravity: the fit with each pose's gravity known (from kinematics) is
exact without noise, reaches its Cramer-Rao bound, and beats the wrench-only bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from com_core.errors import NonPositiveMassError, TooFewPosesError
from com_core.estimators import crlb
from com_core.known_gravity import known_gravity_crlb, known_gravity_ml
from com_core.planner import Plan
from com_core.windows import window_from_mean
from com_core.wrench_model import STANDARD_GRAVITY, SensorModel, gravity_wrench

MASS, COM = 0.1, (0.01, -0.02, 0.1)
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
GRAVITIES = PLAN.gravity_directions() * STANDARD_GRAVITY
COV = PLAN.window_cov()


def windows(means) -> list:
    return [window_from_mean(f"pose{i}", m, COV, 900) for i, m in enumerate(means)]


def test_exact_without_noise():
    est = known_gravity_ml(windows(gravity_wrench(MASS, COM, GRAVITIES)), GRAVITIES)
    assert est.mass == pytest.approx(MASS, rel=1e-12)
    np.testing.assert_allclose(est.com, COM, atol=1e-12)
    assert est.chi2 < 1e-12 and est.dof == 6 * 5 - 4


def test_the_spread_is_the_crlb_and_below_the_wrench_only_bound():
    """2000 runs: the relative standard error of a spread is 1.6 %, so 5 % is > 3 of them."""
    bound = np.sqrt(np.diag(known_gravity_crlb(MASS, COM, GRAVITIES, [COV] * 5)))
    rng = np.random.default_rng(3)
    chol = np.linalg.cholesky(COV)
    truth = gravity_wrench(MASS, COM, GRAVITIES)
    runs = []
    for _ in range(2000):
        noisy = truth + (chol @ rng.standard_normal((6, 5))).T
        est = known_gravity_ml(windows(noisy), GRAVITIES)
        runs.append([est.mass, *est.com])
    np.testing.assert_allclose(np.std(runs, axis=0, ddof=1) / bound, 1.0, atol=0.05)
    np.testing.assert_allclose(np.sqrt(np.diag(est.cov)) / bound, 1.0, atol=0.01)
    # what the joint angles add: the COM along gravity 0.63x the wrench-only bound
    wrenches_only = np.sqrt(np.diag(crlb(MASS, COM, GRAVITIES, np.repeat(COV[None], 5, 0))))
    ratio = bound[1:] / wrenches_only[1:]
    assert np.all(ratio < 0.65) and ratio[2] > 0.55, ratio


def test_one_gravity_direction_does_not_resolve_the_com_along_it():
    with pytest.raises(TooFewPosesError, match="along them"):
        known_gravity_ml(windows(gravity_wrench(MASS, COM, GRAVITIES[:1])), GRAVITIES[:1])
    with pytest.raises(TooFewPosesError, match="one gravity per window"):
        known_gravity_ml(windows(gravity_wrench(MASS, COM, GRAVITIES)), GRAVITIES[:2])


def test_a_load_against_gravity_is_refused():
    with pytest.raises(NonPositiveMassError):
        known_gravity_ml(windows(gravity_wrench(-MASS, COM, GRAVITIES)), GRAVITIES)


def test_a_sensor_mounted_off_its_urdf_frame_is_fitted_with_its_mounting():
    """3 deg of roll between the URDF's sensor frame (where the gravities are known) and
    the sensor: ``kinematics`` misfits it by far; ``kinematics+mount`` finds the mounting
    and stays unbiased, its spread its own bound. 600 runs: a spread's relative standard
    error is 2.9 %, so 10 % is more than 3 of them."""
    from com_core.known_gravity import mount_rpy, mounted_ml
    from com_core.wrench_model import rotation_about

    roll = math.radians(3.0)
    seen = (rotation_about("x", roll).T @ GRAVITIES.T).T  # gravity in the mounted sensor
    truth = gravity_wrench(MASS, COM, seen)
    rng = np.random.default_rng(11)
    chol = np.linalg.cholesky(COV)
    runs, first = [], None
    for _ in range(600):
        ws = windows(truth + (chol @ rng.standard_normal((6, 5))).T)
        fit = mounted_ml(ws, GRAVITIES)
        first = first or (fit, known_gravity_ml(ws, GRAVITIES))
        runs.append([fit.estimate.mass, *fit.estimate.com, *mount_rpy(fit.mount)])
    runs = np.array(runs)
    fit, kinematics_only = first
    assert kinematics_only.p_value < 1e-6  # the misfit is plain without the mounting
    bound = np.sqrt(np.concatenate([np.diag(fit.estimate.cov), np.diag(fit.mount_cov)]))
    np.testing.assert_allclose(np.std(runs, axis=0) / bound, 1.0, atol=0.10)
    mean_error = runs.mean(axis=0) - [MASS, *COM, roll, 0.0, 0.0]
    assert np.all(np.abs(mean_error) < 4 * bound / math.sqrt(len(runs)))  # unbiased
    assert abs(math.degrees(mount_rpy(fit.mount)[0]) - 3.0) < 0.5
