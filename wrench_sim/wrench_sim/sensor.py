"""The wrist F/T sensor's electronics: com_core's SensorModel with a seeded random stream.

The physics hands over the true wrench (load on the sensor, frame ``ft_sensor``, already
through the 2-tap anti-alias filter, see ``physics``); this stage adds bias and Gaussian noise,
quantises and clips exactly as ``com_core.wrench_model.SensorModel.measure`` does, one sample
per call, and remembers whether the last reading saturated.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.wrench_model import SensorModel

__all__ = ["WrenchSensor", "random_streams"]

_STREAMS = ("object", "sensor", "slip")
_BLOCK = 1000  # samples of unit normals drawn at once


def random_streams(seed: int) -> dict[str, np.random.Generator]:
    """Independent generators for the object draw, the sensor noise and the grasp shifts.

    Separate streams keep the noise sequence of a seed the same whether or not the COM offset
    is drawn or shifts are on.
    """
    children = np.random.SeedSequence(seed).spawn(len(_STREAMS))
    return {
        name: np.random.Generator(np.random.PCG64(child))
        for name, child in zip(_STREAMS, children, strict=True)
    }


class WrenchSensor:
    """Turns true wrenches into sensor readings, deterministically for a generator's seed.

    ``read`` gives exactly what ``model.measure(wrench, rng)`` gives call after call (the
    tests check it), but draws the unit normals in blocks of 1000 samples, which matters
    at 5 kHz.

    Parameters
    ----------
    model : noise sigma, bias, resolution and range per axis; may be replaced at any time.
    rng : the noise stream (``random_streams(seed)["sensor"]``).
    """

    def __init__(self, model: SensorModel, rng: np.random.Generator) -> None:
        self.model = model
        self._rng = rng
        self._normals = np.empty((0, 6))
        self._next = 0
        self.saturated = False

    def read(self, true_wrench: ArrayLike) -> NDArray[np.float64]:
        """One reading (6,) of the true wrench (6,); N and N m; frame ``ft_sensor``.

        ``SensorModel.apply`` with the next block-drawn normals; sets ``saturated`` when any
        axis reached its range.
        """
        if self._next == len(self._normals):
            self._normals = self._rng.standard_normal((_BLOCK, 6))
            self._next = 0
        normal = self._normals[self._next]
        self._next += 1
        reading = self.model.apply(true_wrench, normal)
        self.saturated = bool(self.model.saturated(reading).any())
        return reading
