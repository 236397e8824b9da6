"""Joint trajectories as ros2_control's joint_trajectory_controller (Jazzy) follows them:
validation and interpolation.

A command is a trajectory_msgs/JointTrajectory: waypoints with times from its start
(``header.stamp``; 0: when it arrives) and, per point, positions and optionally velocities
and accelerations. As in the controller (``Trajectory::sample``):

- a new command replaces the running one **when it arrives**; the state at arrival (the
  measured positions and velocities: no acceleration interface) is kept;
- until the first point's time (stamp + time_from_start), the set point runs from the
  state at arrival to the first point: a command stamped in the future moves the arm at
  once, slowly, unless its first point is where the arm rests;
- between two points the interpolation is what both carry: positions only, linear (a
  velocity step at each point); with velocities, cubic; with velocities and
  accelerations, quintic (continuous acceleration);
- after the last point, the set point holds it.

A positions-only point therefore jolts the arm (a velocity step gives 37-50 N spikes on the
wrist sensor); a rest-to-rest move of two points with zero velocities and accelerations is
one quintic (a 0.5 rad/s tilt stays below ~0.7 N).
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["JointLimits", "SplineTrajectory", "State", "trajectory_from_command"]

_SAMPLES_PER_SEGMENT = 64
_AT_REST = 1e-9  # rad/s: a last point's velocity taken as zero (a period's rounding)
JUMP_TOLERANCE = 1e-3
"""rad: how far the set point may start from the measured position; a command whose set
point at arrival lies farther (a point at time 0, or a stamp in the past) is refused: the
controller would jump there."""

State = tuple[NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None]
"""(positions, velocities or None, accelerations or None), each shape (n,): a point of a
trajectory, with what it carries."""


@dataclass(frozen=True)
class JointLimits:
    """Position and velocity limits of n joints (rad, rad/s)."""

    names: tuple[str, ...]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]


def interpolate(
    a: State, b: State, duration: float, s: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Position, velocity and acceleration ``s`` s after point ``a`` on the way to point
    ``b`` reached ``duration`` s after it: linear, cubic or quintic by what both points
    carry (the controller's ``interpolate_between_points``); ``s`` outside [0, duration]
    clamps to an end, linearly."""
    if s < 0.0 or s > duration:
        return _evaluate(_coefficients(a, b, duration, linear=True), min(max(s, 0.0), duration))
    return _evaluate(_coefficients(a, b, duration), s)


def _coefficients(a: State, b: State, T: float, linear: bool = False) -> NDArray[np.float64]:
    """The polynomial from point ``a`` to point ``b`` over ``T`` s, shape (m, n): row i
    multiplies s^i; linear (m = 2), cubic (4) or quintic (6) by what both points carry, or
    linear if ``linear``."""
    p0, v0, a0 = a
    p1, v1, a1 = b
    has_velocity = not linear and v0 is not None and v1 is not None
    has_acceleration = has_velocity and a0 is not None and a1 is not None
    if not has_velocity:
        slope = (p1 - p0) / T if T > 0.0 else np.zeros_like(p0)
        return np.array([p0, slope], dtype=np.float64)
    if not has_acceleration:
        return np.array(
            [p0, v0, (3 * (p1 - p0) - (2 * v0 + v1) * T) / T**2,
             (2 * (p0 - p1) + (v0 + v1) * T) / T**3],
            dtype=np.float64,
        )  # fmt: skip
    return np.array(
        [
            p0,
            v0,
            0.5 * a0,
            (20 * (p1 - p0) - (12 * v0 + 8 * v1) * T - (3 * a0 - a1) * T**2) / (2 * T**3),
            (30 * (p0 - p1) + (16 * v0 + 14 * v1) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4),
            (12 * (p1 - p0) - 6 * (v0 + v1) * T - (a0 - a1) * T**2) / (2 * T**5),
        ],
        dtype=np.float64,
    )


def _evaluate(
    c: NDArray[np.float64], s: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Position, velocity and acceleration at ``s`` of the polynomial of ``_coefficients``:
    one product of the powers of ``s`` and their derivatives (3, m) with ``c``."""
    m = len(c)
    powers = [1.0, s]
    for _ in range(m - 2):
        powers.append(powers[-1] * s)
    rows = np.zeros((3, m))
    rows[0] = powers
    rows[1, 1:] = [i * powers[i - 1] for i in range(1, m)]
    rows[2, 2:] = [i * (i - 1) * powers[i - 2] for i in range(2, m)]
    position, velocity, acceleration = rows @ c
    return position, velocity, acceleration


class SplineTrajectory:
    """A joint trajectory over all n joints in absolute time (see module).

    Parameters
    ----------
    start_time : s; the trajectory's start (its header stamp, or its arrival for 0).
    arrival : (s, State); when it arrived and the state then (positions, velocities).
    times : shape (k,); s from ``start_time``; strictly increasing, >= 0.
    points : k States, each over the n joints.
    """

    def __init__(
        self,
        start_time: float,
        arrival: tuple[float, State],
        times: NDArray[np.float64],
        points: Sequence[State],
    ) -> None:
        self._arrival_time, self._arrival = arrival
        self._knots = start_time + np.asarray(times, dtype=np.float64)
        self._points = list(points)
        self._final = np.asarray(points[-1][0], dtype=np.float64)
        self._knot_list = self._knots.tolist()
        self._segments: dict[int, NDArray[np.float64]] = {}

    @property
    def arrival_time(self) -> float:
        """s; when the trajectory arrived (and started to move the arm)."""
        return self._arrival_time

    @property
    def end_time(self) -> float:
        """s; when the last waypoint is reached."""
        return float(self._knots[-1])

    @property
    def final(self) -> NDArray[np.float64]:
        """rad, shape (n,); the last waypoint."""
        return self._final.copy()

    def sample(
        self, t: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position, velocity and acceleration (each shape (n,)) of the set point at
        absolute time ``t`` (s)."""
        if t >= self._knots[-1]:
            zero = np.zeros_like(self._final)
            return self._final.copy(), zero, zero.copy()
        knots = self._knot_list
        if t < knots[0]:  # segment -1: from the state at arrival to the first point
            i, start = -1, self._arrival_time
        else:
            i = bisect.bisect_right(knots, t) - 1
            start = knots[i]
        duration = knots[i + 1] - start
        s = t - start
        if s < 0.0 or s > duration:
            start_point = self._arrival if i < 0 else self._points[i]
            return interpolate(start_point, self._points[i + 1], duration, s)
        c = self._segments.get(i)
        if c is None:  # each segment's polynomial once, on its first sample
            start_point = self._arrival if i < 0 else self._points[i]
            c = self._segments[i] = _coefficients(start_point, self._points[i + 1], duration)
        return _evaluate(c, s)

    def peak_speed(self) -> NDArray[np.float64]:
        """Largest |velocity| of each joint from arrival to the end, rad/s, shape (n,)."""
        peak = np.zeros_like(self._final)
        knots = np.concatenate([[self._arrival_time], self._knots])
        for t0, t1 in itertools.pairwise(knots):
            for t in np.linspace(t0, t1, _SAMPLES_PER_SEGMENT)[:-1]:
                peak = np.maximum(peak, np.abs(self.sample(t)[1]))
        return peak


def trajectory_from_command(
    joint_names: Sequence[str],
    times: ArrayLike,
    positions: ArrayLike,
    limits: JointLimits,
    stamp: float,
    now: float,
    measured: tuple[ArrayLike, ArrayLike],
    velocities: Sequence[ArrayLike | None] | None = None,
    accelerations: Sequence[ArrayLike | None] | None = None,
) -> SplineTrajectory:
    """Check a joint trajectory command arriving at ``now`` and build the trajectory that
    follows it (see module).

    Parameters
    ----------
    joint_names : names of the commanded joints, any subset of ``limits.names`` in any order.
    times : shape (k,); s from the start (time_from_start); >= 0, strictly increasing.
    positions : shape (k, len(joint_names)); rad.
    limits : the arm's joints, in the order of ``measured``.
    stamp : s; the header stamp (0: start now).
    now : s; the arrival time.
    measured : (positions rad, velocities rad/s) of the n joints now, in the order of
        ``limits.names``. Joints not commanded hold their position at arrival.
    velocities, accelerations : per point, like a row of ``positions`` (rad/s, rad/s^2),
        or None / empty where the point carries none (JointTrajectoryPoint's); None: no
        point carries any.

    Returns
    -------
    The trajectory over all n joints.

    Raises
    ------
    ValueError with a message saying what is wrong: unknown or repeated joint names, no
    points, wrong lengths, NaN/inf, times not increasing, a trajectory that ends before
    ``now``, a last point not at rest, positions outside the joint limits, a set point at
    arrival more than JUMP_TOLERANCE from the measured position, or a speed above a joint's
    velocity limit.
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
    commanded = _positions(positions, times.size, len(names))
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(commanded))):
        raise ValueError("NaN or inf in times or positions")
    if times[0] < 0.0 or np.any(np.diff(times) <= 0.0):
        raise ValueError(f"time_from_start must be >= 0 and strictly increasing, got {times}")
    start_time = stamp if stamp > 0.0 else now
    if start_time + times[-1] < now:
        raise ValueError(
            f"the trajectory ends at t = {start_time + times[-1]:.3f} s, before it arrived at "
            f"t = {now:.3f} s (its header stamp is old)"
        )
    index = [limits.names.index(name) for name in names]
    lower, upper = limits.lower[index], limits.upper[index]
    outside = (commanded < lower) | (commanded > upper)
    if np.any(outside):
        point, joint = np.argwhere(outside)[0]
        raise ValueError(
            f"{names[joint]} = {commanded[point, joint]:.4f} rad at point {point} is outside "
            f"its limits [{lower[joint]:.4f}, {upper[joint]:.4f}] rad"
        )
    here = np.asarray(measured[0], dtype=np.float64)
    rates = [
        _rates(kind, given, times.size, len(names))
        for kind, given in (("velocities", velocities), ("accelerations", accelerations))
    ]
    last_velocity = rates[0][-1]
    if last_velocity is not None and np.any(np.abs(last_velocity) > _AT_REST):
        raise ValueError("velocities at the last point must be 0 (the arm ends at rest)")
    points = []
    for k in range(times.size):
        full = here.copy()
        full[index] = commanded[k]
        point = [full]
        for rate in rates:
            if rate[k] is None:
                point.append(None)
            else:
                point.append(np.zeros_like(here))
                point[-1][index] = rate[k]
        points.append(tuple(point))
    arrival = (now, (here, np.asarray(measured[1], dtype=np.float64), None))
    trajectory = SplineTrajectory(start_time, arrival, times, points)
    jump = np.abs(trajectory.sample(now)[0] - here)
    if np.max(jump) > JUMP_TOLERANCE:
        joint = limits.names[int(np.argmax(jump))]
        raise ValueError(
            f"the set point would jump {np.max(jump):.4f} rad on {joint} at arrival (a point "
            "due now, or a stamp in the past, away from where the arm is)"
        )
    too_fast = trajectory.peak_speed() > limits.velocity
    if np.any(too_fast):
        joint = int(np.argmax(too_fast))
        raise ValueError(
            f"unreachable: {limits.names[joint]} would need more than its velocity limit "
            f"{limits.velocity[joint]:.3f} rad/s; give it more time"
        )
    return trajectory


def _positions(positions: ArrayLike, k: int, m: int) -> NDArray[np.float64]:
    """``positions`` as shape (k, m); ValueError when the shape differs."""
    rows = [np.asarray(row, dtype=np.float64) for row in positions]  # type: ignore[union-attr]
    if len(rows) != k:
        raise ValueError(f"{k} times but {len(rows)} rows of positions")
    for i, row in enumerate(rows):
        if row.shape != (m,):
            raise ValueError(f"point {i} has {row.size} positions for {m} joint names")
    return np.array(rows)


def _rates(
    name: str, given: Sequence[ArrayLike | None] | None, k: int, m: int
) -> list[NDArray[np.float64] | None]:
    """Per point, its ``name`` (velocities or accelerations) shape (m,), or None where it
    carries none; ValueError for a wrong length or a non-finite value."""
    if given is None:
        return [None] * k
    if len(given) != k:
        raise ValueError(f"{name}: {len(given)} rows for {k} points")
    out: list[NDArray[np.float64] | None] = []
    for i, row in enumerate(given):
        if row is None or np.size(row) == 0:
            out.append(None)
            continue
        row = np.asarray(row, dtype=np.float64)
        if row.shape != (m,):
            raise ValueError(f"point {i} has {row.size} {name} for {m} joint names")
        if not np.all(np.isfinite(row)):
            raise ValueError(f"NaN or inf in {name}")
        out.append(row)
    return out
