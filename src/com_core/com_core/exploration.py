"""One exploration: stamped samples and stamped pose labels in, a solution with a status out.

The estimator node and the offline replay both feed an ``Exploration`` and call
``solve``: the same messages give the same numbers, to the last bit, because every
decision here depends only on the messages' contents, never on arrival order across
topics:

- a label (std_msgs/Header: ``frame_id`` the label, ``stamp`` the time from which it
  applies) opens a window at its stamp that ends at the next label's stamp; samples
  are assigned to windows by their own header stamps;
- labels ``tare/<pose>`` and ``object/<pose>`` name static windows; any other label
  (``moving``, ``done``, ...) closes the current window; ``done`` asks for a solution
  from the labels up to it;
- samples are kept in arrival order; one whose stamp is not after the previous one's
  is dropped and counted (out of time order), as are non-finite samples and samples in
  another frame than the expected one; a jump back by more than 1 s is a restarted
  clock, not a late sample: what came before it is dropped (``time_resets``).

Statuses: ERROR (no estimate: too few poses, ill-conditioned, no tare, no load),
WARN (an estimate, but: the object moved in the grasp, or input was dropped), OK.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import EstimationError, NonPositiveMassError, WindowError
from .estimators import (
    DEFAULT_ALPHA,
    MIN_TILT_SIGMAS,
    Consistency,
    Estimate,
    check_consistency,
    ml,
    two_pose,
)
from .windows import (
    DONE,
    MOVING,
    OBJECT_PREFIX,
    TARE_PREFIX,
    Window,
    reduce_window,
    subtract_tare,
)
from .wrench_model import STANDARD_GRAVITY, SensorModel

__all__ = [
    "ERROR",
    "METHODS",
    "OK",
    "WARN",
    "Exploration",
    "Solution",
    "done_stamp",
    "format_solution",
    "label_static_windows",
]

OK, WARN, ERROR = "OK", "WARN", "ERROR"
_NO_STAMP = -(2**62)
TIME_RESET_NS = 1_000_000_000
"""A sample stamped this much before its predecessor starts a new clock, not a late one."""
METHODS = {"ml": ml, "two_pose": two_pose}


@dataclass(frozen=True)
class Solution:
    """Outcome of one exploration.

    ``estimate`` is None exactly when ``status`` is ERROR. ``reason`` is one line for
    the user; ``notes`` lists every dropped input.
    """

    status: str
    reason: str
    method: str
    estimate: Estimate | None = None
    consistency: Consistency | None = None
    windows: tuple[Window, ...] = ()
    notes: tuple[str, ...] = ()
    window_samples: Mapping[str, int] = field(default_factory=dict)

    def diagnostic_values(self) -> list[tuple[str, str]]:
        """``as_dict`` as diagnostic_msgs/KeyValue pairs (the reason is the status's
        message): vectors per axis (``com_x``), window counts as ``samples <label>``, and
        floats as repr, the shortest text that reads back to the same double."""

        def text(value: object) -> str:
            if isinstance(value, list):
                return ",".join(map(str, value))
            return repr(value) if isinstance(value, float) else str(value)

        out: list[tuple[str, str]] = []
        for key, value in self.as_dict().items():
            if key in ("com", "sigma_com"):
                out += [(f"{key}_{axis}", text(v)) for axis, v in zip("xyz", value, strict=True)]
            elif key == "window_samples":
                out += [(f"samples {label}", str(n)) for label, n in value.items()]
            elif key not in ("reason", "notes"):
                out.append((key, text(value)))
        return out

    def as_dict(self) -> dict:
        """JSON-ready summary: mass (kg), com (m, sensor frame), their sigmas, status."""
        out: dict = {
            "status": self.status,
            "reason": self.reason,
            "method": self.method,
            "poses": [w.pose for w in self.windows],
            "notes": list(self.notes),
            "window_samples": dict(self.window_samples),
        }
        if self.estimate is not None:
            e = self.estimate
            out |= {
                "mass": e.mass,
                "com": e.com.tolist(),
                "sigma_mass": e.sigma_mass,
                "sigma_com": e.sigma_com.tolist(),
            }
        if self.consistency is not None:
            c = self.consistency
            out |= {
                "chi2": c.chi2,
                "dof": c.dof,
                "p_value": c.p_value,
                "suspect_pose": c.suspect_pose,
            }
        return out


@dataclass
class Exploration:
    """Collects one exploration's samples and labels and solves it (see module).

    Attributes
    ----------
    method : 'ml' or 'two_pose'.
    expected_frame : frame_id the samples must carry ('' accepts any).
    sensor : sensor model for saturation and motion tests; None uses the samples alone.
    tares : tare windows known from before (a cached tare pass), by pose; this
        exploration's own tare windows take precedence.
    untared : estimate the whole load beyond the sensor (hand + object) without any
        tare; the solution is then at best WARN and says so.
    """

    method: str = "ml"
    expected_frame: str = "ft_sensor"
    sensor: SensorModel | None = None
    alpha: float = DEFAULT_ALPHA
    min_tilt_sigmas: float = MIN_TILT_SIGMAS
    g: float = STANDARD_GRAVITY
    tares: Mapping[str, Window] = field(default_factory=dict)
    untared: bool = False
    _stamps: list[NDArray[np.int64]] = field(default_factory=list, repr=False)
    _wrenches: list[NDArray[np.float64]] = field(default_factory=list, repr=False)
    _labels: list[tuple[int, str]] = field(default_factory=list, repr=False)
    _last_stamp: int = field(default=_NO_STAMP, repr=False)
    dropped: dict[str, int] = field(default_factory=dict)
    time_resets: int = 0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}, got {self.method!r}")

    @property
    def sample_count(self) -> int:
        return sum(len(s) for s in self._stamps)

    @property
    def latest_stamp(self) -> int | None:
        """Stamp (ns) of the latest sample kept, or None before the first."""
        return None if self._last_stamp == _NO_STAMP else self._last_stamp

    @property
    def labels(self) -> list[tuple[int, str]]:
        """(stamp ns, label) in arrival order."""
        return list(self._labels)

    def add_samples(
        self, stamps_ns: ArrayLike, wrenches: ArrayLike, frames: ArrayLike | str
    ) -> int:
        """Add samples in arrival order; returns how many were kept.

        stamps_ns : shape (n,), int ns. wrenches : shape (n, 6), N and N m.
        frames : frame_id per sample, or one for all.
        """
        stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
        w = np.asarray(wrenches, dtype=np.float64).reshape(-1, 6)
        if len(stamps) != len(w):
            raise ValueError(f"{len(stamps)} stamps for {len(w)} wrenches")
        keep = np.ones(len(stamps), dtype=bool)
        if self.expected_frame:
            frame_ids = np.asarray(frames, dtype=object)
            frame_ok = np.broadcast_to(frame_ids == self.expected_frame, keep.shape)
            if not frame_ok.all():
                names = sorted(set(np.broadcast_to(frame_ids, keep.shape)[~frame_ok]))
                self._count(
                    f"in frame {'/'.join(names)!r}, not {self.expected_frame!r}",
                    int((~frame_ok).sum()),
                )
            keep &= frame_ok
        finite = np.isfinite(w).all(axis=1)
        self._count("not finite (NaN or inf)", int((keep & ~finite).sum()))
        keep &= finite
        kept_idx = np.flatnonzero(keep)
        if kept_idx.size:
            s = stamps[kept_idx]
            # a restarted clock: a sample more than TIME_RESET_NS before the latest one
            while True:
                latest = np.maximum.accumulate(np.concatenate([[self._last_stamp], s]))[:-1]
                restarts = np.flatnonzero(s <= latest - TIME_RESET_NS)
                if not restarts.size:
                    break
                first = int(restarts[0])
                self._restart_clock(int(s[first]))
                keep[kept_idx[:first]] = False
                kept_idx, s = kept_idx[first:], s[first:]
            # out of time order: not after the latest stamp kept so far
            prior = np.maximum.accumulate(np.concatenate([[self._last_stamp], s[:-1]]))
            late = s <= prior
            self._count("out of time order", int(late.sum()))
            keep[kept_idx[late]] = False
            self._last_stamp = max(self._last_stamp, int(s.max()))
        self._stamps.append(stamps[keep])
        self._wrenches.append(w[keep])
        return int(keep.sum())

    def samples(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """All kept samples: stamps (n,) ns and wrenches (n, 6), in arrival order."""
        if not self._stamps:
            return np.empty(0, np.int64), np.empty((0, 6))
        return np.concatenate(self._stamps), np.concatenate(self._wrenches)

    def _restart_clock(self, stamp_ns: int) -> None:
        """The sensor's clock restarted at ``stamp_ns`` (a restarted simulator, a looped
        bag): the samples and labels of the old timeline are dropped, so the two
        timelines' stamps never mix in a window; counted in ``time_resets``."""
        self.time_resets += 1
        self._stamps.clear()
        self._wrenches.clear()
        self._labels = [(t, lbl) for t, lbl in self._labels if t <= stamp_ns + TIME_RESET_NS]
        self._last_stamp = _NO_STAMP

    def add_label(self, stamp_ns: int, label: str) -> None:
        """A pose label applying from ``stamp_ns`` (see module)."""
        self._labels.append((int(stamp_ns), label))

    def done_stamp(self) -> int | None:
        """Stamp of the ``done`` that ends this exploration (see ``done_stamp``)."""
        return done_stamp(self._labels)

    def _count(self, what: str, n: int) -> None:
        if n:
            self.dropped[what] = self.dropped.get(what, 0) + n

    def segments(self, until_ns: int | None = None) -> list[tuple[str, NDArray[np.float64]]]:
        """(label, samples (n, 6)) of every tare/object window, merged per label.

        Windows run from a label's stamp to the next label's; ``until_ns`` ends the
        last one (default: the ``done`` label, else after the last sample).
        """
        stamps, wrenches = self.samples()
        labels = sorted(self._labels, key=lambda sl: sl[0])  # stable: ties keep arrival order
        end = self.done_stamp() if until_ns is None else until_ns
        if end is not None:
            labels = [(s, lbl) for s, lbl in labels if s <= end]
        if not labels:
            return []
        bounds = [s for s, _ in labels[1:]] + [end if end is not None else 2**62]
        merged: dict[str, list[NDArray[np.float64]]] = {}
        for (start, label), stop in zip(labels, bounds, strict=True):
            if label.startswith((TARE_PREFIX, OBJECT_PREFIX)):
                sel = (stamps >= start) & (stamps < stop)
                merged.setdefault(label, []).append(wrenches[sel])
        return [(label, np.concatenate(parts)) for label, parts in merged.items()]

    def solve(self, until_ns: int | None = None) -> Solution:
        """Windows, per-pose tare, estimate and consistency test, with a status."""
        notes = [f"dropped {n} samples {what}" for what, n in self.dropped.items()]
        tares = dict(self.tares)
        objects: list[Window] = []
        segments = self.segments(until_ns)
        counts = {label: len(samples) for label, samples in segments}
        for label, samples in segments:
            kind, pose = label.split("/", 1)
            if len(samples) == 0:
                notes.append(f"window {label!r} has no samples")
                continue
            try:
                window = reduce_window(pose, samples, self.sensor)
            except (WindowError, ValueError) as exc:
                notes.append(f"{kind} {exc}")
                continue
            if kind == "tare":
                tares[pose] = window
            else:
                objects.append(window)
        try:
            if not objects:
                seen = ", ".join(sorted({lbl for _, lbl in self._labels})) or "none"
                raise EstimationError(f"no object windows (labels seen: {seen})")
            if self.untared:
                notes.append(
                    "no tare: the estimate is of the whole load beyond the sensor (hand + object)"
                )
                windows = objects
            else:
                windows = subtract_tare(objects, tares.values())
                _check_load_direction(windows, tares)
            estimate = METHODS[self.method](
                windows, g=self.g, min_tilt_sigmas=self.min_tilt_sigmas
            )
            consistency = check_consistency(windows, alpha=self.alpha, g=self.g)
        except EstimationError as exc:
            reason = str(exc) + ("; " + "; ".join(notes) if notes else "")
            return Solution(ERROR, reason, self.method, notes=tuple(notes), window_samples=counts)
        status, reason = OK, _summary(estimate)
        if not consistency.consistent:
            status, reason = WARN, consistency.message
        elif notes:
            status, reason = WARN, "; ".join(notes)
        return Solution(
            status,
            reason,
            self.method,
            estimate,
            consistency,
            tuple(windows),
            tuple(notes),
            window_samples=counts,
        )


def done_stamp(labels: Sequence[tuple[int, str]]) -> int | None:
    """Stamp of the first ``done`` that arrived after a window label, or None.

    ``labels`` in arrival order. A ``done`` with no window before it ends an earlier
    exploration (the latched label a late-joining subscriber or a recorder gets first),
    not this one; with a restarted clock its stamp could fall anywhere, so the order of
    arrival decides, not the stamp.
    """
    seen_window = False
    for stamp, label in labels:
        if label.startswith((TARE_PREFIX, OBJECT_PREFIX)):
            seen_window = True
        elif label == DONE and seen_window:
            return stamp
    return None


def label_static_windows(
    stamps_ns: NDArray[np.int64],
    wrenches: NDArray[np.float64],
    min_duration: float = 0.3,
    block_duration: float = 0.05,
    z: float = 6.0,
) -> list[tuple[int, str]]:
    """Labels for the static windows of an unlabelled stream (``object/static_<k>``).

    1. Cut the stream into blocks of ``block_duration`` s (at least 10 samples).
    2. The noise per axis is the median of the blocks' standard deviations (most of an
       exploration is static, so the median is the sensor's noise).
    3. A block is quiet when its standard deviation is below twice the noise on every
       axis (no motion inside it).
    4. Consecutive quiet blocks form one window while each block's mean stays within
       ``z`` standard errors of the window's running mean on every axis.
    5. Windows shorter than ``min_duration`` s are dropped; the first and last block of
       each are trimmed as a guard against the end of a motion.
    A ``moving`` label ends every window.
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
    runs: list[list[int]] = []
    total = np.zeros(6)
    for k in range(n_blocks):
        if runs and quiet[k] and quiet[runs[-1][-1]] and runs[-1][-1] == k - 1:
            run_mean = total / len(runs[-1])
            se = noise * np.sqrt(1.0 / size + 1.0 / (size * len(runs[-1])))
            if np.all(np.abs(means[k] - run_mean) < z * se):
                runs[-1].append(k)
                total += means[k]
                continue
        if quiet[k]:
            runs.append([k])
            total = means[k].copy()
    labels: list[tuple[int, str]] = []
    for run in runs:
        run = run[1:-1]
        if not run or len(run) * size * dt < min_duration:
            continue
        start, stop = run[0] * size, (run[-1] + 1) * size
        labels.append((int(stamps_ns[start]), f"{OBJECT_PREFIX}static_{len(labels) // 2 + 1}"))
        labels.append((int(stamps_ns[min(stop, n - 1)]), MOVING))
    return labels


def _check_load_direction(windows: Sequence[Window], tares: Mapping[str, Window]) -> None:
    """The object's force must point the way the hand's does (both are gravity).

    A load pulling against gravity means a mass at or below zero: the tare was taken
    with the object in the hand, or the windows are swapped.
    """
    for w in windows:
        tare_f = tares[w.pose].force
        if float(w.force @ tare_f) < 0.0:
            raise NonPositiveMassError(
                f"pose {w.pose!r}: the load's force points against gravity (mass at or below "
                f"zero; was the tare taken with the object in the hand?)"
            )


def _summary(e: Estimate) -> str:
    c, s = e.com * 1e3, e.sigma_com * 1e3
    return (
        f"mass {e.mass * 1e3:.2f} +- {e.sigma_mass * 1e3:.2f} g, COM ({c[0]:.2f}, "
        f"{c[1]:.2f}, {c[2]:.2f}) +- ({s[0]:.2f}, {s[1]:.2f}, {s[2]:.2f}) mm "
        f"from {len(e.poses)} poses"
    )


def format_solution(solution: Solution) -> str:
    """One line for logs and the command line."""
    return f"[{solution.status}] {solution.method}: {solution.reason}" + (
        ""
        if solution.estimate is None or solution.status == OK
        else f" | {_summary(solution.estimate)}"
    )
