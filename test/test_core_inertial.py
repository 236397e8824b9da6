"""com_core.estimation.fits.inertial: the 10 inertial parameters from wrenches in motion, exact
without noise, within their covariance with it, physically consistent always (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PANDA

from com_core.estimation.fits.inertial import fit_inertial, log_cholesky, pseudo_inertia
from com_core.robot.config import urdf_file
from com_core.robot.dynamics import inertial_parameters, load_of, sensor_regressor
from com_core.robot.model import RobotModel

LOAD = inertial_parameters(  # a real body's: the inertia's triangle inequalities hold
    0.5, [0.01, -0.02, 0.1], [[2e-3, 1e-4, 0.0], [1e-4, 2.5e-3, -2e-4], [0.0, -2e-4, 1.5e-3]]
)
SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # N, N m per sample


@pytest.fixture(scope="module")
def regressors() -> np.ndarray:
    """(n, 6, 10): a 2 s swing of the Panda's wrist (three joints, incommensurate
    frequencies) sampled at 100 Hz."""
    robot = RobotModel(urdf_file(PANDA).read_text(), PANDA.sensor_frame)
    n = len(robot.joint_names)  # the arm's, then the fingers' (held still)
    home = np.zeros(n)
    home[:7] = PANDA.home_joints
    t = np.arange(0.0, 2.0, 0.01)[:, None]
    omega, amplitude = np.zeros(n), np.zeros(n)
    omega[4:7] = 2 * np.pi * np.array([0.7, 1.1, 1.3])
    amplitude[4:7] = [0.5, 0.5, 0.8]
    q = home + amplitude * np.sin(omega * t)
    dq = amplitude * omega * np.cos(omega * t)
    ddq = -amplitude * omega**2 * np.sin(omega * t)
    return np.array([sensor_regressor(robot, *x) for x in zip(q, dq, ddq, strict=True)])


def test_log_cholesky_parameters_give_the_load_back():
    import pinocchio

    theta = log_cholesky(LOAD)
    np.testing.assert_allclose(
        pinocchio.LogCholeskyParameters(theta).toDynamicParameters(), LOAD, atol=1e-15
    )
    assert np.linalg.eigvalsh(pseudo_inertia(LOAD)).min() > 0


def test_without_noise_the_fit_is_the_load(regressors):
    fit = fit_inertial(regressors, regressors @ LOAD, SIGMA)
    np.testing.assert_allclose(fit.pi, LOAD, rtol=1e-9, atol=1e-12)
    assert not fit.constrained and fit.chi2 < 1e-12 and fit.dof == 6 * len(regressors) - 10


def test_with_noise_the_error_is_within_the_covariance(regressors):
    """200 noisy repetitions: the errors' covariance is the fit's, each parameter's
    standardised error has unit variance (chi-square, 199 dof, 0.1 % each side)."""
    rng = np.random.default_rng(4)
    truth = regressors @ LOAD
    fits = [fit_inertial(regressors, truth + rng.normal(0, SIGMA, truth.shape), SIGMA)
            for _ in range(200)]  # fmt: skip
    errors = np.array([f.pi - LOAD for f in fits])
    z = errors / np.sqrt(np.diag(fits[0].cov))
    assert np.all((z.var(axis=0) > 0.73) & (z.var(axis=0) < 1.31)), z.var(axis=0)
    chi2 = np.array([f.chi2 / f.dof for f in fits])
    assert abs(chi2.mean() - 1) < 0.01


def test_a_fit_with_little_data_is_kept_physically_consistent(regressors):
    """A few samples of a light load and heavy noise: the least squares inertia is no
    real body's; the fit is the consistent load nearest the data."""
    light = inertial_parameters(0.05, [0.0, 0.0, 0.05], np.diag([1e-6, 1e-6, 1e-7]))
    rng = np.random.default_rng(7)
    some = regressors[::20]
    noisy = some @ light + rng.normal(0, 3 * SIGMA, (len(some), 6))
    fit = fit_inertial(some, noisy, 3 * SIGMA)
    assert fit.constrained
    assert np.linalg.eigvalsh(pseudo_inertia(fit.pi)).min() > 0
    mass, _, inertia = load_of(fit.pi)
    assert mass > 0 and np.linalg.eigvalsh(inertia).min() >= 0


def test_a_motion_that_excites_too_little_is_refused(regressors):
    still = np.repeat(regressors[:1], 50, axis=0)
    with pytest.raises(ValueError, match=r"excites .* of the 10"):
        fit_inertial(still, still @ LOAD, SIGMA)
