"""The sensor's noise as it is: correlated from sample to sample, learnt from static windows.

A real F/T sensor low-pass filters its signal before it publishes, so neighbouring samples
are correlated over milliseconds to tens of milliseconds, and the mean of N samples varies
more than sigma^2 / N. Per axis, the noise is modelled as a stationary autoregressive
process of order p (AR(p)):

    x_t = phi_1 x_{t-1} + ... + phi_p x_{t-p} + e_t,    e_t white, variance s_e^2,

learnt from the pooled autocovariance of static windows (each less its own mean) by the
Yule-Walker equations (Levinson-Durbin), its order chosen by AIC up to ``MAX_ORDER``.

Why AR, not batch means or a smoothed spectrum: a digital low-pass of order q on white
noise is AR(q) at its own rate, and the first-order low-pass, decimated to the publish
rate, is exactly AR(1) there; a few numbers describe the whole autocorrelation, so the
variance of the mean of a window of any length follows, shorter than the correlation's
reach included. Batch means need many long batches per window (a 0.9 s window holds only
a few batches of a 20 ms correlation: a covariance with a handful of degrees of freedom);
a spectrum at zero needs a bandwidth chosen per sensor.

Used for (``windows.reduce_window``):

- the covariance of a window mean of n samples: var(mean) = sigma^2 / n * f(n), with
  f(n) = 1 + 2 sum_{k=1}^{n-1} (1 - k / n) rho(k) (``mean_factor``; rho the
  autocorrelation); across axes the samples' covariance is scaled by sqrt(f_a f_b);
- the motion tests: the drift between a window's halves against that covariance, and
  the excess variance against the variance's spread with correlated samples;
- where a window has settled after the arm's ringing (``settled_start``).

Each window is less its own mean, which biases the pooled autocovariance down by the
variance of that mean; the learning corrects for it, iterating with the model's own
variance of each window's mean (three rounds).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.sensing.wrench_model import AXES

__all__ = [
    "COV_FLOOR",
    "MAX_ORDER",
    "MIN_LEARN_SAMPLES",
    "NoiseModel",
    "ar1_noise",
    "learn_noise",
    "white_noise",
]

MAX_ORDER = 8
"""The highest AR order tried."""
MIN_LEARN_SAMPLES = 400
"""Fewer pooled samples than this learn no model (the windows' own covariance, white)."""
COV_FLOOR = np.array([2e-4, 2e-4, 2e-4, 1e-5, 1e-5, 1e-5])
"""N, N m: the smallest sigma a window mean is given per axis, whatever its samples say:
the static error of the simulator's sensor reading (docs/design.md) and below any real
sensor's resolution. A noise-free sensor (the ``ideal`` profile) thus still gives an
estimate, with a covariance from this floor."""
_ROUNDS = 3  # iterations of the demeaning correction


@dataclass(frozen=True)
class NoiseModel:
    """Per-axis AR noise of the sensor (see module).

    Attributes
    ----------
    cov : (6, 6) covariance of one sample (N^2, N^2 m, N^2 m^2): the contemporaneous one.
    ar : per axis, the AR coefficients (phi_1 .. phi_p); empty: white.
    innovation : (6,) variance of each axis's prediction error e_t.
    samples : how many samples it was learnt from (0: assumed, not learnt).
    rate_hz : the sample rate it was learnt at (for times in reports).
    """

    cov: NDArray[np.float64]
    ar: tuple[tuple[float, ...], ...]
    innovation: NDArray[np.float64]
    samples: int = 0
    rate_hz: float = 1000.0
    _rho: dict[str, NDArray[np.float64]] = field(default_factory=dict, repr=False, compare=False)

    @property
    def variance(self) -> NDArray[np.float64]:
        """(6,) variance of one sample per axis."""
        return np.diag(self.cov).copy()

    @property
    def orders(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.ar)

    def autocorrelation(self, lags: int) -> NDArray[np.float64]:
        """(lags + 1, 6): rho(0..lags) per axis, the AR model's (Yule-Walker recursion)."""
        have = self._rho.get("rho")
        if have is not None and len(have) > lags:
            return have[: lags + 1]
        wanted, lags = lags, max(lags, 2 * len(have) if have is not None else 0)
        p = max(self.orders, default=0)
        phi = np.zeros((p, 6))  # each axis's coefficients, padded with zeros
        rho = np.zeros((lags + 1, 6))
        rho[0] = 1.0
        for a, coefficients in enumerate(self.ar):
            if coefficients:
                phi[: len(coefficients), a] = coefficients
                start = _yule_walker_rho(np.array(coefficients))
                rho[1 : min(len(start), lags + 1), a] = start[1 : lags + 1]
        order = np.array(self.orders)
        for k in range(1, lags + 1):  # beyond each axis's own order: the recursion
            past = np.array([rho[abs(k - j)] for j in range(1, p + 1)]).reshape(p, 6)
            rho[k] = np.where(k > order, (phi * past).sum(axis=0), rho[k])
        self._rho["rho"] = rho
        return rho[: wanted + 1]

    def mean_factor(self, n: int) -> NDArray[np.float64]:
        """(6,) f(n): var(mean of n samples) / (sigma^2 / n) per axis (module); 1 if white."""
        if n <= 1 or not any(self.ar):
            return np.ones(6)
        rho = self.autocorrelation(n - 1)[1:]
        weights = 1.0 - np.arange(1, n) / n
        return np.maximum(1.0 + 2.0 * weights @ rho, 1.0 / n)

    @property
    def long_run_factor(self) -> NDArray[np.float64]:
        """(6,) f at n -> inf: s_e^2 / (1 - sum phi)^2 / sigma^2; 1 if white. A window of n
        samples, n much longer than the correlation, is worth n / f independent ones."""
        out = np.ones(6)
        var = self.variance
        for a, phi in enumerate(self.ar):
            if phi and var[a] > 0:
                out[a] = self.innovation[a] / (1.0 - sum(phi)) ** 2 / var[a]
        return out

    @property
    def correlation_time(self) -> NDArray[np.float64]:
        """(6,) s: the integrated correlation time (f_inf - 1) / 2 / rate (a first-order
        low-pass of time constant T gives T)."""
        return (self.long_run_factor - 1.0) / 2.0 / self.rate_hz

    def mean_cov(
        self, n: int, sample_cov: ArrayLike | None = None, floor: bool = True
    ) -> NDArray[np.float64]:
        """(6, 6) covariance of the mean of n samples: ``sample_cov`` (default: the
        model's) scaled per axis pair by sqrt(f_a f_b) / n, with ``COV_FLOOR``."""
        s = self.cov if sample_cov is None else np.asarray(sample_cov, dtype=np.float64)
        root = np.sqrt(self.mean_factor(n))
        return s * np.outer(root, root) / max(n, 1) + (np.diag(COV_FLOOR**2) if floor else 0.0)

    def prediction_errors(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """(n - p_max, 6): each axis's AR prediction errors e_t of samples ``x`` (n, 6),
        less their mean; white with variance ``innovation`` where the model holds."""
        p_max = max(self.orders, default=0)
        y = x - x.mean(axis=0)
        out = y[p_max:].copy()
        for a, phi in enumerate(self.ar):
            for k, c in enumerate(phi, start=1):
                out[:, a] -= c * y[p_max - k : len(y) - k, a]
        return out

    def as_dict(self) -> dict:
        """JSON-ready: every float round-trips."""
        return {
            "cov": self.cov.tolist(),
            "ar": [list(a) for a in self.ar],
            "innovation": self.innovation.tolist(),
            "samples": self.samples,
            "rate_hz": self.rate_hz,
        }

    @staticmethod
    def from_dict(data: dict) -> NoiseModel:
        return NoiseModel(
            np.array(data["cov"], dtype=np.float64).reshape(6, 6),
            tuple(tuple(float(c) for c in a) for a in data["ar"]),
            np.array(data["innovation"], dtype=np.float64).reshape(6),
            int(data.get("samples", 0)),
            float(data.get("rate_hz", 1000.0)),
        )

    def summary(self) -> str:
        """One line: sigma per sample, correlation time and AR order, force and torque."""
        s = np.sqrt(self.variance)
        t = self.correlation_time * 1e3
        return (
            f"noise per sample {s[:3].max():.3g} N, {s[3:].max():.3g} N m; correlation "
            f"time {t[:3].max():.2f} ms (forces), {t[3:].max():.2f} ms (torques); AR order "
            f"{max(self.orders, default=0)}"
            + (f", learnt from {self.samples} samples" if self.samples else ", assumed")
        )

    def changed_from(self, other: NoiseModel, z: float = 6.0) -> str:
        """Why this model's noise level differs from ``other``'s beyond ``z`` standard
        scores of the two estimates (the axis and both sigmas), or ''."""
        if not (self.samples and other.samples):
            return ""
        a, b = self.variance, other.variance
        reach = self.variance_dof_factor / self.samples
        reach += other.variance_dof_factor / other.samples
        with np.errstate(divide="ignore", invalid="ignore"):
            score = np.abs(np.log(a / b)) / np.sqrt(2.0 * reach)
        score = np.where((a > COV_FLOOR**2) | (b > COV_FLOOR**2), score, 0.0)
        worst = int(np.nanargmax(score))
        if not score[worst] > z:
            return ""
        return (
            f"the sensor's noise changed since the tare: {AXES[worst]} "
            f"{math.sqrt(b[worst]):.3g} -> {math.sqrt(a[worst]):.3g} per sample"
        )

    @property
    def variance_dof_factor(self) -> NDArray[np.float64]:
        """(6,) k = 1 + 2 sum_{k>=1} rho(k)^2 (to 500 lags): n correlated samples hold
        n / k degrees of freedom for a variance (1 if white)."""
        return 1.0 + 2.0 * (self.autocorrelation(500)[1:] ** 2).sum(axis=0)


def white_noise(sample_cov: ArrayLike, rate_hz: float = 1000.0) -> NoiseModel:
    """A white ``NoiseModel`` of per-sample covariance ``sample_cov`` (6, 6), assumed."""
    cov = np.asarray(sample_cov, dtype=np.float64)
    return NoiseModel(cov, ((),) * 6, np.diag(cov).copy(), 0, rate_hz)


def ar1_noise(
    sigma: ArrayLike, correlation_time: float, rate_hz: float, white: ArrayLike = 0.0
) -> NoiseModel:
    """An assumed ``NoiseModel``: ``sigma`` (6,) per sample through a first-order low-pass
    of time constant ``correlation_time`` (s), published at ``rate_hz``: AR(1); plus,
    given ``white`` (6,; its sigma per sample, as a quantisation's step / sqrt(12)), a
    white error added after the filter. The sum is ARMA(1, 1), not AR; its model is the
    AR(``MAX_ORDER``) of its autocovariance (Levinson-Durbin, as ``learn_noise`` learns
    it): exact to lag ``MAX_ORDER``, its coefficients falling off geometrically beyond
    while the white part is small beside the filtered one (a quantisation below the
    noise: the realistic sensor's eighth force coefficient is 6e-9)."""
    s = np.asarray(sigma, dtype=np.float64) * np.ones(6)
    w = np.asarray(white, dtype=np.float64) * np.ones(6)
    variance = s**2 + w**2
    if correlation_time <= 0:
        return white_noise(np.diag(variance), rate_hz)
    phi = math.exp(-1.0 / (rate_hz * correlation_time))
    if not np.any(w > 0):
        return NoiseModel(np.diag(variance), ((phi,),) * 6, s**2 * (1 - phi**2), 0, rate_hz)
    fits = []
    for a in range(6):
        gamma = s[a] ** 2 * phi ** np.arange(MAX_ORDER + 1)
        gamma[0] += w[a] ** 2
        fits.append(_levinson(gamma, MAX_ORDER)[-1])
    ar = tuple(tuple(float(c) for c in coefficients) for coefficients, _ in fits)
    return NoiseModel(np.diag(variance), ar, np.array([e for _, e in fits]), 0, rate_hz)


def _yule_walker_rho(phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """rho(0..p) of a stationary AR(p) with coefficients ``phi`` (p,)."""
    p = len(phi)
    # rho(k) - sum_j phi_j rho(|k - j|) = 0 for k = 1..p, rho(0) = 1
    a = np.eye(p + 1)
    b = np.zeros(p + 1)
    b[0] = 1.0
    for k in range(1, p + 1):
        for j, c in enumerate(phi, start=1):
            a[k, abs(k - j)] -= c
    return np.linalg.solve(a, b)


def _levinson(gamma: NDArray[np.float64], order: int) -> list[tuple[NDArray, float]]:
    """Levinson-Durbin: (phi, innovation variance) for orders 0..order from the
    autocovariance ``gamma`` (order + 1,); stops early where the recursion breaks down."""
    out = [(np.zeros(0), float(gamma[0]))]
    phi = np.zeros(0)
    err = float(gamma[0])
    for p in range(1, order + 1):
        if err <= 0:
            break
        k = (gamma[p] - float(np.dot(phi, gamma[1:p][::-1]))) / err
        if not abs(k) < 1.0:
            break
        phi = np.concatenate([phi - k * phi[::-1], [k]])
        err *= 1.0 - k * k
        out.append((phi.copy(), err))
    return out


def learn_noise(
    segments: Sequence[NDArray[np.float64]],
    rate_hz: float = 1000.0,
    min_samples: int = MIN_LEARN_SAMPLES,
) -> NoiseModel | None:
    """The ``NoiseModel`` of static ``segments`` (each (n, 6), in time order; N, N m),
    pooled; None when they hold fewer than ``min_samples`` samples in all. Each segment
    is taken less its own mean (module)."""
    parts = [np.asarray(s, dtype=np.float64) for s in segments if len(s) > MAX_ORDER + 2]
    total = sum(len(s) for s in parts)
    if total < min_samples:
        return None
    demeaned = [s - s.mean(axis=0) for s in parts]
    lengths = np.array([len(s) for s in parts], dtype=np.float64)
    lags = np.arange(MAX_ORDER + 1)
    # sum over segments of the lagged products per axis, and the pair counts
    products = np.zeros((MAX_ORDER + 1, 6))
    for y in demeaned:
        for k in lags:
            products[k] += np.einsum("ij,ij->j", y[: len(y) - k], y[k:])
    counts = np.array([(lengths - k).sum() for k in lags])
    cov0 = sum(y.T @ y for y in demeaned)
    model = None
    for _ in range(_ROUNDS):
        # each segment's own mean took var(mean) from every product (module)
        if model is None:
            correction = np.zeros((MAX_ORDER + 1, 6))
            cov_correction = np.zeros((6, 6))
        else:
            mean_var = np.array([np.diag(model.mean_cov(int(n), floor=False)) for n in lengths])
            correction = np.array([((lengths - k)[:, None] * mean_var).sum(axis=0) for k in lags])
            cov_correction = sum(model.mean_cov(int(n), floor=False) * n for n in lengths)
        gamma = (products + correction) / counts[:, None]
        cov = (cov0 + cov_correction) / total
        ar, innovation = [], np.zeros(6)
        for a in range(6):
            if not gamma[0, a] > COV_FLOOR[a] ** 2:  # below the floor: white, if anything
                ar.append(())
                innovation[a] = max(gamma[0, a], 0.0)
                continue
            fits = _levinson(gamma[:, a], MAX_ORDER)
            aic = [total * math.log(err) + 2 * len(phi) for phi, err in fits if err > 0]
            best = int(np.argmin(aic))
            ar.append(tuple(float(c) for c in fits[best][0]))
            innovation[a] = fits[best][1]
        model = NoiseModel(cov, tuple(ar), innovation, total, rate_hz)
    return model
