"""Static windows of an unlabelled wrench stream, sorted by load level.

A bag without pose labels (a recording of another tool, a run whose labels were lost)
still holds static stretches: the arm at rest in some pose. ``find_static_windows``
finds them; ``split_load_levels`` sorts them into the empty hand's (the tare) and the
loaded hand's (the object) by the gravity load |f|, which does not depend on the
orientation, and pairs each object window with the tare window of the same gravity
direction; ``label_static_windows`` turns that into pose labels an ``Exploration``
takes. Units: N, N m, sensor frame; stamps in ns.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from com_core.contract import MOVING, OBJECT_PREFIX, TARE_PREFIX
from com_core.estimation.fits.windows import Window

__all__ = [
    "LoadLevels",
    "StaticWindow",
    "find_static_windows",
    "label_static_windows",
    "split_load_levels",
]

LEVEL_TOLERANCE = 0.02
"""Relative difference of |f| (N) below which two static windows are one load level: a
sensor calibrated to 1 % reads one load's |f| up to ~1.5 % apart between orientations."""
PAIR_MAX_ANGLE = math.radians(2.0)
"""rad: largest angle between an object window's force and its tare window's."""


@dataclass(frozen=True)
class StaticWindow:
    """A static stretch of an unlabelled stream (``find_static_windows``).

    start_ns : stamp of its first sample, ns. stop_ns : the stamp that ends it (that of
    the sample after its last; at the end of the stream, of its last), ns.
    window : its samples reduced to the mean wrench (N, N m; sensor frame) and the
    covariance of that mean; ``window.pose`` is ``static_<k>``, k counting from 1.
    """

    start_ns: int
    stop_ns: int
    window: Window


@dataclass(frozen=True)
class LoadLevels:
    """Static windows sorted into the empty hand's and the loaded hand's (see
    ``split_load_levels``).

    labels : (stamp ns, label) in time order; each window label is ended by ``moving``.
    weights : |f| of each load level found, N, lightest first (the windows of the
        stream and of the cached tare).
    tare_windows : windows of the stream labelled ``tare/``.
    object_windows : windows of the stream labelled ``object/``.
    cached_pairs : object windows paired with a window of the cached tare.
    unpaired : object windows left out: no tare window within ``PAIR_MAX_ANGLE``.
    other_levels : windows left out: at a load level between the lightest and the
        heaviest (e.g. an object partly resting on a table).
    max_angle : the largest angle between the forces of an object window and its tare
        window, rad.
    angle_limit : the largest angle a pair may have, rad.
    """

    labels: tuple[tuple[int, str], ...]
    weights: tuple[float, ...]
    tare_windows: int = 0
    object_windows: int = 0
    cached_pairs: int = 0
    unpaired: int = 0
    other_levels: int = 0
    max_angle: float = 0.0
    angle_limit: float = PAIR_MAX_ANGLE

    @property
    def untared(self) -> bool:
        """One load level: the windows carry the whole load beyond the sensor."""
        return self.object_windows > 0 and self.tare_windows + self.cached_pairs == 0

    def describe(self) -> str:
        """One line: what was found and what was done with it."""
        found = self.object_windows + self.unpaired + self.other_levels
        if not self.weights:
            return "no static windows found"
        levels = ", ".join(f"{w:.2f}" for w in self.weights)
        if self.untared:
            return (
                f"{found} static windows at one load level ({levels} N): estimated without "
                f"tare (the whole load beyond the sensor)"
            )
        text = (
            f"{self.tare_windows} tare and {self.object_windows} object windows by load level "
            f"({levels} N), paired by gravity direction (largest angle "
            f"{math.degrees(self.max_angle):.2f} deg)"
        )
        if self.cached_pairs:
            text += f", {self.cached_pairs} of them with the cached tare"
        if self.unpaired:
            text += (
                f"; {self.unpaired} object windows left out: no tare window within "
                f"{math.degrees(self.angle_limit):.3g} deg"
            )
        if self.other_levels:
            text += f"; {self.other_levels} windows at other load levels left out"
        return text


def find_static_windows(
    stamps_ns: NDArray[np.int64],
    wrenches: NDArray[np.float64],
    min_duration: float = 0.3,
    block_duration: float = 0.05,
    z: float = 6.0,
) -> list[StaticWindow]:
    """The static windows of an unlabelled stream, in time order.

    stamps_ns : shape (n,), ns. wrenches : shape (n, 6), N and N m, sensor frame.

    1. Cut the stream into blocks of ``block_duration`` s (at least 10 samples).
    2. The noise per axis is the median of the blocks' standard deviations (most of an
       exploration is static, so the median is the sensor's noise).
    3. A block is quiet when its standard deviation is below twice the noise on every
       axis (no motion inside it).
    4. Consecutive quiet blocks form one window while each block's mean stays within
       ``z`` standard errors of the window's running mean on every axis; a block mean's
       standard error is measured, not assumed white: the median difference of
       consecutive quiet block means / (0.6745 sqrt(2)) (a sensor whose samples are
       correlated has block means that vary more than sigma / sqrt(size)).
    5. Windows shorter than ``min_duration`` s are dropped; the first and last block of
       each are trimmed as a guard against the end of a motion.
    """
    n = len(stamps_ns)
    if n < 20:
        return []
    dt = float(np.median(np.diff(stamps_ns))) * 1e-9
    size = max(10, round(block_duration / dt)) if dt > 0 else 10
    n_blocks = n // size
    if n_blocks < 3:
        return []
    blocks = wrenches[: n_blocks * size].reshape(n_blocks, size, 6)
    means, sds = blocks.mean(axis=1), blocks.std(axis=1, ddof=1)
    noise = np.maximum(np.median(sds, axis=0), 1e-12)
    quiet = np.all(sds < 2.0 * noise, axis=1)
    pairs = quiet[1:] & quiet[:-1]
    block_se = noise / np.sqrt(size)
    if pairs.sum() >= 3:
        spread = np.median(np.abs(np.diff(means, axis=0))[pairs], axis=0) / (0.6745 * np.sqrt(2))
        block_se = np.maximum(block_se, spread)
    runs: list[list[int]] = []
    total = np.zeros(6)
    for k in range(n_blocks):
        if runs and quiet[k] and quiet[runs[-1][-1]] and runs[-1][-1] == k - 1:
            run_mean = total / len(runs[-1])
            se = block_se * np.sqrt(1.0 + 1.0 / len(runs[-1]))
            if np.all(np.abs(means[k] - run_mean) < z * se):
                runs[-1].append(k)
                total += means[k]
                continue
        if quiet[k]:
            runs.append([k])
            total = means[k].copy()
    found: list[StaticWindow] = []
    for run in runs:
        run = run[1:-1]
        if not run or len(run) * size * dt < min_duration:
            continue
        start, stop = run[0] * size, min((run[-1] + 1) * size, n - 1)
        samples = wrenches[start:stop]
        cov = np.diag(noise**2) / len(samples)
        window = Window(f"static_{len(found) + 1}", samples.mean(axis=0), cov, len(samples))
        found.append(StaticWindow(int(stamps_ns[start]), int(stamps_ns[stop]), window))
    return found


def split_load_levels(
    found: Sequence[StaticWindow],
    tares: Mapping[str, Window] | None = None,
    tolerance: float = LEVEL_TOLERANCE,
    max_angle: float = PAIR_MAX_ANGLE,
    z: float = 6.0,
) -> LoadLevels:
    """Sort static windows into the empty hand's (tare) and the loaded hand's (object).

    found : the stream's static windows (``find_static_windows``).
    tares : tare windows known from before (a cached tare pass), by pose.
    tolerance, z : two load levels differ by more than ``tolerance`` of |f| and by more
        than ``z`` standard errors (``load_levels``).
    max_angle : rad, the largest angle between the forces of a tare and an object window
        paired.

    The gravity load |f| (N) of a static window does not depend on the orientation, so
    the windows fall into load levels (``load_levels``): the empty hand's is the level
    of most cached tare windows, else the lightest (a hand pressed on by something, as
    the fingers on an object still on its stand, weighs less than when empty), the
    heaviest one with a window of the stream is the hand with the object; other levels
    are left out. Each object window is paired with the tare window
    (of the stream or of ``tares``) whose force points closest to its own, and takes its
    pose name; a pair more than ``max_angle`` rad apart is refused (the window is left
    out), since the tare then holds the hand in another orientation: the hand's force
    differs by about |f_hand| x angle (0.17 N per degree for a 1 kg hand). With one load
    level every window is labelled ``object/static_<k>`` and estimated untared.
    """
    cached = list((tares or {}).values())
    if not found:
        return LoadLevels((), ())
    candidates = [s.window for s in found] + cached
    level = load_levels(candidates, tolerance, z)
    weights = level_weights(candidates, level)
    found_level = level[: len(found)]
    heaviest = int(found_level.max())
    empty = int(np.bincount(level[len(found) :]).argmax()) if cached else 0
    if heaviest == empty:
        labels = [_window_labels(s, f"{OBJECT_PREFIX}{s.window.pose}") for s in found]
        return LoadLevels(_in_time_order(labels), weights[:1], object_windows=len(found))
    tare_side = [k for k, lv in enumerate(level) if lv == empty]  # indices into candidates
    labels: list[tuple[tuple[int, str], tuple[int, str]]] = []
    paired: set[int] = set()
    unpaired = cached_pairs = 0
    worst = 0.0
    for s, lv in zip(found, found_level, strict=True):
        if lv != heaviest:
            continue
        k = min(tare_side, key=lambda k: force_angle(s.window, candidates[k]))
        angle = force_angle(s.window, candidates[k])
        if angle > max_angle:
            unpaired += 1
            continue
        worst = max(worst, angle)
        labels.append(_window_labels(s, f"{OBJECT_PREFIX}{candidates[k].pose}"))
        paired.add(k)
        cached_pairs += k >= len(found)
    n_objects = len(labels)
    tare_found = [found[k] for k in sorted(paired) if k < len(found)]
    labels += [_window_labels(s, f"{TARE_PREFIX}{s.window.pose}") for s in tare_found]
    return LoadLevels(
        _in_time_order(labels),
        weights,
        tare_windows=len(tare_found),
        object_windows=n_objects,
        cached_pairs=cached_pairs,
        unpaired=unpaired,
        other_levels=int(np.sum((found_level != 0) & (found_level != heaviest))),
        max_angle=worst,
        angle_limit=max_angle,
    )


def load_levels(
    windows: Sequence[Window], tolerance: float = LEVEL_TOLERANCE, z: float = 6.0
) -> NDArray[np.int64]:
    """Load level of each window, 0 the lightest: windows sorted by |f| (N) split where
    two neighbours differ by more than ``tolerance`` of the larger and by more than
    ``z`` standard errors of the difference."""
    weights = np.array([force_weight(w) for w in windows])
    sigmas = np.array([force_weight_sigma(w) for w in windows])
    order = np.argsort(weights, kind="stable")
    gaps = np.diff(weights[order])
    limits = np.maximum(
        tolerance * weights[order][1:], z * np.hypot(sigmas[order][1:], sigmas[order][:-1])
    )
    level = np.empty(len(windows), dtype=np.int64)
    level[order] = np.concatenate([[0], np.cumsum(gaps > limits)])
    return level


def level_weights(windows: Sequence[Window], level: NDArray[np.int64]) -> tuple[float, ...]:
    """Mean |f| of the windows of each load level, N, lightest level first."""
    weights = np.array([force_weight(w) for w in windows])
    return tuple(float(weights[level == k].mean()) for k in range(int(level.max()) + 1))


def force_weight(window: Window) -> float:
    """|f| of a window's mean, N: the gravity load, whatever the orientation."""
    return float(np.linalg.norm(window.force))


def force_weight_sigma(window: Window) -> float:
    """Standard error of ``force_weight``, N (the mean's covariance along the force)."""
    f = window.force
    norm = float(np.linalg.norm(f))
    u = f / norm if norm > 0 else np.zeros(3)
    return math.sqrt(max(float(u @ window.cov[:3, :3] @ u), 0.0))


def force_angle(a: Window, b: Window) -> float:
    """Angle between two windows' mean forces, rad (the gravity directions' angle)."""
    fa, fb = a.force, b.force
    return math.atan2(float(np.linalg.norm(np.cross(fa, fb))), float(fa @ fb))


def _window_labels(s: StaticWindow, label: str) -> tuple[tuple[int, str], tuple[int, str]]:
    """The label that opens a static window and the ``moving`` that ends it."""
    return (s.start_ns, label), (s.stop_ns, MOVING)


def _in_time_order(
    pairs: Sequence[tuple[tuple[int, str], tuple[int, str]]],
) -> tuple[tuple[int, str], ...]:
    """Flatten (open, end) label pairs in time order."""
    return tuple(label for pair in sorted(pairs) for label in pair)


def label_static_windows(
    stamps_ns: NDArray[np.int64],
    wrenches: NDArray[np.float64],
    min_duration: float = 0.3,
    block_duration: float = 0.05,
    z: float = 6.0,
    tares: Mapping[str, Window] | None = None,
) -> list[tuple[int, str]]:
    """Labels for the static windows of an unlabelled stream, by load level.

    stamps_ns : shape (n,), ns. wrenches : shape (n, 6), N and N m, sensor frame.
    tares : tare windows known from before (a cached tare pass), by pose.

    The windows are those of ``find_static_windows``; ``split_load_levels`` sorts them
    into the empty hand's (``tare/static_<k>``) and the loaded hand's
    (``object/<pose of the tare window in the same gravity direction>``), or, with one
    load level, labels them all ``object/static_<k>`` (the whole load, untared). A
    ``moving`` label ends every window. Returns (stamp ns, label) in time order.
    """
    found = find_static_windows(stamps_ns, wrenches, min_duration, block_duration, z)
    return list(split_load_levels(found, tares or {}).labels)
