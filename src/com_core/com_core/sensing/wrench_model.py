"""The static gravity wrench of a grasped load and a model of the F/T sensor reading it.

Convention (docs/estimation.md): the wrench on the sensor is the wrench the load exerts on it,
expressed in the sensor frame ``ft_sensor``. A load of mass ``m`` (kg) with centre of
mass ``p`` (m, sensor frame) under gravity ``g_s`` (m/s^2, sensor frame) gives

    f = m g_s,    tau = p x f                                   (N, N m)

This is the paper's eq. 2 with W_HAND removed and R_COM = I, written with tau = P x f
as in its eq. 10 (its eqs. 4-9 use the opposite sign; see ``estimators``).
Wrench vectors are ordered (fx, fy, fz, tx, ty, tz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "AXES",
    "STANDARD_GRAVITY",
    "SensorModel",
    "as_vector",
    "calibration_matrix",
    "gravity_in_sensor",
    "gravity_wrench",
    "rotation_about",
    "skew",
]

STANDARD_GRAVITY = 9.80665
"""m/s^2; the simulator uses the same value."""

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")

_UNIT_AXES = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def as_vector(value: ArrayLike, size: int, name: str) -> NDArray[np.float64]:
    """Return ``value`` as a float64 array of shape (size,), broadcasting a scalar.

    Raises ValueError naming the shape it got.
    """
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0:
        return np.full(size, float(array))
    if array.shape != (size,):
        raise ValueError(f"{name} must be a scalar or shape ({size},), got shape {array.shape}")
    return array.copy()


def skew(v: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrix of ``v`` (the paper's v^X): ``skew(a) @ b == a x b``."""
    x, y, z = as_vector(v, 3, "v")
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_about(axis: str | ArrayLike, angle: float) -> NDArray[np.float64]:
    """Rotation matrix (3, 3) of ``angle`` rad about ``axis`` ('x', 'y', 'z' or a vector)."""
    u = _UNIT_AXES[axis] if isinstance(axis, str) else as_vector(axis, 3, "axis")
    u = u / np.linalg.norm(u)
    k = skew(u)
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def gravity_in_sensor(
    R_world_sensor: ArrayLike, g: float | ArrayLike = STANDARD_GRAVITY
) -> NDArray[np.float64]:
    """g_s = R_world_sensor^T g_world: gravity (m/s^2) expressed in the sensor frame.

    R_world_sensor : (3, 3) or a stack (n, 3, 3); maps sensor-frame vectors to the world
        frame.
    g : m/s^2; a number g for world gravity (0, 0, -g) (a base standing upright, z up),
        or the world's gravity vector, shape (3,) (a tilted or wall-mounted base).

    Returns (3,) or (n, 3). Raises ValueError for other shapes.
    """
    R = np.asarray(R_world_sensor, dtype=np.float64)
    if R.ndim not in (2, 3) or R.shape[-2:] != (3, 3):
        raise ValueError(f"rotations must have shape (3, 3) or (n, 3, 3), got {R.shape}")
    g_world = np.asarray(g, dtype=np.float64)
    if g_world.ndim == 0:
        g_world = np.array([0.0, 0.0, -float(g_world)])
    elif g_world.shape != (3,):
        raise ValueError(f"g must be a number or shape (3,), got shape {g_world.shape}")
    return g_world @ R  # as rows, g_s^T = g^T R: for one R or a stack of them


def calibration_matrix(
    accuracy: float, full_scale_f: float, full_scale_tau: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """A sensor's calibration (6, 6), C = I + S E S^-1: S = diag(fs_f x3, fs_tau x3) the
    full scales, each element of E drawn N(0, (accuracy / 2)^2) (the stated accuracy is
    the 95 % bound of one axis's error at full scale; ``com_core.sensing.calibration``)."""
    s = np.array([full_scale_f] * 3 + [full_scale_tau] * 3, dtype=np.float64)
    e = rng.normal(0.0, accuracy / 2.0, (6, 6))
    return np.eye(6) + s[:, None] * e / s[None, :]


def gravity_wrench(mass: float, com: ArrayLike, g_sensor: ArrayLike) -> NDArray[np.float64]:
    """Wrench the static load exerts on the sensor: f = m g_s, tau = p x f.

    Parameters
    ----------
    mass : kg.
    com : shape (3,); m; sensor frame.
    g_sensor : shape (3,) or (n, 3); m/s^2; gravity in the sensor frame per pose.

    Returns
    -------
    shape (6,) or (n, 6); N and N m; sensor frame.
    """
    p = as_vector(com, 3, "com")
    g = np.asarray(g_sensor, dtype=np.float64)
    f = mass * g
    return np.concatenate([f, np.cross(p, f)], axis=-1)


@dataclass(frozen=True)
class SensorModel:
    """A 6-axis F/T sensor: calibration, bias, Gaussian noise, quantisation, range.

    All arrays are shape (6,) in the order of ``AXES``; N for forces, N m for torques.
    ``resolution`` 0 means no quantisation, ``limit`` inf means no saturation.
    ``sigma`` is the noise per published sample. ``correlation_time`` (s) is the
    electronics' first-order digital low-pass: the sensor samples fast and publishes every
    k-th filtered sample, so its noise is exactly AR(1) at the publish rate, coefficient
    phi = exp(-1 / (rate_hz correlation_time)) (decimating an AR(1) by k gives phi^k);
    0: white. ``calibration`` (6, 6): the reading is ``calibration @ wrench`` (None: exact;
    ``calibration_matrix`` draws one).
    """

    sigma: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))
    bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))
    resolution: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))
    limit: NDArray[np.float64] = field(default_factory=lambda: np.full(6, np.inf))
    rate_hz: float = 1000.0
    correlation_time: float = 0.0
    calibration: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        for name in ("sigma", "bias", "resolution", "limit"):
            object.__setattr__(self, name, as_vector(getattr(self, name), 6, name))
        if np.any(self.sigma < 0) or np.any(self.resolution < 0) or np.any(self.limit <= 0):
            raise ValueError("sigma and resolution must be >= 0 and limit > 0")
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {self.rate_hz}")
        if not (math.isfinite(self.correlation_time) and self.correlation_time >= 0):
            raise ValueError(f"correlation_time must be >= 0 s, got {self.correlation_time}")
        if self.calibration is not None:
            c = np.asarray(self.calibration, dtype=np.float64)
            if c.shape != (6, 6) or not np.all(np.isfinite(c)):
                raise ValueError("calibration must be a finite (6, 6) matrix")
            object.__setattr__(self, "calibration", c)
        object.__setattr__(self, "_quantised", bool(np.any(self.resolution > 0)))
        object.__setattr__(self, "_limited", bool(np.any(np.isfinite(self.limit))))
        # for ``apply``, once: the quantisation step per axis (1 where none) and the range's
        # lower end
        object.__setattr__(self, "_step", np.where(self.resolution > 0, self.resolution, 1.0))
        object.__setattr__(self, "_low", -self.limit)

    @classmethod
    def from_scalars(
        cls,
        sigma_f: float = 0.0,
        sigma_tau: float = 0.0,
        *,
        bias_f: float = 0.0,
        bias_tau: float = 0.0,
        resolution_f: float = 0.0,
        resolution_tau: float = 0.0,
        limit_f: float = np.inf,
        limit_tau: float = np.inf,
        rate_hz: float = 1000.0,
        correlation_time: float = 0.0,
        calibration: ArrayLike | None = None,
    ) -> SensorModel:
        """Same value on every force axis and on every torque axis.

        A limit of 0 (or inf) means no range check, as the nodes' parameters write it.
        """

        def pair(a: float, b: float) -> NDArray[np.float64]:
            return np.array([a, a, a, b, b, b], dtype=np.float64)

        return cls(
            sigma=pair(sigma_f, sigma_tau),
            bias=pair(bias_f, bias_tau),
            resolution=pair(resolution_f, resolution_tau),
            limit=pair(limit_f or np.inf, limit_tau or np.inf),
            rate_hz=rate_hz,
            correlation_time=correlation_time,
            calibration=None if calibration is None else np.asarray(calibration, dtype=float),
        )

    @property
    def phi(self) -> float:
        """The noise's AR(1) coefficient at the publish rate (0: white)."""
        if self.correlation_time <= 0:
            return 0.0
        return math.exp(-1.0 / (self.rate_hz * self.correlation_time))

    def sample_covariance(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of one sample: noise plus quantisation (resolution^2 / 12)."""
        return np.diag(self.sigma**2 + self.resolution**2 / 12.0)

    def measure(self, wrench: ArrayLike, rng: np.random.Generator) -> NDArray[np.float64]:
        """Readings of true wrenches ``wrench`` (n, 6) or (6,): bias, noise, quantise, clip.

        A reading beyond the range is clipped to it, as an ADC does; ``saturated`` finds it.
        """
        w = np.asarray(wrench, dtype=np.float64)
        normals = rng.standard_normal(w.shape)
        if self.phi and normals.ndim == 2:  # stationary AR(1), first sample from its law
            scale = math.sqrt(1.0 - self.phi**2)
            for t in range(1, len(normals)):
                normals[t] = self.phi * normals[t - 1] + scale * normals[t]
        return self.apply(w, normals)

    def apply(
        self, wrench: ArrayLike, normals: ArrayLike, drift: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """``measure`` with the unit noise given (same shape as ``wrench``; already
        coloured by ``phi`` for a correlated sensor), and ``drift`` (6,), N and N m, a bias
        beyond ``bias`` (a warm-up, a random walk) added as it is.

        For callers that draw their noise in blocks (one sample at a time at 1 kHz).
        """
        w = np.asarray(wrench, dtype=np.float64)
        if self.calibration is not None:
            w = w @ self.calibration.T
        reading = w + self.bias + normals * self.sigma  # a new array: changed in place below
        if drift is not None:
            reading += drift
        if self._quantised:
            q = self._step
            reading = np.where(self.resolution > 0, np.round(reading / q) * q, reading)
        if self._limited:
            np.maximum(reading, self._low, out=reading)
            np.minimum(reading, self.limit, out=reading)
        return reading

    def saturated(self, reading: ArrayLike) -> NDArray[np.bool_]:
        """Boolean mask, same shape as ``reading``: the value is at or beyond the range."""
        return np.abs(np.asarray(reading, dtype=np.float64)) >= self.limit
