"""Smooth joint trajectories for the position-controlled arm: validation and interpolation.

A command is a list of waypoints with times from its start, as in
trajectory_msgs/JointTrajectory. It is followed by one quintic polynomial per segment: the
first segment starts from the controller's current set point, velocity and acceleration (so
replacing a running trajectory is continuous), every later waypoint is reached at rest (zero
velocity and acceleration). Rest-to-rest segments keep the jerk bounded, which keeps the
dynamic part of the sensed wrench small (an abrupt velocity step gives 37-50 N spikes on the
wrist sensor; a 0.5 rad/s quintic tilt stays below ~0.7 N).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["JointLimits", "QuinticTrajectory", "trajectory_from_command"]

_SAMPLES_PER_SEGMENT = 64
_AT_REST = 1e-9  # rad/s, rad/s^2: a last point's rates taken as zero (a period's rounding)


@dataclass(frozen=True)
class JointLimits:
    """Position and velocity limits of n joints (rad, rad/s)."""

    names: tuple[str, ...]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]


def _quintic_coefficients(
    p0: NDArray[np.float64],
    v0: NDArray[np.float64],
    a0: NDArray[np.float64],
    p1: NDArray[np.float64],
    duration: float,
    v1: NDArray[np.float64] | float = 0.0,
    a1: NDArray[np.float64] | float = 0.0,
) -> NDArray[np.float64]:
    """Coefficients (6, n) of p(s) = sum c_k s^k reaching p1 with velocity v1 and
    acceleration a1 (at rest by default) after ``duration`` s."""
    T = duration
    # p(s) = p0 + v0 s + a0 s^2 / 2 + c3 s^3 + c4 s^4 + c5 s^5; solve p(T) = p1, p'(T) = v1,
    # p''(T) = a1 for (c3, c4, c5).
    A = np.array(
        [
            [T**3, T**4, T**5],
            [3.0 * T**2, 4.0 * T**3, 5.0 * T**4],
            [6.0 * T, 12.0 * T**2, 20.0 * T**3],
        ]
    )
    rhs = np.stack([p1 - p0 - v0 * T - 0.5 * a0 * T**2, v1 - v0 - a0 * T, a1 - a0 + 0.0 * p0])
    c345 = np.linalg.solve(A, rhs)
    return np.vstack([p0, v0, 0.5 * a0, c345])


class QuinticTrajectory:
    """Piecewise-quintic joint trajectory in absolute time.

    Parameters
    ----------
    t0 : s; start time.
    start : (position, velocity, acceleration), each shape (n,); rad, rad/s, rad/s^2.
    times : shape (k,); s from ``t0``; strictly increasing, > 0.
    positions : shape (k, n); rad; the waypoints.
    velocities, accelerations : shape (k, n); rad/s, rad/s^2 at each waypoint (None: at
        rest; the last waypoint is always reached at rest).
    """

    def __init__(
        self,
        t0: float,
        start: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
        times: NDArray[np.float64],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64] | None = None,
        accelerations: NDArray[np.float64] | None = None,
    ) -> None:
        p, v, a = (np.asarray(x, dtype=np.float64) for x in start)
        rest = np.zeros_like(np.asarray(positions, dtype=np.float64))
        velocities = rest if velocities is None else velocities
        accelerations = rest if accelerations is None else accelerations
        self._knots = t0 + np.concatenate([[0.0], times])
        self._coefficients = []
        for i, target in enumerate(positions):
            duration = self._knots[i + 1] - self._knots[i]
            v1, a1 = velocities[i], accelerations[i]
            self._coefficients.append(_quintic_coefficients(p, v, a, target, duration, v1, a1))
            p, v, a = target, v1, a1
        self._final = np.asarray(positions[-1], dtype=np.float64)

    @property
    def start_time(self) -> float:
        """s; when the trajectory starts."""
        return float(self._knots[0])

    @property
    def end_time(self) -> float:
        """s; when the last waypoint is reached."""
        return float(self._knots[-1])

    def sample(
        self, t: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position, velocity and acceleration (each shape (n,)) at absolute time ``t`` (s)."""
        if t >= self._knots[-1]:
            zero = np.zeros_like(self._final)
            return self._final.copy(), zero, zero.copy()
        i = max(int(np.searchsorted(self._knots, t, side="right")) - 1, 0)
        s = t - self._knots[i]
        c = self._coefficients[i]
        powers = s ** np.arange(6)
        position = powers @ c
        velocity = (np.arange(1, 6) * powers[:5]) @ c[1:]
        acceleration = (np.array([2.0, 6.0, 12.0, 20.0]) * powers[:4]) @ c[2:]
        return position, velocity, acceleration

    def peak_speed(self) -> NDArray[np.float64]:
        """Largest |velocity| of each joint over the trajectory, rad/s, shape (n,)."""
        peak = np.zeros_like(self._final)
        for i in range(len(self._coefficients)):
            ts = np.linspace(self._knots[i], self._knots[i + 1], _SAMPLES_PER_SEGMENT)
            for t in ts[:-1]:
                peak = np.maximum(peak, np.abs(self.sample(t)[1]))
        return peak


def trajectory_from_command(
    joint_names: Sequence[str],
    times: ArrayLike,
    positions: ArrayLike,
    limits: JointLimits,
    t_now: float,
    start: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    velocities: ArrayLike | None = None,
    accelerations: ArrayLike | None = None,
) -> QuinticTrajectory:
    """Check a joint trajectory command and build the trajectory that follows it.

    Parameters
    ----------
    joint_names : names of the commanded joints, any subset of ``limits.names`` in any order.
    times : shape (k,); s from now; strictly increasing, the first >= 0 (0 only for a
        waypoint at the current set point).
    positions : shape (k, len(joint_names)); rad.
    limits : the arm's joints, in the order of ``start``.
    t_now : s; current time.
    start : current set point (position, velocity, acceleration), each shape (n,), in the
        order of ``limits.names``. Joints not commanded hold their set point.
    velocities, accelerations : like ``positions``, rad/s and rad/s^2 at each waypoint
        (JointTrajectoryPoint's; None or empty: each waypoint at rest); the last waypoint
        must be at rest.

    Returns
    -------
    The trajectory over all n joints.

    Raises
    ------
    ValueError with a message saying what is wrong: unknown or repeated joint names, no
    waypoints, wrong lengths, NaN/inf, non-monotonic times, positions outside the joint
    limits, or a speed above the joint's velocity limit.
    """
    names = list(joint_names)
    if not names:
        raise ValueError("no joint names")
    unknown = [name for name in names if name not in limits.names]
    if unknown:
        raise ValueError(f"unknown joint names {unknown}; expected a subset of {limits.names}")
    if len(set(names)) != len(names):
        raise ValueError(f"repeated joint names in {names}")
    times = np.asarray(times, dtype=np.float64)
    if times.ndim != 1 or times.size == 0:
        raise ValueError("the trajectory has no points")
    rows = [np.asarray(row, dtype=np.float64) for row in positions]
    if len(rows) != times.size:
        raise ValueError(f"{times.size} times but {len(rows)} position rows")
    for i, row in enumerate(rows):
        if row.shape != (len(names),):
            raise ValueError(
                f"point {i} has {row.size} positions for {len(names)} joint names {names}"
            )
    commanded = np.array(rows)
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(commanded))):
        raise ValueError("NaN or inf in times or positions")
    if times[0] < 0.0 or np.any(np.diff(times) <= 0.0):
        raise ValueError(f"time_from_start must be >= 0 and strictly increasing, got {times}")
    index = [limits.names.index(name) for name in names]
    lower, upper = limits.lower[index], limits.upper[index]
    outside = (commanded < lower) | (commanded > upper)
    if np.any(outside):
        point, joint = np.argwhere(outside)[0]
        raise ValueError(
            f"{names[joint]} = {commanded[point, joint]:.4f} rad at point {point} is outside "
            f"its limits [{lower[joint]:.4f}, {upper[joint]:.4f}] rad"
        )
    full = np.tile(np.asarray(start[0], dtype=np.float64), (times.size, 1))
    full[:, index] = commanded
    rates = [
        _waypoint_rates(name, x, commanded.shape, index, len(limits.names))
        for name, x in (("velocities", velocities), ("accelerations", accelerations))
    ]
    if times[0] == 0.0:
        if np.max(np.abs(full[0] - start[0])) > 1e-3:
            raise ValueError("a point at time 0 must equal the current position (within 1 mrad)")
        full, times, rates = full[1:], times[1:], [r[1:] for r in rates]
        if times.size == 0:
            times, full = np.array([1e-3]), np.asarray(start[0], dtype=np.float64)[None, :]
            rates = [np.zeros_like(full), np.zeros_like(full)]
    trajectory = QuinticTrajectory(t_now, start, times, full, *rates)
    too_fast = trajectory.peak_speed() > limits.velocity
    if np.any(too_fast):
        joint = limits.names[int(np.argmax(too_fast))]
        raise ValueError(
            f"unreachable: {joint} would need more than its velocity limit "
            f"{limits.velocity[int(np.argmax(too_fast))]:.3f} rad/s; give it more time"
        )
    return trajectory


def _waypoint_rates(
    name: str, rates: ArrayLike | None, shape: tuple[int, int], index: list[int], n: int
) -> NDArray[np.float64]:
    """The waypoints' ``name`` (velocities or accelerations) over all n joints, shape (k, n):
    zero when None or empty; ValueError unless ``shape`` (k, joints), finite and zero at
    the last waypoint."""
    out = np.zeros((shape[0], n))
    if rates is None or np.size(rates) == 0:
        return out
    given = np.asarray(rates, dtype=np.float64)
    if given.shape != shape:
        raise ValueError(f"{name}: {given.shape} values for {shape} positions")
    if not np.all(np.isfinite(given)):
        raise ValueError(f"NaN or inf in {name}")
    if np.any(np.abs(given[-1]) > _AT_REST):
        raise ValueError(f"{name} at the last point must be 0 (the arm ends at rest)")
    out[:, index] = given
    out[-1] = 0.0
    return out
