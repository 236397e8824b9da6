"""A strain-gauge sensor's hysteresis: the model the simulator reads through
(``wrench_sim.gauges``) and the share of it the estimator weighs.

Per axis a (N or N m) of range r_a, a state h_a moves toward -b_a while the load x_a
rises and +b_a while it falls by the fraction 1 - exp(-|dx_a| / (``SATURATION`` r_a)) of
the way with each change dx_a (a Dahl model, rate-independent); b_a is set so that a loop
over the whole range opens the datasheet's band H_a at no load (``edge``). A change dx_a
moves a state from the middle of its band by b_a |dx_a| / (SATURATION r_a) (at most
b_a), toward the side the load came from; from the far edge, after the load turned, by up
to twice that, and from the near edge not at all.

Along a motion the load turns after every swing, and each excursion after a turn reads
short by a fraction of it (``Hysteresis.gain_deficit``): a gain below one, the same sign
on every sensor. The fit in motion weighs it as the calibration's error on each axis's
own gain (``sensing.calibration``, ``Calibration.with_gain_spread``;
``motion_solution.motion_calibration``), zero-mean, its spread the largest deficit,
2 b / (``SATURATION`` r): a swing's turn leaves the state near the far edge.

The estimator weighs it per static window (``Hysteresis.window_sigma``): the change of
load since the window before it (in time) moves the state by a sigma of the middle's
move, and the state keeps what it moved (``FitSetup._with_hysteresis`` sums the increments
so far, a persistent nuisance). The sign follows the direction the load came from, which
the fit's model does not carry; the sum over many changes can exceed the band, which the
state cannot: conservative there.
"""

from __future__ import annotations

import math
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

    def window_sigma(self, means: ArrayLike) -> NDArray[np.float64]:
        """(n, 6): each window's sigma (N, N m) for windows whose ``means`` (n, 6) follow
        one another in time (module); the first is taken as after a change to its load
        from none."""
        m = np.asarray(means, dtype=np.float64).reshape(-1, 6)
        b = edge(self.band)
        change = np.abs(np.diff(m, axis=0, prepend=np.zeros((1, 6))))
        scale = SATURATION * np.asarray(self.full_scale, dtype=np.float64)
        return np.minimum(b * change / scale, b)

    def gain_deficit(self) -> NDArray[np.float64]:
        """(6,): how much short of the load's change a small excursion reads per axis
        when the state starts from the middle of its band, b / (``SATURATION`` r)
        (module; from the far edge, after a turn, up to twice it; from the near edge,
        none): a gain below one along a motion, the same sign on every sensor."""
        return edge(self.band) / (SATURATION * np.asarray(self.full_scale, dtype=np.float64))
