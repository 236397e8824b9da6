"""An excitation for the 10 inertial parameters: a periodic wrist motion, designed once
per arm and grasp.

The wrist joints follow finite Fourier series (Swevers et al. 1997) of base frequency
w = 2 pi / period and ``HARMONICS`` harmonics each,

    q_j(t) = q_home,j + sum_l a_jl / (w l) sin(w l t) - b_jl / (w l) (cos(w l t) - 1),

so the motion starts and ends at home, periodic; with sum_l a_jl = 0 and sum_l l b_jl = 0
it starts and ends at rest (zero velocity and acceleration), so it needs no transition.
The coefficients maximise the D-optimality criterion, log det of the information matrix of
the load's 10 parameters and the sensor's 6 biases over the motion sampled at 100 Hz under
white noise per axis (``SIGMA``): it shrinks the volume of the estimate's confidence
ellipsoid, and unlike the condition number it does not depend on the parameters' units
(rescaling a parameter adds a constant to log det). Each candidate is scaled to the
largest amplitude within the URDF's position and velocity limits and ``max_acceleration``
(rad/s^2 per moved joint: ``acceleration_bounds``, the bound asked for within the arm's
published limits; ``DEFAULT_ACCELERATION`` keeps the load's acceleration, the joints'
times the lever, to a few m/s^2 so that the grasp holds); the shapes are searched by a
seeded random search with shrinking steps (numpy only). The same seed, arm and grasp give
the same motion.

The velocity limits bind first over a long period, the accelerations over a short one:
a shorter period at a higher bound is the faster motion, and the inertia is told by the
accelerations (``planning.motion_accuracy`` weighs a longer motion against a faster one).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.robot.dynamics import sensor_regressors
from com_core.robot.model import RobotModel

__all__ = [
    "DEFAULT_ACCELERATION",
    "HARMONICS",
    "SIGMA",
    "WAYPOINT_RATE",
    "Excitation",
    "acceleration_bounds",
    "cached_excitation",
    "design_excitation",
    "excitation_information",
]

HARMONICS = 3
"""Harmonics per joint."""
DEFAULT_ACCELERATION = 8.0
"""rad/s^2: the bound on each moved joint's acceleration unless a faster motion is asked
for (the sequencer's ``motion_acceleration``)."""
SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])
"""N, N m: the noise per sample the design weighs the axes by (the realistic sensor's)."""
_RATE = 100.0  # Hz the design samples the motion at
WAYPOINT_RATE = 20.0
"""Hz: the waypoints (positions, velocities, accelerations) an arm's controller is sent."""


@dataclass(frozen=True)
class Excitation:
    """A periodic motion of ``joints`` about ``home`` (rad; every joint of the arm, in
    ``joint_names`` order), ``period`` s, run ``cycles`` times over (``duration``); ``a``
    and ``b`` (len(joints), HARMONICS) its Fourier coefficients (rad/s); ``log_det`` its
    criterion (of one period)."""

    joint_names: tuple[str, ...]
    home: NDArray[np.float64]
    joints: tuple[str, ...]
    period: float
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    log_det: float
    cycles: int = 1

    @property
    def duration(self) -> float:
        """s: ``cycles`` periods."""
        return self.cycles * self.period

    def at(self, t: NDArray[np.float64] | float) -> tuple[NDArray[np.float64], ...]:
        """(positions, velocities, accelerations) of every joint at times ``t`` (s from the
        start; (n,) -> (n, joints)); rad, rad/s, rad/s^2."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))[:, None, None]
        w = 2 * np.pi / self.period
        harmonic = np.arange(1, HARMONICS + 1)[None, None, :]
        wl = w * harmonic
        s, c = np.sin(wl * t), np.cos(wl * t)
        q = (self.a / wl * s - self.b / wl * (c - 1)).sum(axis=2)
        dq = (self.a * c + self.b * s).sum(axis=2)
        ddq = (-self.a * wl * s + self.b * wl * c).sum(axis=2)
        index = [self.joint_names.index(name) for name in self.joints]
        out = []
        for offset, part in ((self.home, q), (0.0, dq), (0.0, ddq)):
            full = np.zeros((t.shape[0], len(self.joint_names))) + offset
            full[:, index] += part
            out.append(full)
        return tuple(out)

    def waypoints(
        self, joints: Sequence[str], rate: float = WAYPOINT_RATE
    ) -> tuple[NDArray[np.float64], ...]:
        """(times s after the start, positions, velocities, accelerations) of ``joints``
        (names, any order; rad, rad/s, rad/s^2) every 1 / ``rate`` s over its ``cycles``
        periods, the first at its start and the last at its end, both at rest at home: a
        trajectory of these points holds the arm still until its first point's time."""
        times = np.arange(0, round(rate * self.duration) + 1) / rate
        index = [self.joint_names.index(name) for name in joints]
        return (times, *(x[:, index] for x in self.at(times)))


def excitation_information(robot: RobotModel, excitation: Excitation) -> NDArray[np.float64]:
    """The information matrix (16, 16) of the load's 10 parameters and the sensor's 6
    biases over one period sampled at 100 Hz, under white noise ``SIGMA``."""
    t = np.arange(0.0, excitation.period, 1.0 / _RATE)
    Y = sensor_regressors(robot, *excitation.at(t))
    rows = np.concatenate([Y, np.broadcast_to(np.eye(6), (len(t), 6, 6))], axis=2)
    rows /= SIGMA[:, None]
    info = np.zeros((16, 16))
    for k in range(len(t)):
        info += rows[k].T @ rows[k]
    return info


def acceleration_bounds(
    requested: float,
    joints: Sequence[str],
    arm_joints: Sequence[str],
    published: Sequence[float],
) -> tuple[float, ...]:
    """rad/s^2 per joint of ``joints``: ``requested``, within the arm's ``published``
    limits (one per joint of ``arm_joints``; none: the arm states none)."""
    limits = dict(zip(arm_joints, published, strict=True)) if published else {}
    return tuple(min(requested, limits.get(name, np.inf)) for name in joints)


def design_excitation(
    robot: RobotModel,
    home: Sequence[float],
    joints: Sequence[str],
    period: float = 4.0,
    max_acceleration: float | Sequence[float] = DEFAULT_ACCELERATION,
    iterations: int = 150,
    seed: int = 0,
) -> Excitation:
    """The D-optimal excitation of ``joints`` (the wrist's) about ``home`` (rad, every
    joint of ``robot.joint_names``) with ``period`` s, within the URDF's limits and
    ``max_acceleration`` rad/s^2 (one for every joint, or one per joint; see module)."""
    rng = np.random.default_rng(seed)
    limits = robot.joint_limits()
    home = np.asarray(home, dtype=np.float64)
    index = [robot.joint_names.index(name) for name in joints]
    room = np.array([min(home[i] - limits[n][0], limits[n][1] - home[i]) for i, n in
                     zip(index, joints, strict=True)])  # fmt: skip
    speed = np.array([limits[n][2] for n in joints])
    acceleration = np.broadcast_to(np.asarray(max_acceleration, dtype=np.float64), speed.shape)

    def candidate(shape: NDArray[np.float64]) -> Excitation:
        a, b = _at_rest(shape.reshape(2, len(joints), HARMONICS))
        trial = Excitation(robot.joint_names, home, tuple(joints), period, a, b, -np.inf)
        t = np.arange(0.0, period, 1.0 / _RATE)
        q, dq, ddq = (x[:, index] for x in trial.at(t))
        scale = 0.95 * min(
            np.min(room / np.maximum(np.abs(q - home[index]).max(axis=0), 1e-12)),
            np.min(speed / np.maximum(np.abs(dq).max(axis=0), 1e-12)),
            np.min(acceleration / np.maximum(np.abs(ddq).max(axis=0), 1e-12)),
        )
        scaled = Excitation(robot.joint_names, home, tuple(joints), period, a * scale,
                            b * scale, -np.inf)  # fmt: skip
        sign, log_det = np.linalg.slogdet(excitation_information(robot, scaled))
        return Excitation(robot.joint_names, home, tuple(joints), period, a * scale,
                          b * scale, log_det if sign > 0 else -np.inf)  # fmt: skip

    shape = rng.normal(size=2 * len(joints) * HARMONICS)
    best = candidate(shape)
    step = 1.0
    for _ in range(iterations):
        trial_shape = shape + step * rng.normal(size=shape.size)
        trial = candidate(trial_shape)
        if trial.log_det > best.log_det:
            shape, best = trial_shape, trial
        else:
            step = max(step * 0.97, 0.05)
    return best


def cached_excitation(
    path: str | Path,
    robot: RobotModel,
    home: Sequence[float],
    joints: Sequence[str],
    period: float = 4.0,
    max_acceleration: float | Sequence[float] = DEFAULT_ACCELERATION,
    iterations: int = 150,
    seed: int = 0,
) -> Excitation:
    """``design_excitation``'s motion, read from the JSON file ``path`` when it was
    designed before for the same arm (its URDF's SHA-256), home, joints and settings (to
    the last bit: JSON floats round-trip), else designed and added to the file (written
    whole to a temporary file, then renamed: a reader never sees half of it)."""
    request = {
        "urdf_sha256": robot.urdf_sha256,
        "home": [float(x) for x in home],
        "joints": list(joints),
        "period": float(period),
        "max_acceleration": np.asarray(max_acceleration, dtype=np.float64).tolist(),
        "iterations": int(iterations),
        "seed": int(seed),
    }
    key = hashlib.sha256(json.dumps(request, sort_keys=True).encode()).hexdigest()
    path = Path(path)
    try:
        entries = dict(json.loads(path.read_text())["entries"])
    except (OSError, ValueError, KeyError, TypeError):  # none yet, or not a cache: designed
        entries = {}
    try:
        e = entries[key]["excitation"]
        return Excitation(
            tuple(e["joint_names"]),
            np.array(e["home"]),
            tuple(e["joints"]),
            e["period"],
            np.array(e["a"]),
            np.array(e["b"]),
            e["log_det"],
        )
    except (KeyError, TypeError):  # not designed yet for this request (or not readable)
        pass
    designed = design_excitation(robot, home, joints, period, max_acceleration, iterations, seed)
    fields = {name: getattr(designed, name) for name in Excitation.__dataclass_fields__}
    stored = {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in fields.items()}
    entries[key] = {"request": request, "excitation": stored}
    temporary = path.with_name(f".{path.name}.{os.getpid()}")
    temporary.write_text(json.dumps({"entries": entries}, indent=1))
    temporary.replace(path)
    return designed


def _at_rest(coefficients: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """(a, b) from free ``coefficients`` (2, joints, HARMONICS): the first harmonic's set
    so that sum_l a_l = 0 and sum_l l b_l = 0 (rest at the start and the end)."""
    a, b = coefficients[0].copy(), coefficients[1].copy()
    harmonic = np.arange(1, HARMONICS + 1)
    a[:, 0] = -a[:, 1:].sum(axis=1)
    b[:, 0] = -(harmonic[1:] * b[:, 1:]).sum(axis=1)
    return a, b
