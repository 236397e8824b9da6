"""The sensor's calibration error as a systematic term of the fit's covariance.

A sensor reads C w instead of the wrench w, with C = I + S E S^-1 its calibration's
error: S = diag(fs_f, fs_f, fs_f, fs_tau, fs_tau, fs_tau) the full scales, and E a fixed
6 x 6 matrix of gain and cross-talk errors, each element of spread accuracy / 2 (the
stated accuracy is the 95 % bound of one axis's error as a fraction of full scale;
``wrench_model.calibration_matrix`` draws one so). E is the same in every window, so it
is not averaged away: it adds to the windows' means a common error

    dw_i = S E S^-1 w_i = J(w_i) vec(E),    J(w)[a, 6 a + b] = S_a w_b / S_b,

whose covariance couples every pair of windows:

    cov(dw_i, dw_j) = (accuracy / 2)^2 (w~_i . w~_j) S^2,    w~ = S^-1 w.

The kinematic fit (``known_gravity``) weighs its windows with the block-diagonal noise
covariance plus this term (generalised least squares): the reported covariance then holds
the calibration's share, the chi-square test is not misled by a misfit the calibration
explains, and the verification's residual covariance has it too. The true wrenches are
taken as the measured window means (first order).

The wrenches alone (``estimators``) weigh windows one by one: the tare-subtracted windows'
common error is E applied to the object's wrench (the hand's cancels in the subtraction),
its share of the estimate's covariance is propagated through the estimator's Jacobian by
the window means (``propagated``), and the chi-square test widens each window by its own
share (``widened``; the correlation across windows is left out of that test).

A sensor calibrated in place (``estimation.fits.in_place``) has an estimate of the error
as its fit sees it: the common error taken at the readings y = C w, not at the wrenches,
is exactly y - w = S E' S^-1 y with I - S E' S^-1 = C^-1, so E' = E - E^2 + E^3 - ...
is what the fit identifies, not E (they differ by E's square: some 2e-4 per element for
a 2 % sensor, three times what a 2 kg reference identifies E to). Its estimate E'^
(``estimate``) and what is left of it, E' - E'^, of covariance ``residual_cov`` (36, 36)
in place of sigma^2 I: its readings are corrected by I - S E'^ S^-1 (``correct``), which
leaves S (E' - E'^) S^-1 y, the common error above for the rest, each formula with
``error_cov`` for sigma^2 I. The rest acts on the reading as read, y, not on it as
corrected (``as_read``): they differ by C - I, whose force-from-torque terms are
S_f / S_tau (some 30) times E's, so that the torque-from-force error times what is
left of the force-from-torque one moves a force's gain by as much as a heavy reference
identifies it to.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.sensing.hysteresis import Hysteresis

__all__ = ["Calibration", "reading_correction"]

_STEP = 1e-3
"""Central-difference step of ``propagated``, in sigmas of each window mean."""


@dataclass(frozen=True)
class Calibration:
    """The sensor's stated ``accuracy`` (fraction of full scale, 95 %) and its full
    scales (N, N m), which weigh the cross-talk between forces and torques; for a sensor
    calibrated in place, the estimate E^ (6, 6) of its error (``estimate``) and the
    covariance of the rest (``residual_cov``, (36, 36), row-major vec(E)); the estimate
    is of the error as read, E' (module)."""

    accuracy: float
    full_scale_f: float
    full_scale_tau: float
    estimate: NDArray[np.float64] | None = field(default=None, compare=False)
    residual_cov: NDArray[np.float64] | None = field(default=None, compare=False)

    @property
    def scale(self) -> NDArray[np.float64]:
        """(6,) S's diagonal: N, N, N, N m, N m, N m."""
        return np.array([self.full_scale_f] * 3 + [self.full_scale_tau] * 3)

    @property
    def sigma(self) -> float:
        """The prior spread of each element of E (the stated accuracy's)."""
        return self.accuracy / 2.0

    @property
    def error_cov(self) -> NDArray[np.float64]:
        """(36, 36): the covariance of what is left of vec(E) (sigma^2 I uncalibrated)."""
        if self.residual_cov is None:
            return self.sigma**2 * np.eye(36)
        return self.residual_cov

    def with_gain_spread(self, sigma: ArrayLike) -> Calibration:
        """This calibration with each axis's own gain (E's diagonal) off by a further
        independent error of spread ``sigma`` (6,; a fraction): a sensor's hysteresis
        along a motion (``sensing.hysteresis``). Its estimate, if any, is kept."""
        extra = np.zeros(36)
        extra[np.arange(6) * 7] = np.asarray(sigma, dtype=np.float64) ** 2
        return replace(self, residual_cov=self.error_cov + np.diag(extra))

    def spread(self, gain: ArrayLike) -> NDArray[np.float64]:
        """(k, k): the covariance of k numbers that move with vec(E) by ``gain`` (k, 36)."""
        g = np.asarray(gain, dtype=np.float64)
        if self.residual_cov is None:
            return self.sigma**2 * g @ g.T
        return g @ self.residual_cov @ g.T

    def draws(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """(n, 36): draws of what is left of vec(E)."""
        if self.residual_cov is None:
            return self.sigma * rng.standard_normal((n, 36))
        return rng.multivariate_normal(np.zeros(36), self.residual_cov, n, method="eigh")

    @property
    def correction(self) -> NDArray[np.float64]:
        """(6, 6) I - S E'^ S^-1: what corrects a reading, C^-1 as far as the estimate of
        the error as read goes (module; I without an estimate)."""
        if self.estimate is None:
            return np.eye(6)
        s = self.scale
        return np.eye(6) - s[:, None] * self.estimate / s[None, :]

    def correct(self, wrenches: ArrayLike) -> NDArray[np.float64]:
        """Readings (..., 6; N, N m) corrected by the in-place estimate (``correction``);
        unchanged without one."""
        w = np.asarray(wrenches, dtype=np.float64)
        return w if self.estimate is None else w @ self.correction.T

    def as_read(self, wrenches: ArrayLike) -> NDArray[np.float64]:
        """Readings (..., 6; N, N m) ``correct`` corrected, as the sensor read them: what
        the rest of the error acts on (module); unchanged without an estimate."""
        w = np.asarray(wrenches, dtype=np.float64)
        return w if self.estimate is None else np.linalg.solve(self.correction, w.T).T

    def jacobian(self, wrench: ArrayLike) -> NDArray[np.float64]:
        """(6, 36): d(C w) / d vec(E) at the wrench ``wrench`` (6,), of a reading corrected
        by the estimate: at it as read (``as_read``); row-major vec(E)."""
        return self.stacked_jacobian(np.asarray(wrench).reshape(1, 6))

    def stacked_jacobian(self, wrenches: ArrayLike) -> NDArray[np.float64]:
        """(6 n, 36): ``jacobian`` of each of ``wrenches`` (n, 6), stacked."""
        w = self.as_read(np.asarray(wrenches, dtype=np.float64).reshape(-1, 6))
        s = self.scale
        out = np.zeros((len(w), 6, 6, 6))  # window, read axis a, the block 6 a .. 6 a + 6
        out[:, np.arange(6), np.arange(6), :] = s[None, :, None] * w[:, None, :] / s
        return out.reshape(6 * len(w), 36)

    def cov(self, wrenches: ArrayLike) -> NDArray[np.float64]:
        """(6 n, 6 n): the covariance of the common error of windows with ``wrenches``
        (n, 6) as their means (module)."""
        w = np.asarray(wrenches, dtype=np.float64).reshape(-1, 6)
        if self.residual_cov is not None:
            return self.spread(self.stacked_jacobian(w))
        s = self.scale
        normalised = w / s
        return self.sigma**2 * np.kron(normalised @ normalised.T, np.diag(s**2))

    def widened(self, windows: Sequence) -> list:
        """``windows`` (``windows.Window``) with each covariance plus its own share of the
        common error."""
        return [replace(w, cov=w.cov + self.cov(w.mean)) for w in windows]

    def propagated(
        self, estimate_of: Callable[[list], NDArray[np.float64]], windows: Sequence
    ) -> NDArray[np.float64]:
        """(k, k): the covariance the common error gives the k numbers
        ``estimate_of(windows)`` computes from ``windows``, through its Jacobian by the
        windows' means (central differences)."""
        windows = list(windows)
        columns = []
        for i, w in enumerate(windows):
            for a in range(6):
                h = _STEP * float(np.sqrt(w.cov[a, a]))
                step = np.zeros(6)
                step[a] = h
                plus, minus = list(windows), list(windows)
                plus[i], minus[i] = replace(w, mean=w.mean + step), replace(w, mean=w.mean - step)
                columns.append((estimate_of(plus) - estimate_of(minus)) / (2 * h))
        jac = np.array(columns).T
        return jac @ self.cov(np.array([w.mean for w in windows])) @ jac.T


def reading_correction(
    calibration: Calibration | None, hysteresis: Hysteresis | None
) -> NDArray[np.float64] | None:
    """(6, 6) what corrects a reading (N, N m; readings times its transpose): the gauges'
    gain under the stated ``hysteresis`` taken off first (``Hysteresis.gain``), then the
    calibration in place (``Calibration.correction``), which was identified from readings
    so corrected; None when there is neither."""
    if hysteresis is None and (calibration is None or calibration.estimate is None):
        return None
    correction = np.eye(6) if calibration is None else calibration.correction
    return correction if hysteresis is None else correction / hysteresis.gain()
