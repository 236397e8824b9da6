"""Mass and centre of mass from tare-subtracted static windows.

Two estimators run on the same windows (each a mean wrench of the object alone, with
the covariance of that mean; N, N m; sensor frame):

``two_pose``
    The paper's method on the first two windows: mass from the force (eq. 3), the COM
    component perpendicular to gravity from the first torque (eqs. 7, 8), the
    component along the first gravity direction from the second torque (eq. 11).
    Written for any orientation: for the paper's top grasp (force along -z) it is
    exactly eqs. 3, 7, 8, 11 under one convention, tau = p x f.

    The paper mixes two conventions: eqs. 4-8 follow tau = f x p (eq. 4 reads
    tau = -P^X R f), eq. 9 states tau = f x P, but eq. 10 expands P x f, and eq. 11
    as printed, P_z = (tau_x - f_z P_y) / f_r, has the sign of neither (from eq. 10,
    P_z = (f_z P_y - tau_x) / f_y). Here everything follows tau = p x f (docs/estimation.md),
    so eqs. 7, 8 read p_x = tau_y / (m g), p_y = -tau_x / (m g).

``ml``
    Maximum likelihood over any number n >= 2 of poses. Information used: the
    wrenches only. The gravity direction d_i of each pose is a nuisance parameter (2
    per pose); the robot's kinematics are not needed, so a mis-calibrated arm or an
    unknown sensor mounting cannot bias the result. Parameters: m, p (3), d_1..d_n;
    model w_i = [m g d_i ; m g p x d_i]; residuals weighted by each window's inverse
    covariance; Gauss-Newton from the closed-form start. Its covariance is the inverse
    Fisher information at the estimate; ``crlb`` is the same matrix at the truth, the
    Cramer-Rao bound for exactly this information. Residual chi-square has
    6n - (4 + 2n) = 4n - 4 degrees of freedom.

``check_consistency`` tests that one (m, p) explains every pose (the chi-square
above) and, when not, names the pose at which the object moved in the grasp (the
paper's reconfiguration).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.errors import (
    IllConditionedError,
    NonPositiveMassError,
    TooFewPosesError,
)
from com_core.estimation.fits.stats import chi2_sf
from com_core.estimation.fits.windows import Window
from com_core.sensing.wrench_model import STANDARD_GRAVITY

__all__ = [
    "DEFAULT_ALPHA",
    "MIN_TILT_SIGMAS",
    "Consistency",
    "Estimate",
    "check_consistency",
    "check_windows",
    "crlb",
    "ml",
    "two_pose",
]

DEFAULT_ALPHA = 1e-3
"""False-alarm rate of the consistency test (clean data flagged this often)."""

MIN_TILT_SIGMAS = 3.0
"""Gravity directions must differ by this many standard deviations of their angle."""

_COV_FLOOR = 1e-14
"""Variance (N^2, (N m)^2) added to every window's diagonal so noise-free data stays
finite; far below any real sensor's noise (1e-7 N standard deviation)."""

_MAX_ITERATIONS = 60
_CONVERGED_DECREMENT = 1e-10
"""Gauss-Newton stops after a step shorter than 1e-5 standard deviations."""


@dataclass(frozen=True)
class Estimate:
    """Mass and COM with their covariance.

    Attributes
    ----------
    method : 'ml' or 'two_pose'.
    mass : kg.
    com : shape (3,); m; sensor frame.
    cov : shape (4, 4); covariance of (mass, com_x, com_y, com_z); kg, m.
    chi2, dof, p_value : residual chi-square of one (m, p) fitted to all poses.
    poses : names of the poses used.
    """

    method: str
    mass: float
    com: NDArray[np.float64]
    cov: NDArray[np.float64]
    chi2: float
    dof: int
    p_value: float
    poses: tuple[str, ...]
    iterations: int = 0

    @property
    def sigma_mass(self) -> float:
        """kg."""
        return float(math.sqrt(self.cov[0, 0]))

    @property
    def sigma_com(self) -> NDArray[np.float64]:
        """shape (3,); m."""
        return np.sqrt(np.diag(self.cov)[1:])


@dataclass(frozen=True)
class Consistency:
    """Whether one rigid object explains all poses.

    ``suspect_pose`` names the first pose that no longer fits (the object moved there
    or just before), or None when consistent or when two poses cannot tell which.
    """

    consistent: bool
    chi2: float
    dof: int
    p_value: float
    alpha: float
    suspect_pose: str | None = None
    message: str = field(default="")


# --- the paper's two-pose method -----------------------------------------------------


def two_pose(
    windows: Sequence[Window],
    g: float = STANDARD_GRAVITY,
    min_tilt_sigmas: float = MIN_TILT_SIGMAS,
) -> Estimate:
    """The paper's eqs. 3, 7, 8, 11 on the first two windows, for any orientation.

    With u = f1 / |f1| the first gravity direction:
    - m = |f1| / g                                    (eq. 3; -f_z / g for a top grasp)
    - p_perp = f1 x tau1 / |f1|^2                      (eqs. 7, 8)
    - s = a . (tau2 - p_perp x f2) / |a|^2, a = u x f2  (eq. 11), p = p_perp + s u
    The covariance is propagated to first order from the two windows' covariances.
    The method fits no residual (chi2 and p_value are NaN, dof 0); ``check_consistency``
    tests the same windows.

    Raises TooFewPosesError, NonPositiveMassError, IllConditionedError.
    """
    if len(windows) < 2:
        raise TooFewPosesError(f"two_pose needs 2 poses, got {len(windows)}")
    pair = list(windows[:2])
    check_windows(pair, min_tilt_sigmas)
    x0 = np.concatenate([pair[0].mean, pair[1].mean])
    theta = _two_pose_closed_form(x0, g)
    jac = _numeric_jacobian(lambda x: _two_pose_closed_form(x, g), x0)
    cov_x = np.zeros((12, 12))
    cov_x[:6, :6], cov_x[6:, 6:] = pair[0].cov, pair[1].cov
    return Estimate(
        method="two_pose",
        mass=float(theta[0]),
        com=theta[1:].copy(),
        cov=jac @ cov_x @ jac.T,
        chi2=math.nan,
        dof=0,
        p_value=math.nan,
        poses=tuple(w.pose for w in pair),
    )


def _two_pose_closed_form(x: NDArray[np.float64], g: float) -> NDArray[np.float64]:
    """(m, p) from the stacked means (f1, tau1, f2, tau2), shape (12,)."""
    f1, t1, f2, t2 = x[0:3], x[3:6], x[6:9], x[9:12]
    f1_sq = float(f1 @ f1)
    u = f1 / math.sqrt(f1_sq)
    p_perp = _cross(f1, t1) / f1_sq
    a = _cross(u, f2)
    s = float(a @ (t2 - _cross(p_perp, f2))) / float(a @ a)
    return np.concatenate([[math.sqrt(f1_sq) / g], p_perp + s * u])


def _numeric_jacobian(fun, x0: NDArray[np.float64]) -> NDArray[np.float64]:
    """Central-difference Jacobian of ``fun`` at ``x0``."""
    y0 = fun(x0)
    jac = np.empty((y0.size, x0.size))
    for k in range(x0.size):
        h = 1e-6 * max(1.0, abs(x0[k]))
        dx = np.zeros_like(x0)
        dx[k] = h
        jac[:, k] = (fun(x0 + dx) - fun(x0 - dx)) / (2 * h)
    return jac


# --- maximum likelihood ----------------------------------------------------------------


def ml(
    windows: Sequence[Window],
    g: float = STANDARD_GRAVITY,
    min_tilt_sigmas: float = MIN_TILT_SIGMAS,
) -> Estimate:
    """Maximum-likelihood mass and COM from n >= 2 windows (wrenches only; see module).

    Raises TooFewPosesError, NonPositiveMassError, IllConditionedError.
    """
    check_windows(windows, min_tilt_sigmas)
    fit = _fit(windows, np.zeros(len(windows), dtype=int), g)
    info = fit.fisher()
    cov = _marginal_covariance(info, 4)
    chi2, dof = fit.chi2_dof()
    if not fit.mass > 0 or fit.mass < 3.0 * math.sqrt(cov[0, 0]):
        raise NonPositiveMassError(
            f"fitted mass {fit.mass:.4g} kg is not above zero by 3 sigma "
            f"({math.sqrt(cov[0, 0]):.2g} kg)"
        )
    return Estimate(
        method="ml",
        mass=fit.mass,
        com=fit.coms[0].copy(),
        cov=cov,
        chi2=chi2,
        dof=dof,
        p_value=chi2_sf(chi2, dof),
        poses=tuple(w.pose for w in windows),
        iterations=fit.iterations,
    )


def crlb(
    mass: float,
    com: ArrayLike,
    g_sensor: ArrayLike,
    covs: ArrayLike,
    g: float = STANDARD_GRAVITY,
) -> NDArray[np.float64]:
    """Cramer-Rao bound on (m, p) from windows with the given covariances.

    Parameters
    ----------
    mass : kg; com : shape (3,), m, sensor frame (the truth, or a guess for planning).
    g_sensor : shape (n, 3); gravity direction per pose in the sensor frame (normalised).
    covs : shape (n, 6, 6); covariance of each window's mean.

    Returns
    -------
    shape (4, 4): inverse Fisher information of the wrench-only model (``ml``'s
    information), marginalised over the n gravity directions; kg, m.
    """
    d = np.asarray(g_sensor, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    state = _FitState(
        mass=float(mass),
        coms=np.asarray(com, dtype=np.float64).reshape(1, 3),
        dirs=d,
        groups=np.zeros(len(d), dtype=int),
        whiteners=_whiteners(np.asarray(covs, dtype=np.float64)),
        means=np.zeros((len(d), 6)),
        g=g,
    )
    return _marginal_covariance(state.fisher(), 4)


def _marginal_covariance(info: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """First k x k block of the inverse of the Fisher information ``info``."""
    scale = np.sqrt(np.diag(info))
    if not np.all(scale > 0):
        raise IllConditionedError("the poses carry no information on some parameter")
    corr = info / np.outer(scale, scale)
    if np.linalg.cond(corr) > 1e12:
        raise IllConditionedError(
            "the poses do not determine mass and COM (gravity directions nearly parallel)"
        )
    cov = np.linalg.inv(corr) / np.outer(scale, scale)
    return cov[:k, :k]


@dataclass
class _FitState:
    """Parameters of the wrench-only model with one COM per group of poses."""

    mass: float
    coms: NDArray[np.float64]  # (G, 3)
    dirs: NDArray[np.float64]  # (n, 3) unit gravity directions
    groups: NDArray[np.int_]  # (n,) COM group of each pose
    whiteners: NDArray[np.float64]  # (n, 6, 6): U with U cov U^T = I
    means: NDArray[np.float64]  # (n, 6)
    g: float
    iterations: int = 0
    _evaluated: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    def residual_and_jacobian(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Whitened residuals (6n,) and Jacobian (6n, 1 + 3G + 2n) of the model.

        Computed once per state (a state is never changed; ``updated`` makes a new one).
        """
        if self._evaluated is None:
            self._evaluated = self._evaluate()
        return self._evaluated

    def _evaluate(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        n, n_groups = len(self.dirs), len(self.coms)
        d, p = self.dirs, self.coms[self.groups]
        mg = self.mass * self.g
        model = np.concatenate([mg * d, mg * _cross(p, d)], axis=1)
        basis = _tangent_bases(d)  # (n, 3, 2)
        jac = np.zeros((n, 6, 1 + 3 * n_groups + 2 * n))
        jac[:, :, 0] = self.g * np.concatenate([d, _cross(p, d)], axis=1)
        skew_d = _skew_batch(d)
        for i, grp in enumerate(self.groups):
            jac[i, 3:, 1 + 3 * grp : 4 + 3 * grp] = -mg * skew_d[i]
        col = 1 + 3 * n_groups + 2 * np.arange(n)
        jd = mg * np.concatenate([basis, _skew_batch(p) @ basis], axis=1)  # (n, 6, 2)
        jac[np.arange(n), :, col] = jd[:, :, 0]
        jac[np.arange(n), :, col + 1] = jd[:, :, 1]
        r = np.einsum("nij,nj->ni", self.whiteners, self.means - model)
        jw = np.einsum("nij,njk->nik", self.whiteners, jac)
        return r.reshape(-1), jw.reshape(6 * n, -1)

    def updated(self, step: NDArray[np.float64]) -> _FitState:
        n_groups = len(self.coms)
        delta = step[1 + 3 * n_groups :].reshape(-1, 2)
        dirs = self.dirs + np.einsum("nij,nj->ni", _tangent_bases(self.dirs), delta)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        return _FitState(
            mass=self.mass + float(step[0]),
            coms=self.coms + step[1 : 1 + 3 * n_groups].reshape(-1, 3),
            dirs=dirs,
            groups=self.groups,
            whiteners=self.whiteners,
            means=self.means,
            g=self.g,
            iterations=self.iterations + 1,
        )

    def chi2(self) -> float:
        r, _ = self.residual_and_jacobian()
        return float(r @ r)

    def chi2_dof(self) -> tuple[float, int]:
        n = len(self.dirs)
        return self.chi2(), 6 * n - (1 + 3 * len(self.coms) + 2 * n)

    def fisher(self) -> NDArray[np.float64]:
        _, jac = self.residual_and_jacobian()
        return jac.T @ jac


def _fit(windows: Sequence[Window], groups: NDArray[np.int_], g: float) -> _FitState:
    """Gauss-Newton (with step halving) for the wrench-only model; COM per group."""
    whiteners = _whiteners(np.array([w.cov for w in windows]))
    state = _initial_state(np.array([w.mean for w in windows]), whiteners, groups, g)
    r, jac = state.residual_and_jacobian()
    chi2 = float(r @ r)
    for _ in range(_MAX_ITERATIONS):
        step = np.linalg.lstsq(jac, r, rcond=None)[0]
        jac_step = jac @ step
        decrement = float(jac_step @ jac_step)  # squared step length in units of sigma
        for _halving in range(30):
            trial = state.updated(step)
            r_new, jac_new = trial.residual_and_jacobian()
            chi2_new = float(r_new @ r_new)
            if chi2_new <= chi2 * (1.0 + 1e-12) + 1e-300:
                break
            step = step / 2.0
        else:
            break
        state, r, jac, chi2 = trial, r_new, jac_new, chi2_new
        if decrement < _CONVERGED_DECREMENT:
            break
    return state


def _initial_state(
    means: NDArray[np.float64],
    whiteners: NDArray[np.float64],
    groups: NDArray[np.int_],
    g: float,
) -> _FitState:
    """Closed-form start: m from |f|, d from f / |f|, p per group by least squares."""
    f, tau = means[:, :3], means[:, 3:]
    norms = np.linalg.norm(f, axis=1)
    n_groups = int(groups.max()) + 1
    coms = np.zeros((n_groups, 3))
    for grp in range(n_groups):
        sel = groups == grp
        # tau = p x f = -skew(f) p, stacked over the group's poses
        a = -_skew_batch(f[sel]).reshape(-1, 3)
        coms[grp] = np.linalg.lstsq(a, tau[sel].reshape(-1), rcond=None)[0]
    return _FitState(
        mass=float(norms.mean() / g),
        coms=coms,
        dirs=f / norms[:, None],
        groups=groups,
        whiteners=whiteners,
        means=means,
        g=g,
    )


def _whiteners(covs: NDArray[np.float64]) -> NDArray[np.float64]:
    """U_i = L_i^-1 with L_i L_i^T = cov_i + floor, so U_i cov_i U_i^T = I."""
    lower = np.linalg.cholesky(covs + _COV_FLOOR * np.eye(6))
    return np.linalg.inv(lower)


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise cross product of (..., 3) arrays (numpy.cross is slow for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _skew_batch(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cross-product matrices of the rows of ``v`` (n, 3) -> (n, 3, 3)."""
    out = np.zeros((len(v), 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


def _tangent_bases(d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Orthonormal bases (n, 3, 2) of the planes perpendicular to the unit rows of d."""
    helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    e1 = _cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = _cross(d, e1)
    return np.stack([e1, e2], axis=2)


# --- checks shared by both estimators -----------------------------------------------


def check_windows(windows: Sequence[Window], min_tilt_sigmas: float = MIN_TILT_SIGMAS) -> None:
    """Raise if fewer than 2 poses, no load, or the gravity directions are not resolved.

    The largest angle between two poses' force directions must exceed both 1e-6 rad
    and ``min_tilt_sigmas`` times that angle's standard deviation (from the windows'
    force covariances): a smaller tilt cannot be told from noise.
    """
    if len(windows) < 2:
        raise TooFewPosesError(
            f"need at least 2 poses with different gravity directions, got {len(windows)}"
        )
    forces = np.array([w.force for w in windows])
    norms = np.linalg.norm(forces, axis=1)
    sd_perp = np.array([math.sqrt(max(np.trace(w.cov[:3, :3]), 0.0) / 3.0) for w in windows])
    weak = norms <= 3.0 * sd_perp
    if weak.any() or not np.all(norms > 0):
        i = int(np.argmax(weak | ~(norms > 0)))
        raise NonPositiveMassError(
            f"no load sensed in pose {windows[i].pose!r}: |f| = {norms[i]:.3g} N, noise "
            f"{sd_perp[i]:.2g} N; mass at or below zero (empty grasp or wrong tare)"
        )
    dirs = forces / norms[:, None]
    angles = np.arccos(np.clip(dirs @ dirs.T, -1.0, 1.0))
    sd_angle = np.sqrt((sd_perp / norms)[:, None] ** 2 + (sd_perp / norms)[None, :] ** 2)
    score = angles / np.maximum(sd_angle, 1e-300)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    if angles.max() < 1e-6 or score[i, j] < min_tilt_sigmas:
        raise IllConditionedError(
            f"gravity directions too close: poses differ by at most "
            f"{math.degrees(angles.max()):.3g} deg, {score[i, j]:.2g} sigma of the noise "
            f"(need {min_tilt_sigmas:g}); tilt further or dwell longer"
        )


# --- consistency -------------------------------------------------------------------------


def check_consistency(
    windows: Sequence[Window],
    alpha: float = DEFAULT_ALPHA,
    g: float = STANDARD_GRAVITY,
    locate: bool = True,
) -> Consistency:
    """Chi-square test that one rigid (m, p) explains all windows; names a moved pose.

    The ML fit's residual chi-square (4n - 4 dof) is compared with its 1 - alpha
    quantile. When it fails, two families of alternatives, each giving some poses a COM
    of their own, are fitted: "pose k alone moved" and "the object moved at pose k
    and stayed". The alternative with the smallest chi-square names pose k
    (``locate=False`` skips this search).
    """
    if len(windows) < 2:
        raise TooFewPosesError(f"need at least 2 poses, got {len(windows)}")
    n = len(windows)
    chi2, dof = _fit(windows, np.zeros(n, dtype=int), g).chi2_dof()
    p_value = chi2_sf(chi2, dof)
    if p_value >= alpha:
        return Consistency(True, chi2, dof, p_value, alpha, None, "poses consistent")
    head = f"poses inconsistent (chi2 {chi2:.1f}, dof {dof}, p {p_value:.2g})"
    if n == 2 or not locate:
        msg = (
            f"{head}: the object moved in the grasp between {windows[0].pose!r} and "
            f"{windows[-1].pose!r}"
        )
        return Consistency(False, chi2, dof, p_value, alpha, None, msg)
    best_chi2, suspect = math.inf, 0
    for k in range(n):
        alone = (np.arange(n) == k).astype(int)
        after = (np.arange(n) >= k).astype(int)
        for groups in (alone, after) if 0 < k < n - 1 else (alone,):
            alt = _fit(windows, groups, g).chi2()
            if alt < best_chi2:
                best_chi2, suspect = alt, k
    msg = f"{head}: the object moved in the grasp at pose {windows[suspect].pose!r}"
    return Consistency(False, chi2, dof, p_value, alpha, windows[suspect].pose, msg)
