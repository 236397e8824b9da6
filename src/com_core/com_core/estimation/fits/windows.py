"""Static windows: labelled runs of F/T samples reduced to a mean wrench and its covariance.

A window holds the samples taken while the arm rests in one pose. It is reduced to its
mean wrench and the covariance of that mean (N, N m; sensor frame). Windows whose
samples are not finite, reached the sensor's range, or show motion are refused with
the reason. Object windows are matched to tare windows (empty hand) of the same pose
and the tare is subtracted pose by pose: the hand's own wrench changes with the
orientation, so one constant tare is wrong after a tilt (the paper's W_HAND, eq. 2).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.errors import (
    MissingTareError,
    MotionError,
    NonFiniteError,
    SaturationError,
)
from com_core.estimation.fits.stats import chi2_isf
from com_core.sensing.noise import COV_FLOOR, NoiseModel
from com_core.sensing.wrench_model import AXES, SensorModel

__all__ = [
    "MIN_SAMPLES_FOR_COVARIANCE",
    "Window",
    "reduce_window",
    "settled_start",
    "subtract_tare",
    "window_from_mean",
]

MIN_SAMPLES_FOR_COVARIANCE = 30
"""Below this many samples the covariance comes from the sensor model, not the samples."""

_MOTION_Z = 6.0
"""Threshold (standard scores) of the motion tests; a false alarm < 1e-8 per axis."""
SETTLE_PROBE = 0.1
"""s: the length of the pieces ``settled_start`` tests for the arm's ringing."""
_SETTLE_ALPHA = 1e-5
"""False-alarm rate of the settling test's variance per probe and axis."""
_MOTION_ALPHA = 1e-9
"""False-alarm rate of the excess-variance motion test per axis (6 standard scores)."""


@dataclass(frozen=True)
class Window:
    """A static window reduced to its mean.

    Attributes
    ----------
    pose : pose name without the ``tare/`` or ``object/`` prefix, e.g. ``tilt_x+``.
    mean : shape (6,); N and N m; sensor frame.
    cov : shape (6, 6); covariance of ``mean`` (not of one sample).
    n : number of samples averaged.
    """

    pose: str
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    n: int

    @property
    def force(self) -> NDArray[np.float64]:
        """Mean force, shape (3,); N."""
        return self.mean[:3]

    @property
    def torque(self) -> NDArray[np.float64]:
        """Mean torque, shape (3,); N m."""
        return self.mean[3:]


def window_from_mean(pose: str, mean: ArrayLike, cov: ArrayLike, n: int = 1) -> Window:
    """Build a window from a known mean and covariance of the mean (validated)."""
    mean_a = np.asarray(mean, dtype=np.float64)
    cov_a = np.asarray(cov, dtype=np.float64)
    if mean_a.shape != (6,) or cov_a.shape != (6, 6):
        raise ValueError(
            f"window {pose!r}: mean (6,) and cov (6, 6), got {mean_a.shape}, {cov_a.shape}"
        )
    if not (np.all(np.isfinite(mean_a)) and np.all(np.isfinite(cov_a))):
        raise NonFiniteError(f"window {pose!r}: mean or covariance is not finite")
    return Window(pose, mean_a, cov_a, int(n))


def reduce_window(
    pose: str,
    samples: ArrayLike,
    sensor: SensorModel | None = None,
    noise: NoiseModel | None = None,
) -> Window:
    """Reduce samples of one static pose to their mean wrench and its covariance.

    Parameters
    ----------
    pose : pose name.
    samples : shape (n, 6); N and N m; sensor frame, in time order.
    sensor : the sensor's model. Its range finds saturated samples; without ``noise``,
        its noise is the covariance when there are fewer than
        ``MIN_SAMPLES_FOR_COVARIANCE`` samples and the reference of the motion test on
        the variance.
    noise : the sensor's learnt noise (``com_core.sensing.noise``): the window starts where the
        arm's ringing has settled (``settled_start``), the covariance of its mean is the
        model's for that many samples (correlated noise: var(mean) = sigma^2 f(n) / n),
        and the motion tests use it.

    Returns
    -------
    Window whose ``cov`` is the covariance of the mean. Without ``noise`` the samples are
    taken as white (the sample covariance / n).

    Raises
    ------
    NonFiniteError, SaturationError, MotionError (with the axis and the statistic), or
    ValueError when the shape is wrong or the window is too short to have a covariance.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 6 or x.shape[0] == 0:
        raise ValueError(f"window {pose!r}: samples must have shape (n, 6), got {x.shape}")
    n = x.shape[0]
    bad = ~np.isfinite(x)
    if bad.any():
        raise NonFiniteError(
            f"window {pose!r}: {int(bad.any(axis=1).sum())} of {n} samples are NaN or inf"
        )
    if sensor is not None:
        sat = sensor.saturated(x)
        if sat.any():
            axis = AXES[int(np.argmax(sat.any(axis=0)))]
            raise SaturationError(
                f"window {pose!r}: {int(sat.any(axis=1).sum())} samples at the sensor's range "
                f"on {axis} (limit {sensor.limit[AXES.index(axis)]:g})"
            )
    if noise is not None:
        x = x[settled_start(x, noise) :]
        n = x.shape[0]
        _check_static_correlated(pose, x, noise)
        return Window(pose, x.mean(axis=0), noise.mean_cov(n), n)
    mean = x.mean(axis=0)
    if n >= MIN_SAMPLES_FOR_COVARIANCE:
        sample_cov = np.cov(x, rowvar=False)
        _check_static(pose, x, sample_cov, sensor)
    elif sensor is not None:
        sample_cov = sensor.sample_covariance()
    else:
        raise ValueError(
            f"window {pose!r}: {n} samples are too few for a covariance "
            f"(need {MIN_SAMPLES_FOR_COVARIANCE}) and no sensor model was given"
        )
    return Window(pose, mean, sample_cov / n, n)


def _quiet(noise: NoiseModel) -> NDArray[np.bool_]:
    """(6,) axes whose noise is below ``COV_FLOOR``: a noise-free sensor, nothing to test."""
    return noise.variance <= COV_FLOOR**2


def _variance_limit(noise: NoiseModel, n: int, alpha: float) -> NDArray[np.float64]:
    """(6,) the largest ratio of n samples' mean square (about their mean) to the noise's
    variance that is noise at false-alarm rate ``alpha``: chi-square with the n / k
    degrees of freedom that correlated samples hold for a variance, k = 1 + 2 sum
    rho(k)^2 (``NoiseModel.variance_dof_factor``), over its dof."""
    dof = n / noise.variance_dof_factor
    return np.array([chi2_isf(alpha, d) / d for d in dof])


def settled_start(x: NDArray[np.float64], noise: NoiseModel) -> int:
    """The first sample (index) of ``x`` (n, 6) after the arm's ringing has settled.

    The first half of the window is cut into probes of ``SETTLE_PROBE`` s; a probe still
    rings when, on any axis, its variance about its own mean exceeds the noise's
    (``_variance_limit`` at ``_SETTLE_ALPHA``). The window starts after the last probe
    that rings (0 when none does), or later, at the first probe from which the rest of the
    window as a whole has the noise's variance (a ringing below each probe's reach). A
    ringing oscillates about the static wrench; a step or
    a creep of the mean is motion, not ringing, and is left to the motion tests. Depends
    on the samples and the model only, so the node and the replay of its bag cut the same
    windows."""
    n = len(x)
    probe = max(10, round(SETTLE_PROBE * noise.rate_hz))
    if n < 4 * probe or _quiet(noise).all():
        return 0
    variance = np.where(_quiet(noise), np.inf, noise.variance)
    limit = _variance_limit(noise, probe, _SETTLE_ALPHA)
    start = 0
    for a in range(0, n // 2 - probe + 1, probe):
        if (x[a : a + probe].var(axis=0) / variance > limit).any():
            start = a + probe
    # a ringing that each probe hides may still show in the rest as a whole: start where
    # the rest's variance is the noise's
    for a in range(start, n // 2 + 1, probe):
        rest = x[a:]
        quiet = rest.var(axis=0) / variance <= _variance_limit(noise, len(rest), _SETTLE_ALPHA)
        if quiet.all():
            return a if a == start or _same_level(x[:a], rest, noise) else start
    return start


def _same_level(head: NDArray[np.float64], rest: NDArray[np.float64], noise: NoiseModel) -> bool:
    """The mean of ``head`` agrees with that of ``rest`` within ``_MOTION_Z`` standard
    scores of their correlated noise: a ringing about the static wrench, not a step."""
    var = np.where(_quiet(noise), 0.0, noise.variance)
    sd = np.sqrt(
        var * noise.mean_factor(len(head)) / len(head)
        + var * noise.mean_factor(len(rest)) / len(rest)
        + 2.0 * COV_FLOOR**2
    )
    return bool((np.abs(head.mean(axis=0) - rest.mean(axis=0)) <= _MOTION_Z * sd).all())


def _check_static_correlated(pose: str, x: NDArray[np.float64], noise: NoiseModel) -> None:
    """Raise MotionError if the window's samples show motion, under correlated noise.

    Two tests per axis:
    - drift: the means of the first and second half differ by more than ``_MOTION_Z``
      standard scores of the model's noise of the two means (``NoiseModel.mean_factor``);
    - excess variance: the samples' variance exceeds the noise's beyond its spread with
      correlated samples at ``_MOTION_ALPHA`` (``_variance_limit``).
    """
    n = x.shape[0]
    if n < 2 * MIN_SAMPLES_FOR_COVARIANCE:
        return
    half = n // 2
    var = noise.variance
    drift = x[half:].mean(axis=0) - x[:half].mean(axis=0)
    drift_sd = np.sqrt(
        var * noise.mean_factor(half) / half
        + var * noise.mean_factor(n - half) / (n - half)
        + 2.0 * COV_FLOOR**2
    )
    drift_z = np.abs(drift) / drift_sd
    worst = int(np.argmax(drift_z))
    if drift_z[worst] > _MOTION_Z:
        raise MotionError(
            f"window {pose!r}: motion, {AXES[worst]} drifts by {drift[worst]:.4g} between "
            f"the halves of the window ({drift_z[worst]:.1f} sigma of the correlated noise)"
        )
    quiet = _quiet(noise)
    ratio = np.where(quiet, 0.0, x.var(axis=0) / np.where(quiet, 1.0, var))
    limit = _variance_limit(noise, n, _MOTION_ALPHA)
    worst = int(np.argmax(ratio / limit))
    if ratio[worst] > limit[worst]:
        raise MotionError(
            f"window {pose!r}: motion, variance of {AXES[worst]} is {ratio[worst]:.1f}x the "
            f"sensor noise's (limit {limit[worst]:.2f}x)"
        )


def _check_static(
    pose: str, x: NDArray[np.float64], sample_cov: NDArray[np.float64], sensor: SensorModel | None
) -> None:
    """Raise MotionError if the window's samples show motion (white noise).

    Two tests per axis, each at ``_MOTION_Z`` standard scores:
    - drift: the means of the first and second half differ by more than their noise;
    - excess variance (needs the sensor model): the sample variance exceeds the sensor's
      by more than the chi-square spread, var/var0 > 1 + z sqrt(2 / (n - 1)).
    """
    n = x.shape[0]
    var = np.diag(sample_cov)
    half = n // 2
    drift = x[half:].mean(axis=0) - x[:half].mean(axis=0)
    drift_sd = np.sqrt(var * (1.0 / half + 1.0 / (n - half)))
    with np.errstate(divide="ignore", invalid="ignore"):
        drift_z = np.where(drift_sd > 0, np.abs(drift) / drift_sd, 0.0)
    worst = int(np.argmax(drift_z))
    if drift_z[worst] > _MOTION_Z:
        raise MotionError(
            f"window {pose!r}: motion, {AXES[worst]} drifts by {drift[worst]:.4g} between "
            f"the halves of the window ({drift_z[worst]:.1f} sigma)"
        )
    if sensor is None:
        return
    var0 = np.diag(sensor.sample_covariance())
    limit = 1.0 + _MOTION_Z * math.sqrt(2.0 / (n - 1))
    ratio = np.divide(var, var0, out=np.zeros(6), where=var0 > 0)
    worst = int(np.argmax(ratio))
    if ratio[worst] > limit:
        raise MotionError(
            f"window {pose!r}: motion, variance of {AXES[worst]} is {ratio[worst]:.1f}x the "
            f"sensor noise (limit {limit:.2f}x)"
        )


def subtract_tare(objects: Sequence[Window], tares: Iterable[Window]) -> list[Window]:
    """Object windows minus the tare window of the same pose, covariances added.

    The tare of each pose is the empty hand's wrench in that pose, so the result is the
    object's wrench alone in every pose (the paper's W_E after removing W_HAND).

    Raises MissingTareError naming every object pose without a tare.
    """
    by_pose = {t.pose: t for t in tares}
    missing = [w.pose for w in objects if w.pose not in by_pose]
    if missing:
        have = ", ".join(sorted(by_pose)) or "none"
        raise MissingTareError(
            f"no tare for pose(s) {', '.join(missing)} (tare poses recorded: {have})"
        )
    return [
        Window(w.pose, w.mean - by_pose[w.pose].mean, w.cov + by_pose[w.pose].cov, w.n)
        for w in objects
    ]
