"""The strain gauges' own errors: what a wrist F/T sensor adds to the load's wrench before
its calibration matrix maps the gauges to a wrench (``wrench_sim.sensor``).

Per axis a (fx fy fz tx ty tz; N and N m), of the true wrench x_a with the axis's range
r_a (the profile's ``limit_f``, ``limit_tau``):

- **Hysteresis**: a reading lags the way the load came (``com_core.sensing.hysteresis``:
  a Dahl model, rate-independent: the same path read slowly or fast gives the same
  readings), its band H_a the profile's ``hysteresis`` at no load over a full-range loop
  (the datasheet's band). A small excursion opens a narrow loop (its band grows with
  the square of the excursion) but reads with a gain off by b_a / (``SATURATION`` r_a)
  after each turn of the load, about 1.4 times the band's share of the range: where two
  branches part by H_a mid-range and meet at its ends, their slopes differ so. Datasheets
  state the full loop only; how minor loops go is this model's assumption.
- **Non-linearity**: N_a s_a(x_a / r_a), N_a the profile's ``nonlinearity`` (the
  largest deviation from the straight line through zero and full scale, the terminal-line
  definition of load-cell datasheets), s_a a shape of this sensor (drawn from its
  serial): a mix of the odd x (1 - x^2) and the even x^2 (1 - x^2), scaled so its largest
  value over the range is 1; zero at no load and at full scale.
- **Temperature**: the gain 1 + k_a dT(t), k_a drawn uniform in +-``sensitivity_drift``
  (1/K) per axis from the serial, dT(t) = ``warmup_kelvin`` (1 - exp(-t / warmup_time)):
  the sensor warms from power-on (sim time 0) with the bias's warm-up.

x_a (1 + k_a dT) + h_a + N_a s_a(x_a / r_a) is what the gauges give the calibration.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.sensing.hysteresis import SATURATION, dahl_step, edge
from com_core.sensing.sensor_profiles import SensorProfile

__all__ = ["GaugeErrors", "profile_gauges"]

_GRID = np.linspace(-1.0, 1.0, 2001)


def _odd(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x * (1.0 - x * x)


def _even(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x * x * (1.0 - x * x)


class GaugeErrors:
    """Hysteresis, non-linearity and the gain's temperature drift (module), one sample at
    a time; ``rng`` draws this sensor's shapes and coefficients, ``start`` where its
    hysteresis state starts, anywhere within its band (the loads before the run left it
    there; None: in the middle, a sensor never loaded)."""

    def __init__(
        self,
        profile: SensorProfile,
        rng: np.random.Generator,
        start: np.random.Generator | None = None,
    ) -> None:
        p = profile
        limits = np.array([p.limit_f] * 3 + [p.limit_tau] * 3, dtype=np.float64)
        if np.any(limits <= 0) and (p.hysteresis or p.nonlinearity):
            raise ValueError("hysteresis and non-linearity need the sensor's range")
        self.range = np.where(limits > 0, limits, np.inf)
        band = np.asarray(p.hysteresis or [0.0] * 6, dtype=np.float64)
        self.edge = edge(band)  # b per axis
        self.nonlinearity = np.asarray(p.nonlinearity or [0.0] * 6, dtype=np.float64)
        angle = rng.uniform(0.0, 2 * math.pi, 6)
        self._mix = np.stack([np.cos(angle), np.sin(angle)])  # (2, 6)
        peaks = np.abs(np.outer(_odd(_GRID), self._mix[0]) + np.outer(_even(_GRID), self._mix[1]))
        self._mix /= peaks.max(axis=0)
        self.coefficient = rng.uniform(-1.0, 1.0, 6) * p.sensitivity_drift
        self.warmup_kelvin, self.warmup_time = p.warmup_kelvin, p.warmup_time
        # where the loads before left the hysteresis state; None: never loaded
        self.state = np.zeros(6) if start is None else start.uniform(-1.0, 1.0, 6) * self.edge
        self._last: NDArray[np.float64] | None = None

    def shape(self, x: ArrayLike) -> NDArray[np.float64]:
        """(n, 6) or (6,): s_a at ``x`` (a fraction of each axis's range, within +-1)."""
        u = np.clip(np.asarray(x, dtype=np.float64), -1.0, 1.0)
        return self._mix[0] * _odd(u) + self._mix[1] * _even(u)

    def temperature(self, t: float) -> float:
        """dT (K) at sim time ``t`` (s) from power-on (warm at once for a ``warmup_time``
        of 0, as the bias's warm-up, ``sensor.BiasDrift``)."""
        if self.warmup_kelvin == 0.0:
            return 0.0
        warm = 1.0 - math.exp(-t / self.warmup_time) if self.warmup_time > 0 else 1.0
        return self.warmup_kelvin * warm

    def apply(self, wrench: ArrayLike, t: float = 0.0) -> NDArray[np.float64]:
        """What the gauges give (6,) for the true wrench (6,; N, N m) at sim time ``t``
        (s); calls in time order (the hysteresis remembers the load's path)."""
        x = np.asarray(wrench, dtype=np.float64)
        if self._last is not None:
            self.state = dahl_step(self.state, x - self._last, self.edge, SATURATION * self.range)
        self._last = x.copy()
        gain = 1.0 + self.coefficient * self.temperature(t)
        return x * gain + self.state + self.nonlinearity * self.shape(x / self.range)


def profile_gauges(
    profile: SensorProfile, rng: np.random.Generator, start: np.random.Generator
) -> GaugeErrors | None:
    """``profile``'s gauge errors drawn from ``rng`` (the serial's stream), the hysteresis
    state's start from ``start`` (the run's); None when it has none."""
    p = profile
    if not (p.hysteresis or p.nonlinearity or (p.sensitivity_drift and p.warmup_kelvin)):
        return None
    return GaugeErrors(p, rng, start)
