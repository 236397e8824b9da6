"""Mass and COM when each pose's gravity in the sensor frame is known (the ``kinematics``
information model: gravity from the robot's forward kinematics, ``com_core.kinematics``).

With g_i known (m/s^2, sensor frame), a static load's wrench is linear in the unknowns
theta = (m, c) with c = m p (kg m):

    f_i   = m g_i
    tau_i = p x (m g_i) = c x g_i = -[g_i]_x c

so the maximum-likelihood fit under Gaussian window noise (covariance S_i of each window
mean, N and N m) is weighted least squares, theta = (sum A_i^T S_i^-1 A_i)^-1 sum A_i^T
S_i^-1 w_i, and its covariance (sum A_i^T S_i^-1 A_i)^-1 is exactly the Cramer-Rao bound
for this information. (m, p = c / m) and their covariance follow to first order. The
wrench-only ``estimators.ml`` treats each g_i direction as unknown; knowing it adds
information, most about the COM along gravity (docs/design.md, Estimators).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import NonPositiveMassError, TooFewPosesError
from .estimators import Estimate
from .stats import chi2_sf
from .windows import Window
from .wrench_model import rotation_about, skew

__all__ = [
    "MountedEstimate",
    "known_gravity_crlb",
    "known_gravity_ml",
    "mount_rpy",
    "mounted_ml",
]

METHOD = "ml"  # the maximum-likelihood fit of the kinematics information


def _design(gravity: NDArray[np.float64]) -> NDArray[np.float64]:
    """A_i (6, 4): the wrench of theta = (m, c) at gravity g_i (m/s^2)."""
    a = np.zeros((6, 4))
    a[:3, 0] = gravity
    a[3:, 1:] = -skew(gravity)
    return a


def _information(
    gravities: NDArray[np.float64], covs: Sequence[NDArray[np.float64]]
) -> tuple[NDArray[np.float64], list[NDArray[np.float64]]]:
    """(sum A^T S^-1 A (4, 4), the A_i^T S_i^-1 (4, 6) per pose)."""
    info = np.zeros((4, 4))
    weighted = []
    for g, cov in zip(gravities, covs, strict=True):
        a = _design(g)
        at_w = np.linalg.solve(cov, a).T  # A^T S^-1 (S symmetric)
        info += at_w @ a
        weighted.append(at_w)
    return info, weighted


def _mass_com_covariance(
    theta: NDArray[np.float64], cov_theta: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Covariance (4, 4) of (m, p = c / m) from that of theta = (m, c), first order."""
    m, c = theta[0], theta[1:]
    jac = np.zeros((4, 4))
    jac[0, 0] = 1.0
    jac[1:, 0] = -c / m**2
    jac[1:, 1:] = np.eye(3) / m
    return jac @ cov_theta @ jac.T


def known_gravity_ml(windows: Sequence[Window], gravities: ArrayLike) -> Estimate:
    """The ML mass (kg) and COM (m, sensor frame) of tare-subtracted ``windows`` whose
    gravity vectors ``gravities`` (n, 3), m/s^2 in the sensor frame, are known; its
    covariance is the CRLB; chi2 has 6n - 4 degrees of freedom.

    Raises TooFewPosesError for no window, NonPositiveMassError for a mass at or below
    zero. One pose suffices for m and the COM across gravity; the component along
    gravity needs a second gravity direction (else the information is singular:
    TooFewPosesError).
    """
    g = np.asarray(gravities, dtype=np.float64).reshape(-1, 3)
    if len(windows) == 0 or len(windows) != len(g):
        raise TooFewPosesError(f"need one gravity per window: {len(windows)} windows, {len(g)}")
    info, weighted = _information(g, [w.cov for w in windows])
    if np.linalg.cond(info) > 1e12:
        raise TooFewPosesError("the poses' gravity directions do not resolve the COM along them")
    cov_theta = np.linalg.inv(info)
    theta = cov_theta @ sum(at_w @ w.mean for at_w, w in zip(weighted, windows, strict=True))
    if not theta[0] > 0:
        raise NonPositiveMassError(f"mass {theta[0] * 1e3:.3g} g: at or below zero")
    residuals = [w.mean - _design(gi) @ theta for w, gi in zip(windows, g, strict=True)]
    chi2 = float(
        sum(r @ np.linalg.solve(w.cov, r) for r, w in zip(residuals, windows, strict=True))
    )
    dof = 6 * len(windows) - 4
    return Estimate(
        method=METHOD,
        mass=float(theta[0]),
        com=theta[1:] / theta[0],
        cov=_mass_com_covariance(theta, cov_theta),
        chi2=chi2,
        dof=dof,
        p_value=chi2_sf(chi2, dof) if dof > 0 else 1.0,
        poses=tuple(w.pose for w in windows),
    )


def known_gravity_crlb(
    mass: float,
    com: ArrayLike,
    gravities: ArrayLike,
    covs: Sequence[NDArray[np.float64]],
) -> NDArray[np.float64]:
    """The Cramer-Rao bound (4, 4) of (m, p) at the truth (kg, m; sensor frame) when the
    gravities (n, 3, m/s^2) are known and the windows have covariances ``covs``."""
    g = np.asarray(gravities, dtype=np.float64).reshape(-1, 3)
    info, _ = _information(g, covs)
    theta = np.concatenate([[mass], mass * np.asarray(com, dtype=np.float64)])
    return _mass_com_covariance(theta, np.linalg.inv(info))


def _rotation(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix (3, 3) of a rotation vector (axis x angle, rad)."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.eye(3) + skew(rotvec)
    return rotation_about(rotvec / angle, angle)


def mount_rpy(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Roll, pitch, yaw (rad; fixed axes x, y, z) of a mounting rotation vector."""
    r = _rotation(np.asarray(rotvec, dtype=np.float64))
    return np.array(
        [
            math.atan2(r[2, 1], r[2, 2]),
            -math.asin(max(-1.0, min(1.0, r[2, 0]))),
            math.atan2(r[1, 0], r[0, 0]),
        ]
    )


@dataclass(frozen=True)
class MountedEstimate:
    """The ``kinematics+mount`` fit: the estimate (in the sensor's own frame) and the
    sensor's mounting relative to its URDF frame: ``mount`` a rotation vector (3,), rad
    (the sensor's axes in the URDF frame are R(mount)), with its covariance (3, 3)."""

    estimate: Estimate
    mount: NDArray[np.float64]
    mount_cov: NDArray[np.float64]


def mounted_ml(
    windows: Sequence[Window], gravities: ArrayLike, iterations: int = 20
) -> MountedEstimate:
    """ML of (m, p) and of a constant mounting rotation R between the URDF's sensor frame
    (where ``gravities``, (n, 3) m/s^2, are known) and the sensor: the windows see
    gravity R^T g_i. Gauss-Newton from the known-gravity fit; the covariance of all 7
    unknowns is the inverse Fisher information (its CRLB); chi2 has 6n - 7 dof. Needs
    two gravity directions at least (the mounting about gravity is seen only by them).
    """
    g = np.asarray(gravities, dtype=np.float64).reshape(-1, 3)
    start = known_gravity_ml(windows, g)
    x = np.concatenate([[start.mass], start.mass * start.com, np.zeros(3)])
    whiten = [np.linalg.cholesky(np.linalg.inv(w.cov)).T for w in windows]
    means = [w.mean for w in windows]

    def residuals(params: NDArray[np.float64]) -> NDArray[np.float64]:
        r_t = _rotation(params[4:]).T
        return np.concatenate(
            [
                wh @ (m - _design(r_t @ gi) @ params[:4])
                for wh, m, gi in zip(whiten, means, g, strict=True)
            ]
        )

    def jacobian(params: NDArray[np.float64]) -> NDArray[np.float64]:
        base = residuals(params)
        cols = []
        for k in range(7):
            step = np.zeros(7)
            step[k] = 1e-7 * max(1.0, abs(params[k]))
            cols.append((residuals(params + step) - base) / step[k])
        return np.stack(cols, axis=1)

    for _ in range(iterations):
        jac, res = jacobian(x), residuals(x)
        delta = np.linalg.lstsq(jac, -res, rcond=None)[0]
        x = x + delta
        if np.max(np.abs(delta[4:])) < 1e-12 and np.max(np.abs(delta[:4])) < 1e-12 * max(
            1.0, x[0]
        ):
            break
    jac, res = jacobian(x), residuals(x)
    info = jac.T @ jac
    if np.linalg.cond(info) > 1e12:
        raise TooFewPosesError("the poses' gravity directions do not resolve the mounting")
    cov = np.linalg.inv(info)
    if not x[0] > 0:
        raise NonPositiveMassError(f"mass {x[0] * 1e3:.3g} g: at or below zero")
    chi2, dof = float(res @ res), 6 * len(windows) - 7
    estimate = Estimate(
        method=METHOD,
        mass=float(x[0]),
        com=x[1:4] / x[0],
        cov=_mass_com_covariance(x[:4], cov[:4, :4]),
        chi2=chi2,
        dof=dof,
        p_value=chi2_sf(chi2, dof) if dof > 0 else 1.0,
        poses=tuple(w.pose for w in windows),
    )
    return MountedEstimate(estimate, x[4:].copy(), cov[4:, 4:])
