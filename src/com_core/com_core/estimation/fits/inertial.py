"""The 10 inertial parameters of a load from wrenches in motion, physically consistent.

Each sample k gives w_k = Y_k pi + e_k (``com_core.robot.dynamics.sensor_regressor``;
pi: m, m c, the inertia about the sensor origin, pinocchio's order). The weighted least
squares estimate minimises sum_k e_k^T W e_k with W the inverse of the sensor's noise
covariance per sample. A load is physically consistent when its pseudo-inertia

    J(pi) = [[Sigma, m c], [m c^T, m]],  Sigma = tr(I)/2 1 - I   (second moment of mass)

is positive definite (Wensing, Kim and Slotine 2017): a positive mass whose inertia a
real distribution of mass could have (the triangle inequalities included). When the
least squares estimate is not (too little excitation, too much noise), the fit runs
Gauss-Newton in log-Cholesky parameters theta (Rucker and Wensing 2022; pinocchio's
``LogCholeskyParameters``: J = U U^T with U upper triangular of positive diagonal, so
every theta is a consistent load), from the estimate's pseudo-inertia with its eigenvalues
raised to a floor. The covariance is the weighted least squares' (the Cramer-Rao bound of
the linear model under this noise), at the solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["InertialFit", "fit_inertial", "fit_whitened", "log_cholesky", "pseudo_inertia"]

_FLOOR = 1e-9
"""The smallest eigenvalue (kg, kg m^2) a projected pseudo-inertia starts from."""


def pseudo_inertia(pi: ArrayLike) -> NDArray[np.float64]:
    """J (4, 4) of the parameters ``pi`` (10,): [[Sigma, h], [h^T, m]]."""
    p = np.asarray(pi, dtype=np.float64).reshape(10)
    ixx, ixy, iyy, ixz, iyz, izz = p[4:]
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    out = np.zeros((4, 4))
    out[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    out[:3, 3] = out[3, :3] = p[1:4]
    out[3, 3] = p[0]
    return out


def log_cholesky(pi: ArrayLike) -> NDArray[np.float64]:
    """theta (10,), pinocchio's log-Cholesky parameters (alpha, d1, d2, d3, s12, s23, s13,
    t1, t2, t3) of a consistent ``pi`` (LinAlgError when J(pi) is not positive definite):
    J = U U^T with U = e^alpha [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3],
    [0, 0, 0, 1]]."""
    flip = np.eye(4)[::-1]
    upper = flip @ np.linalg.cholesky(flip @ pseudo_inertia(pi) @ flip) @ flip
    alpha = np.log(upper[3, 3])
    scale = np.exp(alpha)
    d = np.log(np.diag(upper)[:3]) - alpha
    s = np.array([upper[0, 1], upper[1, 2], upper[0, 2]]) / scale
    return np.concatenate([[alpha], d, s, upper[:3, 3] / scale])


@dataclass(frozen=True)
class InertialFit:
    """A load's parameters from motion.

    pi : (10,), m (kg), m c (kg m), inertia about the sensor origin (kg m^2), sensor frame.
    cov : (10, 10), their covariance (the weighted least squares' at ``pi``).
    chi2 : the weighted sum of squared residuals, ``dof`` = 6 n - 10 degrees of freedom.
    constrained : the least squares estimate was not consistent, and ``pi`` is the
        consistent load closest to the data (log-Cholesky Gauss-Newton).
    least_squares : (10,) the weighted least squares estimate (``pi`` unless constrained).
    """

    pi: NDArray[np.float64]
    cov: NDArray[np.float64]
    chi2: float
    dof: int
    constrained: bool
    least_squares: NDArray[np.float64]


def fit_inertial(
    regressors: ArrayLike, wrenches: ArrayLike, sigma: ArrayLike, iterations: int = 50
) -> InertialFit:
    """The load's parameters from ``regressors`` (n, 6, 10) and ``wrenches`` (n, 6; N, N m,
    the load's part: the tare and the bias taken off) with independent noise ``sigma``
    (6,) per sample and axis; physically consistent (see module). ValueError for fewer
    than 2 samples or a regressor of rank < 10 (a motion that does not excite every
    parameter)."""
    Y = np.asarray(regressors, dtype=np.float64)
    w = np.asarray(wrenches, dtype=np.float64)
    n = Y.shape[0]
    if n < 2 or Y.shape[1:] != (6, 10) or w.shape != (n, 6):
        raise ValueError(f"need (n, 6, 10) regressors and (n, 6) wrenches, n >= 2; got {Y.shape}")
    scale = 1.0 / np.asarray(sigma, dtype=np.float64).reshape(1, 6, 1)
    return fit_whitened((Y * scale).reshape(-1, 10), (w * scale[..., 0]).reshape(-1), iterations)


def fit_whitened(A: ArrayLike, b: ArrayLike, iterations: int = 50) -> InertialFit:
    """``fit_inertial`` of the whitened system A pi = b + e, e white of unit variance
    (A (rows, 10), b (rows,)): the rows already divided by their noise, or passed through
    its whitening filter (``estimation.fits.motion``)."""
    A, b = np.asarray(A, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rank = np.linalg.matrix_rank(A)
    if rank < 10:
        raise ValueError(f"the motion excites {rank} of the 10 inertial parameters")
    least_squares, *_ = np.linalg.lstsq(A, b, rcond=None)
    constrained = not _consistent(least_squares)
    pi = _consistent_fit(A, b, least_squares, iterations) if constrained else least_squares
    cov = np.linalg.inv(A.T @ A)
    residual = b - A @ pi
    return InertialFit(pi, cov, float(residual @ residual), A.shape[0] - 10, constrained,
                       least_squares)  # fmt: skip


def _consistent(pi: NDArray[np.float64]) -> bool:
    return bool(np.linalg.eigvalsh(pseudo_inertia(pi)).min() > 0)


def _consistent_fit(
    A: NDArray[np.float64], b: NDArray[np.float64], start: NDArray[np.float64], iterations: int
) -> NDArray[np.float64]:
    """The consistent pi nearest the data: Gauss-Newton (Levenberg's damping) on
    ||A pi(theta) - b||^2 over log-Cholesky theta, from ``start``'s pseudo-inertia with
    its eigenvalues raised to ``_FLOOR``."""
    import pinocchio

    values, vectors = np.linalg.eigh(pseudo_inertia(start))
    raised = vectors @ np.diag(np.maximum(values, _FLOOR * max(values.max(), 1.0))) @ vectors.T
    theta = log_cholesky(pinocchio.PseudoInertia.FromMatrix(raised).toDynamicParameters())
    cost, damping = np.inf, 1e-3
    for _ in range(iterations):
        params = pinocchio.LogCholeskyParameters(theta)
        pi = np.asarray(params.toDynamicParameters())
        residual = A @ pi - b
        cost = residual @ residual
        jac = A @ np.asarray(params.calculateJacobian())
        step = np.linalg.solve(jac.T @ jac + damping * np.eye(10), -jac.T @ residual)
        trial = theta + step
        trial_pi = np.asarray(pinocchio.LogCholeskyParameters(trial).toDynamicParameters())
        if not np.all(np.isfinite(trial_pi)):  # a step too long for the exponentials
            damping *= 10.0
            continue
        with np.errstate(over="ignore", invalid="ignore"):  # a step so long it overflows:
            trial_residual = A @ trial_pi - b  # not taken
            trial_cost = trial_residual @ trial_residual
        if trial_cost < cost:
            theta, damping = trial, damping * 0.3
            if cost - trial_cost < 1e-12 * max(cost, 1.0):
                break
        else:
            damping *= 10.0
    return np.asarray(pinocchio.LogCholeskyParameters(theta).toDynamicParameters())
