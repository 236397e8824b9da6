"""A strain-gauge sensor's hysteresis: the model the simulator reads through
(``wrench_sim.gauges``) and what of it the estimator takes off and weighs.

Per axis a (N or N m) of range r_a, a state h_a moves toward -b_a while the load x_a
rises and +b_a while it falls by the fraction 1 - exp(-|dx_a| / (``SATURATION`` r_a)) of
the way with each change dx_a (a Dahl model, rate-independent); b_a is set so that a loop
over the whole range opens the datasheet's band H_a at no load (``edge``). A change dx_a
moves a state from the middle of its band by b_a |dx_a| / (SATURATION r_a) (at most
b_a), toward the side the load came from; from the far edge, after the load turned, by up
to twice that, and from the near edge not at all.

So for loads that stay well within SATURATION r_a of one another, h_a = -d_a x_a + c_a to
first order, d_a = b_a / (SATURATION r_a) (``Hysteresis.gain_deficit``): the gauges read
the load with a gain 1 - d_a below one, the same sign on every sensor, and c_a, set by the
load's history, is a constant the fits' bias takes up. The estimator takes the gain off
every reading (``gain``; ``sensing.calibration.reading_correction``) and weighs what the
first order leaves. Along a motion, ``residual_share``: from the middle of the band the
slope of h_a moves by d_a u / 2 over an excursion u = span / (SATURATION r_a), and a
state off the middle by h moves it by d_a h / b_a, h within +-d_a span / 2 once the loads
have swung over their span; the share min(1, u / 2) of d_a weighs either, as a spread of
each axis's own gain (``motion_solution.motion_calibration``,
``Calibration.with_gain_spread``). At rest the path between two windows is the arm's
move, whose transients turn the load on the way (an acceleration, the grasp's lift), and
a turn moves the state from the middle by up to twice the first order's: each static
window carries the state's whole move with its change of load (``Hysteresis.window_sigma``)
about the gain's, a state that keeps what it moved (``FitSetup.with_hysteresis`` sums the
increments so far, a persistent nuisance).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SATURATION", "Hysteresis", "edge"]

SATURATION = 0.5
"""The load change, as a fraction of the range, over which the hysteresis state moves
1 - 1/e of its way to the band's edge."""


def _loop_opening(saturation: float) -> float:
    """The band at no load of a steady loop over the whole range, per unit of b: the state
    falls from -a to +a over 2 r (a = b tanh(1 / saturation)), and at no load it has come
    r of that way, so the opening is 2 (b - (b + a) exp(-1 / saturation))."""
    decay = math.exp(-1.0 / saturation)
    return 2.0 * (1.0 - (1.0 + math.tanh(1.0 / saturation)) * decay)


def edge(band: ArrayLike) -> NDArray[np.float64]:
    """b per axis (6,): the state's bound for a full-range loop's ``band`` H (6,)."""
    return np.asarray(band, dtype=np.float64) / _loop_opening(SATURATION)


@dataclass(frozen=True)
class Hysteresis:
    """A sensor's hysteresis as the estimator weighs it: the ``band`` H (6,; N, N m) a
    full-range loop opens per axis (a datasheet's "hysteresis, % FS" times the range) and
    the ``full_scale`` r (6,)."""

    band: tuple[float, ...]
    full_scale: tuple[float, ...]

    @classmethod
    def stated(cls, band: Sequence[float], force: float, torque: float) -> Hysteresis | None:
        """The hysteresis of a stated ``band`` (6,) over a sensor's full scales in
        ``force`` (N, the three forces') and ``torque`` (N m); None for a band of zeros."""
        if not any(band):
            return None
        return cls(tuple(band), (force,) * 3 + (torque,) * 3)

    def gain_deficit(self) -> NDArray[np.float64]:
        """(6,): d = b / (``SATURATION`` r) per axis, how much short of the load's change a
        small excursion reads when the state starts from the middle of its band (module;
        from the far edge, after a turn, up to twice it; from the near edge, none)."""
        return edge(self.band) / (SATURATION * np.asarray(self.full_scale, dtype=np.float64))

    def gain(self) -> NDArray[np.float64]:
        """(6,): 1 - d, the gain the gauges read a load's changes with (module)."""
        return 1.0 - self.gain_deficit()

    def residual_share(self, loads: ArrayLike) -> NDArray[np.float64]:
        """(6,): the share of d left uncertain once the gain is taken off, for loads
        (n, 6; N, N m) spanning what ``loads`` span: min(1, u / 2), u = span /
        (``SATURATION`` r) (module)."""
        x = np.asarray(loads, dtype=np.float64).reshape(-1, 6)
        span = np.ptp(x, axis=0) if len(x) else np.zeros(6)
        return np.minimum(span / (2.0 * SATURATION * np.asarray(self.full_scale)), 1.0)

    def window_sigma(self, means: ArrayLike) -> NDArray[np.float64]:
        """(n, 6): each window's sigma (N, N m), the state's whole move with its change of
        load dx, min(d |dx|, b), for windows whose ``means`` (n, 6) follow one another in
        time (module); the first is taken as after a change to its load from none."""
        m = np.asarray(means, dtype=np.float64).reshape(-1, 6)
        change = np.abs(np.diff(m, axis=0, prepend=np.zeros((1, 6))))
        return np.minimum(self.gain_deficit() * change, edge(self.band))
