"""Synthetic explorations from the wrench model: labelled samples or window means.

Used by the Monte Carlo study, the tests and the scripted publisher, so they all see
the same physics as the estimator assumes (``wrench_model``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.contract import DONE, MOVING, OBJECT_PREFIX, TARE_PREFIX, VERIFY_PREFIX
from com_core.estimation.fits.windows import Window
from com_core.planning.planner import Plan
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    SensorModel,
    as_vector,
    gravity_wrench,
)

__all__ = [
    "Load",
    "Stream",
    "WanderingRecording",
    "exploration_samples",
    "exploration_stream",
    "object_windows",
    "wandering_recording",
]


@dataclass(frozen=True)
class Load:
    """A rigid load on the sensor: mass (kg) and COM (shape (3,), m, sensor frame)."""

    mass: float
    com: tuple[float, float, float]


def _shifts(n: int, shift_sigma: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """COM shift per pose (n, 3), m: zero at home, N(0, shift_sigma^2 I) at each tilt.

    The paper's reconfiguration: the object moves in the grasp when the hand tilts.
    """
    out = np.zeros((n, 3))
    if shift_sigma > 0:
        out[1:] = rng.normal(0.0, shift_sigma, size=(n - 1, 3))
    return out


def object_windows(
    plan: Plan,
    load: Load,
    rng: np.random.Generator,
    shift_sigma: float = 0.0,
    noise: bool = True,
    g: float = STANDARD_GRAVITY,
) -> tuple[list[Window], NDArray[np.float64]]:
    """Tare-subtracted windows of ``plan`` drawn as their means.

    For white Gaussian noise the mean of N samples is exactly N(w, cov) with the plan's
    window covariance, so drawing the mean is the same experiment as averaging samples.

    Returns the windows and the true COM per pose (n, 3), m (differs from ``load.com``
    only with ``shift_sigma`` > 0).
    """
    g_dirs = plan.gravity_directions()
    n = len(g_dirs)
    coms = np.asarray(load.com, dtype=np.float64) + _shifts(n, shift_sigma, rng)
    cov = plan.window_cov()
    chol = np.linalg.cholesky(cov) if noise else np.zeros((6, 6))
    windows = []
    for (pose, _), d, com in zip(plan.poses(), g_dirs, coms, strict=True):
        mean = gravity_wrench(load.mass, com, g * d) + chol @ rng.standard_normal(6)
        windows.append(Window(pose, mean, cov.copy(), plan.samples_per_window()))
    return windows, coms


def _exploration_truth(
    plan: Plan,
    load: Load,
    hand: Load,
    rng: np.random.Generator,
    shift_sigma: float,
    g: float,
    verify: Mapping[str, ArrayLike] | None = None,
) -> list[tuple[str, NDArray[np.float64], int]]:
    """(label, true wrench (6,), samples) per window: tare pass, then object pass, then
    a ``verify/<pose>`` window of the object pass's length at each gravity direction
    (sensor frame, unit) of ``verify``, the COM as at the last pose."""
    g_dirs = g * plan.gravity_directions()
    poses = [name for name, _ in plan.poses()]
    coms = as_vector(load.com, 3, "com") + _shifts(len(poses), shift_sigma, rng)
    hand_com = as_vector(hand.com, 3, "hand com")
    n_obj = plan.samples_per_window()
    finite_tare = plan.tare_dwell is not None and math.isfinite(plan.tare_dwell)
    tare_s = plan.tare_dwell if finite_tare else plan.dwell
    n_tare = max(1, round(tare_s * plan.sensor.rate_hz))
    out = []
    for pose, g_s in zip(poses, g_dirs, strict=True):
        out.append((TARE_PREFIX + pose, gravity_wrench(hand.mass, hand_com, g_s), n_tare))
    for pose, g_s, com in zip(poses, g_dirs, coms, strict=True):
        w = gravity_wrench(hand.mass, hand_com, g_s) + gravity_wrench(load.mass, com, g_s)
        out.append((OBJECT_PREFIX + pose, w, n_obj))
    for pose, direction in (verify or {}).items():
        g_s = g * as_vector(direction, 3, "verify direction")
        w = gravity_wrench(hand.mass, hand_com, g_s) + gravity_wrench(load.mass, coms[-1], g_s)
        out.append((VERIFY_PREFIX + pose, w, n_obj))
    return out


def exploration_samples(
    plan: Plan,
    load: Load,
    hand: Load,
    rng: np.random.Generator,
    shift_sigma: float = 0.0,
    g: float = STANDARD_GRAVITY,
) -> list[tuple[str, NDArray[np.float64]]]:
    """Labelled raw samples of a whole exploration: tare pass, then object pass.

    Returns (label, samples (N, 6)) in time order: ``tare/<pose>`` windows of the empty
    hand, then ``object/<pose>`` windows of hand + object, each through ``plan.sensor``
    (noise, bias, quantisation, saturation). N, N m; sensor frame.
    """
    truth = _exploration_truth(plan, load, hand, rng, shift_sigma, g)
    return [(label, plan.sensor.measure(np.tile(w, (n, 1)), rng)) for label, w, n in truth]


@dataclass(frozen=True)
class Stream:
    """A stamped exploration as the sensor and the sequencer publish it.

    stamps : (N,) ns; wrenches : (N, 6) N and N m, sensor frame; labels : (stamp ns,
    label) with ``moving`` between windows and ``done`` at the end.
    """

    stamps: NDArray[np.int64]
    wrenches: NDArray[np.float64]
    labels: list[tuple[int, str]]


def exploration_stream(
    plan: Plan,
    load: Load,
    hand: Load,
    rng: np.random.Generator,
    shift_sigma: float = 0.0,
    move_time: float = 0.2,
    start_ns: int = 1_000_000_000,
    g: float = STANDARD_GRAVITY,
    verify: Mapping[str, ArrayLike] | None = None,
) -> Stream:
    """The exploration of ``exploration_samples`` as one stamped stream.

    Between windows the wrench ramps linearly from one pose's to the next over
    ``move_time`` s, labelled ``moving``; ``done`` follows the last window and 50 ms of
    samples follow ``done``, so a consumer sees the stream pass it. ``verify`` adds
    verification windows after the object pass (see ``_exploration_truth``).
    """
    truth = _exploration_truth(plan, load, hand, rng, shift_sigma, g, verify)
    dt = 1e9 / plan.sensor.rate_hz
    n_move = max(2, round(move_time * plan.sensor.rate_hz))
    pieces, labels, t = [], [], 0
    previous = truth[0][1]
    for label, w, n in truth:
        labels.append((start_ns + round(t * dt), MOVING))
        pieces.append(np.linspace(previous, w, n_move))
        t += n_move
        labels.append((start_ns + round(t * dt), label))
        pieces.append(np.tile(w, (n, 1)))
        t += n
        previous = w
    labels.append((start_ns + round(t * dt), DONE))
    pieces.append(np.tile(previous, (max(1, round(0.05 * plan.sensor.rate_hz)), 1)))
    true = np.concatenate(pieces)
    stamps = start_ns + np.round(np.arange(len(true)) * dt).astype(np.int64)
    return Stream(stamps, plan.sensor.measure(true, rng), labels)


@dataclass(frozen=True)
class WanderingRecording:
    """A synthetic recording without labels (``wandering_recording``): stamps (n,) s,
    readings (n, 6) N and N m, R_base_sensor (n, 3, 3), and the truth: the load's mass (kg)
    and COM (m, sensor frame) at each sample (n,) and (n, 3), and the bias (6,)."""

    times: NDArray[np.float64]
    wrenches: NDArray[np.float64]
    rotations: NDArray[np.float64]
    mass: NDArray[np.float64]
    com: NDArray[np.float64]
    bias: NDArray[np.float64]


def _rotation_of(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 3, 3) of rotation vectors (n, 3), Rodrigues."""
    angle = np.linalg.norm(rotvec, axis=1)
    axis = rotvec / np.maximum(angle, 1e-12)[:, None]
    k = np.zeros((len(rotvec), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k -= k.transpose(0, 2, 1)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * k @ k


def wandering_recording(
    sensor: SensorModel,
    load: Load,
    rng: np.random.Generator,
    duration: float = 56.0,
    tilt: float = 1.0,
    speed: float = 0.1,
    axes: ArrayLike | None = None,
    change: tuple[float, float] | None = None,
) -> WanderingRecording:
    """A slow, teleoperated-like recording: rests of 0.3-3 s between slow moves (up to
    ``speed`` rad/s, a smooth profile) to random orientations within ``tilt`` rad of the
    sensor hanging straight down (z along gravity), read through ``sensor`` (its bias,
    calibration and coloured noise) at its rate, for ``duration`` s; quasi-static (the
    wrench model: f = m g_s, tau = p x f). ``axes`` (3,): every move turns about this
    one axis of the hanging sensor (a recording whose orientations share one axis).
    ``change`` (time s, mass kg): from then on the load's mass is this (a second load)."""
    rate = sensor.rate_hz
    t = np.arange(0.0, duration, 1.0 / rate)
    knots_t, knots_v = [0.0], [np.zeros(3)]
    while knots_t[-1] < duration:
        knots_t.append(knots_t[-1] + rng.uniform(0.3, 3.0))  # a rest
        knots_v.append(knots_v[-1])
        if axes is None:  # a tilt of 0.3-1 x ``tilt`` and a turn about the hanging axis
            across = rng.normal(size=2)
            across *= tilt * rng.uniform(0.3, 1.0) / max(np.linalg.norm(across), 1e-9)
            target = np.array([*across, 0.5 * tilt * rng.normal()])
        else:
            target = np.asarray(axes, dtype=np.float64) * tilt * rng.uniform(-1.0, 1.0)
        step = np.linalg.norm(target - knots_v[-1])
        knots_t.append(knots_t[-1] + max(step / (speed * rng.uniform(0.4, 1.0)), 0.2))
        knots_v.append(target)
    knots_t_a, knots_v_a = np.array(knots_t), np.array(knots_v)
    k = np.clip(np.searchsorted(knots_t_a, t, side="right") - 1, 0, len(knots_t_a) - 2)
    s = (t - knots_t_a[k]) / (knots_t_a[k + 1] - knots_t_a[k])
    s = s * s * (3 - 2 * s)  # smooth start and stop
    rotvec = knots_v_a[k] + s[:, None] * (knots_v_a[k + 1] - knots_v_a[k])
    hanging = np.diag([1.0, -1.0, -1.0])  # z down: the sensor hanging from a flange
    rotations = hanging @ _rotation_of(rotvec)
    mass = np.full(len(t), load.mass)
    if change is not None:
        mass[t >= change[0]] = change[1]
    com = np.tile(np.asarray(load.com, dtype=np.float64), (len(t), 1))
    g = np.einsum("kji,j->ki", rotations, np.array([0.0, 0.0, -STANDARD_GRAVITY]))
    true = np.concatenate([mass[:, None] * g, np.cross(com, mass[:, None] * g)], axis=1)
    return WanderingRecording(
        t, sensor.measure(true, rng), rotations, mass, com, sensor.bias.copy()
    )
