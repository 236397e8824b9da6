"""The wrist F/T sensor's electronics: com_core's SensorModel with a seeded random stream,
one sample per call, with the parts of a real sensor that depend on time.

Frame ``ft_sensor`` has the axes and origin of the robot configuration's ``sensor_frame``
(Panda: ``panda_hand``; xArm6: ``xarm_gripper_base_link``), the child link of the fixed joint
at the flange (``panda_hand_joint``; ``gripper_fix``). The sensor reads the wrench the load
beyond it (every link after that joint: hand or gripper base, fingers, and a grasped object)
exerts on it, expressed in ``ft_sensor``: a static load of mass m with COM p gives
f = m g_s, tau = p x f (docs/estimation.md, Conventions).

The physics hands over that true wrench, already through the 2-tap anti-alias filter
(``wrench_sim.load``, which reads it from pybullet's joint sensor). This stage filters it
with the sensor's own first-order low-pass (``SensorModel.correlation_time``; the signal is delayed
and smoothed as the noise is coloured), adds the bias (the static one, a warm-up toward a
final offset and a random walk, from sim time 0: the sensor is powered when the sim starts)
and the noise (AR(1) at the publish rate), calibrates, quantises and clips as
``com_core.sensing.wrench_model.SensorModel.apply`` does, and remembers whether the last reading
saturated. Figures: ``com_core.sensing.sensor_profiles``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.sensing.sensor_profiles import SensorProfile
from com_core.sensing.wrench_model import SensorModel, calibration_matrix
from wrench_sim.gauges import GaugeErrors, profile_gauges
from wrench_sim.joint_torques import JointTorqueEstimate, profile_joint_torques

if TYPE_CHECKING:
    from wrench_sim.physics import ArmWorld

__all__ = [
    "BiasDrift",
    "WrenchSensor",
    "profile_calibration",
    "profile_drift",
    "profile_sensor",
    "random_streams",
]

_STREAMS = (
    "object",
    "sensor",
    "slip",
    "calibration",
    "drift",
    "gauges",
    "joint_torques",
    "reference",
    "hysteresis",
)
_BLOCK = 1000  # samples of unit normals drawn at once


def random_streams(seed: int) -> dict[str, np.random.Generator]:
    """Independent generators for the object draw, the sensor noise, the grasp shifts, the
    calibration error, the bias's drift, the gauges' errors (``wrench_sim.gauges``), the
    arm model's error of a wrench estimated from the joint torques
    (``wrench_sim.joint_torques``), a reference weight's error of its stated mass
    (``objects.reference_weight_mass``) and where the gauges' hysteresis state starts.

    Separate streams keep the noise sequence of a seed the same whether or not the COM offset
    is drawn, shifts are on or the sensor drifts (later names were appended: SeedSequence's
    children keep their order).
    """
    children = np.random.SeedSequence(seed).spawn(len(_STREAMS))
    return {
        name: np.random.Generator(np.random.PCG64(child))
        for name, child in zip(_STREAMS, children, strict=True)
    }


class BiasDrift:
    """A bias that warms up and wanders: per axis A (1 - exp(-t / T)) toward a final offset
    A drawn N(0, ``warmup``^2), plus a random walk of ``random_walk`` per sqrt(s); N, N m.

    ``at(t)`` must be called with non-decreasing times (s). ``warmup`` and ``random_walk``
    are read at construction (whether the bias moves at all)."""

    def __init__(
        self,
        warmup: ArrayLike,
        warmup_time: float,
        random_walk: ArrayLike,
        rng: np.random.Generator,
    ) -> None:
        self.final = rng.standard_normal(6) * np.asarray(warmup, dtype=np.float64)
        self.warmup_time = warmup_time
        self.random_walk = np.asarray(random_walk, dtype=np.float64)
        self._rng = rng
        self._walk = np.zeros(6)
        self._time = 0.0
        # nothing to warm up or wander (the white and ideal profiles): every reading's drift
        # is final * warm + walk = (+-0) * warm + 0 = +0 on each axis, at any time
        self._walking = bool(self.random_walk.any())
        self._zeros = None if self.final.any() or self._walking else np.zeros(6)
        if self._zeros is not None:
            self._zeros.flags.writeable = False

    def at(self, t: float) -> NDArray[np.float64]:
        """The drift (6,) at sim time ``t`` (s); N, N m; a new array but for a sensor
        without warm-up or random walk, whose zeros are shared (read-only)."""
        if self._zeros is not None:
            self._time = max(self._time, t)
            return self._zeros
        dt = t - self._time
        if dt > 0 and self._walking:
            self._walk += self._rng.standard_normal(6) * self.random_walk * math.sqrt(dt)
        self._time = max(self._time, t)
        warm = 1.0 - math.exp(-t / self.warmup_time) if self.warmup_time > 0 else 1.0
        return self.final * warm + self._walk


class WrenchSensor:
    """Turns true wrenches into sensor readings, deterministically for a generator's seed.

    For a white sensor without drift ``read`` gives exactly what
    ``model.measure(wrench, rng)`` gives call after call (the tests check it), but draws
    the unit normals in blocks of 1000 samples, which matters at 5 kHz; a correlated one
    colours them as ``measure`` does.

    Parameters
    ----------
    model : noise sigma, correlation, calibration, bias, resolution and range per axis; may
        be replaced at any time.
    rng : the noise stream (``random_streams(seed)["sensor"]``).
    drift : the bias's warm-up and random walk (None: none).
    gauges : hysteresis, non-linearity and the gain's temperature drift, applied to the
        true wrench first (None: none).
    joint_torques : for a wrench the arm estimates from its joint torques, the error its
        model adds (``wrench_sim.joint_torques.wrench_in`` adds it before ``read``; None:
        a wrist sensor).
    """

    def __init__(
        self,
        model: SensorModel,
        rng: np.random.Generator,
        drift: BiasDrift | None = None,
        gauges: GaugeErrors | None = None,
        joint_torques: JointTorqueEstimate | None = None,
    ) -> None:
        self.model = model
        self.drift = drift
        self.gauges = gauges
        self.joint_torques = joint_torques
        self._rng = rng
        self._normals = np.empty((0, 6))
        self._next = 0
        self._coloured: NDArray[np.float64] | None = None
        self._signal: NDArray[np.float64] | None = None
        self.saturated = False

    @property
    def model(self) -> SensorModel:
        """The sensor's model; set it to change the sensor from the next reading on."""
        return self._model

    @model.setter
    def model(self, model: SensorModel) -> None:
        self._model = model
        self._phi = model.phi  # the model is frozen: its coefficient once, not per reading
        # no finite range: |reading| >= inf only where the reading is infinite
        self._unlimited = bool(np.all(model.limit == np.inf))

    def read(self, true_wrench: ArrayLike, t: float = 0.0) -> NDArray[np.float64]:
        """One reading (6,) of the true wrench (6,) at sim time ``t`` (s); N and N m; frame
        ``ft_sensor``. Sets ``saturated`` when any axis reached its range."""
        if self._next == len(self._normals):
            self._normals = self._rng.standard_normal((_BLOCK, 6))
            self._next = 0
        normal = self._normals[self._next]
        self._next += 1
        model = self._model
        signal = np.asarray(true_wrench, dtype=np.float64)
        if self.gauges is not None:
            signal = self.gauges.apply(signal, t)
        phi = self._phi
        if phi:
            if self._coloured is None or self._signal is None:
                self._coloured, self._signal = normal.copy(), signal.copy()
            else:
                self._coloured = phi * self._coloured + math.sqrt(1.0 - phi * phi) * normal
                self._signal = phi * self._signal + (1.0 - phi) * signal
            normal, signal = self._coloured, self._signal
        else:
            self._coloured = self._signal = None
        drift = None if self.drift is None else self.drift.at(t)
        reading = model.apply(signal, normal, drift)
        if self._unlimited:  # model.saturated(reading).any(), in one pass fewer
            self.saturated = bool(np.isinf(reading).any())
        else:
            self.saturated = bool(model.saturated(reading).any())
        return reading


def profile_calibration(profile: SensorProfile, serial: int) -> NDArray[np.float64] | None:
    """The calibration (6, 6) of the sensor ``serial`` with ``profile``'s accuracy, drawn
    from the serial's stream (None: a perfect one)."""
    p = profile
    if p.calibration_accuracy <= 0:
        return None
    stream = random_streams(serial)["calibration"]
    return calibration_matrix(p.calibration_accuracy, p.limit_f, p.limit_tau, stream)


def profile_drift(profile: SensorProfile, rng: np.random.Generator) -> BiasDrift:
    """``profile``'s warm-up and random walk of the bias, drawn from ``rng``."""
    p = profile
    walk = [p.random_walk_f] * 3 + [p.random_walk_tau] * 3
    return BiasDrift([p.warmup_f] * 3 + [p.warmup_tau] * 3, p.warmup_time, walk, rng)


def profile_sensor(
    profile: SensorProfile,
    seed: int,
    serial: int,
    rate_hz: float = 1000.0,
    world: ArmWorld | None = None,
) -> WrenchSensor:
    """A sensor of every part of ``profile`` (``com_core.sensing.sensor_profiles``),
    publishing at ``rate_hz``: its drift, noise and hysteresis's start drawn from
    ``seed``'s streams, its calibration, gauges (and, of a wrench estimated from the joint
    torques, ``world``'s arm model's error) from ``serial``'s, as the simulator draws them
    (for offline studies and tests; the node builds its model from its parameters)."""
    p, streams = profile, random_streams(seed)
    model = SensorModel.from_scalars(
        p.sigma_f, p.sigma_tau, resolution_f=p.resolution_f, resolution_tau=p.resolution_tau,
        limit_f=p.limit_f, limit_tau=p.limit_tau, rate_hz=rate_hz,
        correlation_time=p.correlation_time, calibration=profile_calibration(p, serial),
    )  # fmt: skip
    drift = profile_drift(p, streams["drift"])
    own = random_streams(serial)
    gauges = profile_gauges(p, own["gauges"], streams["hysteresis"])
    arm = None if world is None else profile_joint_torques(p, world, own["joint_torques"])
    return WrenchSensor(model, streams["sensor"], drift, gauges, arm)
