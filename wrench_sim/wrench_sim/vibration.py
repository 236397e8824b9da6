"""The arm's structural vibration: lightly damped modes that every move excites and that ring
on into the next static window.

Each mode is an oscillator in the world frame (3 axes alike), x'' + 2 zeta w x' + w^2 x = 0,
x the structure's deflection at the sensor. A move excites it when it ends (the arm's drives
stop the structure, which carries on): from then the load beyond the sensor feels the extra
acceleration x'', of amplitude ``gain`` times the move's peak speed at the sensor origin,
along the direction the sensor last moved, shared equally by the modes, decaying at
zeta w. The sensor reads the load's reaction: f = -m R^T x'', tau = c x f, with m and c the
load's mass and COM (``ft_sensor``). Driven by the moves alone, not by each step's velocity:
pybullet's links jolt when a contact closes (a grasp), which an arm's servo holds, and a
differenced velocity passes every jolt on. Semi-implicit Euler at the physics step (stable
for w dt < 2; at 1 kHz and 27 Hz the frequency is within 0.5 %).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["Vibration"]


class Vibration:
    """Modes (frequency Hz, damping ratio) that each move's end excites; ``gain`` (1/s):
    the extra acceleration (m/s^2) at a move's end per m/s of its peak speed."""

    def __init__(self, modes: Sequence[tuple[float, float]], dt: float, gain: float = 1.0) -> None:
        for hz, zeta in modes:
            if not (math.isfinite(hz) and 0.0 < hz < 0.3 / dt):
                raise ValueError(f"vibration mode {hz} Hz must be in (0, {0.3 / dt:g}) Hz")
            if not 0.0 <= zeta < 1.0:
                raise ValueError(f"vibration damping {zeta} must be in [0, 1)")
        self.modes = [(2.0 * math.pi * hz, zeta) for hz, zeta in modes]
        # w^2 and 2 zeta w, a column each for the (modes, 3) state
        self._stiffness = np.array([w * w for w, _ in self.modes]).reshape(-1, 1)
        self._damping = np.array([2.0 * zeta * w for w, zeta in self.modes]).reshape(-1, 1)
        self.dt = dt
        self.gain = gain
        self._x = np.zeros((len(modes), 3))
        self._v = np.zeros((len(modes), 3))
        self._peak = 0.0
        self._direction = np.zeros(3)

    def step(self, velocity: NDArray[np.float64], moving: bool) -> NDArray[np.float64]:
        """The structure's extra acceleration (3,), m/s^2, world frame, after one step in
        which the sensor origin's velocity became ``velocity`` (3,), m/s, and the arm was
        ``moving`` along a trajectory (its end excites the modes)."""
        speed = float(np.linalg.norm(velocity))
        if moving:
            self._peak = max(self._peak, speed)
            if speed > 1e-6:
                self._direction = velocity / speed
        elif self._peak > 0.0:  # the move just ended
            amplitude = self.gain * self._peak / max(len(self.modes), 1)
            for k, (w, _) in enumerate(self.modes):
                self._v[k] += amplitude / w * self._direction
            self._peak = 0.0
        accel = -self._damping * self._v - self._stiffness * self._x  # (modes, 3)
        self._v += accel * self.dt
        self._x += self._v * self.dt
        return accel.sum(axis=0)
