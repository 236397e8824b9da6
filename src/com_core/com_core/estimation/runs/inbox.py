"""An exploration's inbox: stamped samples, stamped pose labels and joint states as they
arrive, with every input it refuses counted.

Every decision here depends only on the messages' contents, never on arrival order
across topics, so the estimator node and the offline replay keep the same input:

- samples (geometry_msgs/WrenchStamped: N and N m, sensor frame; stamps in ns) are kept
  in arrival order; one whose stamp equals the latest kept stamp is dropped and counted
  as a duplicate stamp, one stamped before it as out of time order, as are non-finite
  samples and samples in another frame than the expected one;
- a sample stamped more than ``TIME_RESET_NS`` before the latest kept one is a restarted
  clock (a restarted simulator, a looped bag), not a late sample: the samples and labels
  of the old timeline are dropped (``time_resets``);
- a label (std_msgs/Header: ``frame_id`` the label, ``stamp`` the time from which it
  applies; grammar in ``com_core.contract``) stamped more than ``max_label_gap`` s after
  the latest label starts a new exploration: the earlier labels and samples belong to a
  run that stopped (a killed sequencer) and are dropped (``stale_drops``), so two runs'
  windows of the same name never merge; labels longer than ``MAX_LABEL_LENGTH``
  characters are refused;
- a ``cancelled`` label ends a run that was cancelled: its labels and samples up to the
  label's stamp are dropped, so nothing of it is estimated (``cancelled``, the stamps);
- joint states (sensor_msgs/JointState: rad or m, by joint name) are kept with their
  stamps, for each window's orientation under the kinematic information, each message
  with the joints it names (a gripper's publisher names only its own); one without a
  position per name is refused (``add_joint_state``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.contract import (
    CANCELLED,
    WINDOW_PREFIXES,
    done_stamp,
)

__all__ = [
    "IDLE_KEEP",
    "MAX_LABEL_GAP",
    "MAX_LABEL_LENGTH",
    "TIME_RESET_NS",
    "Inbox",
    "shorten",
]

_NO_STAMP = -(2**62)
TIME_RESET_NS = 1_000_000_000
"""A sample stamped this much before its predecessor starts a new clock, not a late one."""
MAX_LABEL_GAP = 120.0
"""s (sensor time) without a label after which the next label starts a new exploration."""
MAX_LABEL_LENGTH = 128
"""Characters; a longer label is refused (pose names are short: ``object/tilt_x+``)."""
IDLE_KEEP = 10.0
"""s (sensor time) of samples an exploration keeps before its first label."""


def shorten(text: str, limit: int = 40) -> str:
    """``text`` cut to ``limit`` characters, with the number of characters left out."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit} more characters)"


@dataclass
class Inbox:
    """One exploration's input, kept and counted as the module says.

    Attributes
    ----------
    expected_frame : frame_id the samples must carry ('' accepts any).
    wrench_sign : 1 for a wrench the load exerts on the sensor (the convention of
        docs/estimation.md), -1 for a driver that publishes its opposite (what the sensor
        exerts on the load); each sample is multiplied by it as it comes in.
    max_label_gap : s (sensor time); a label this long after the previous one starts a
        new exploration (0: never).
    dropped, dropped_labels : samples and labels refused, counted by why.
    time_resets : restarted clocks seen. stale_drops : stopped runs dropped.
    cancelled : stamps (ns) of the ``cancelled`` labels whose runs were dropped.
    """

    expected_frame: str = "ft_sensor"
    wrench_sign: float = 1.0
    max_label_gap: float = MAX_LABEL_GAP
    _joint_states: list[tuple[int, dict[str, float]]] = field(default_factory=list, repr=False)
    _joint_latest: dict[str, int] = field(default_factory=dict, repr=False)
    _stamps: list[NDArray[np.int64]] = field(default_factory=list, repr=False)
    _wrenches: list[NDArray[np.float64]] = field(default_factory=list, repr=False)
    _labels: list[tuple[int, str]] = field(default_factory=list, repr=False)
    _last_stamp: int = field(default=_NO_STAMP, repr=False)
    dropped: dict[str, int] = field(default_factory=dict)
    dropped_labels: dict[str, int] = field(default_factory=dict)
    time_resets: int = 0
    stale_drops: int = 0
    cancelled: list[int] = field(default_factory=list)

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

    @property
    def joint_states(self) -> list[tuple[int, dict[str, float]]]:
        """(stamp ns, joint positions rad or m by name) in arrival order."""
        return list(self._joint_states)

    def add_samples(
        self, stamps_ns: ArrayLike, wrenches: ArrayLike, frames: ArrayLike | str
    ) -> int:
        """Add samples in arrival order; returns how many were kept.

        stamps_ns : shape (n,), int ns. wrenches : shape (n, 6), N and N m.
        frames : frame_id per sample, or one for all.
        """
        stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
        w = np.asarray(wrenches, dtype=np.float64).reshape(-1, 6)
        if self.wrench_sign != 1.0:
            w = self.wrench_sign * w
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
            # not after the latest stamp kept so far: a duplicate, or out of time order
            prior = np.maximum.accumulate(np.concatenate([[self._last_stamp], s[:-1]]))
            self._count("with a duplicate stamp", int((s == prior).sum()))
            self._count("out of time order", int((s < prior).sum()))
            keep[kept_idx[s <= prior]] = False
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
        """The sensor's clock restarted at ``stamp_ns``: the samples and labels of the old
        timeline are dropped, so the two timelines' stamps never mix in a window; counted
        in ``time_resets``."""
        self.time_resets += 1
        self._stamps.clear()
        self._wrenches.clear()
        self._labels = [(t, lbl) for t, lbl in self._labels if t <= stamp_ns + TIME_RESET_NS]
        self._last_stamp = _NO_STAMP

    def add_label(self, stamp_ns: int, label: str) -> None:
        """A pose label applying from ``stamp_ns`` (see module)."""
        stamp_ns = int(stamp_ns)
        if len(label) > MAX_LABEL_LENGTH:
            what = f"longer than {MAX_LABEL_LENGTH} characters ({shorten(label)})"
            self.count_dropped(what, 1, labels=True)
            return
        if self._labels and self.max_label_gap > 0:
            latest = max(t for t, _ in self._labels)
            if stamp_ns - latest > self.max_label_gap * 1e9:
                self._drop_before(stamp_ns)
        if label == CANCELLED:
            self._forget(stamp_ns + 1)
            self.cancelled.append(stamp_ns)
            return
        self._labels.append((stamp_ns, label))

    def _drop_before(self, stamp_ns: int) -> None:
        """Forget the labels and the samples before ``stamp_ns``: they belong to an
        exploration that stopped (see module); counted in ``stale_drops``."""
        self.stale_drops += 1
        self._forget(stamp_ns)

    def _forget(self, stamp_ns: int) -> None:
        """Forget the labels, the counts and the samples stamped before ``stamp_ns``."""
        self._labels.clear()
        self.dropped.clear()
        self.dropped_labels.clear()
        kept = [(t >= stamp_ns, t, w) for t, w in zip(self._stamps, self._wrenches, strict=True)]
        self._stamps = [t[k] for k, t, _ in kept]
        self._wrenches = [w[k] for k, _, w in kept]

    def forget_idle(self, keep_s: float = IDLE_KEEP) -> None:
        """Before the first window label, keep only the last ``keep_s`` s (sensor time) of
        samples and joint states: the lead-in a first window may reach back into. A node
        that only compensates (no exploration running) then holds a bounded buffer."""
        opened = any(label.startswith(WINDOW_PREFIXES) for _, label in self._labels)
        if opened or self._last_stamp == _NO_STAMP:
            return
        cut = self._last_stamp - round(keep_s * 1e9)
        if self._stamps and (len(self._stamps[0]) == 0 or self._stamps[0][0] < cut):
            kept = [(t >= cut, t, w) for t, w in zip(self._stamps, self._wrenches, strict=True)]
            self._stamps = [t[k] for k, t, _ in kept if k.any()]
            self._wrenches = [w[k] for k, _, w in kept if k.any()]
        if self._joint_states and self._joint_states[0][0] < cut:
            self._joint_states = [(t, q) for t, q in self._joint_states if t >= cut]

    def done_stamp(self) -> int | None:
        """Stamp (ns) of the ``done`` that ends this exploration
        (``com_core.contract.done_stamp``)."""
        return done_stamp(self._labels)

    def count_dropped(self, what: str, n: int, labels: bool = False) -> None:
        """Count ``n`` samples (or ``labels``) dropped before they reached this inbox
        (e.g. bytes that do not decode); the solution says so, as for the input it drops
        itself."""
        if labels:
            if n:
                self.dropped_labels[what] = self.dropped_labels.get(what, 0) + n
        else:
            self._count(what, n)

    def _count(self, what: str, n: int) -> None:
        if n:
            self.dropped[what] = self.dropped.get(what, 0) + n

    def add_joint_state(
        self, stamp_ns: int, names: Sequence[str], positions: Sequence[float]
    ) -> bool:
        """A joint state (sensor_msgs/JointState: names, positions in rad or m; any of the
        robot's joints) at ``stamp_ns``, for the gravity of each window under the
        kinematic information; False (nothing kept) when the positions are not one per
        name."""
        if len(positions) != len(names):
            return False
        stamp, latest = int(stamp_ns), self._joint_latest
        self._joint_states.append((stamp, dict(zip(names, positions, strict=True))))
        for name in names:
            latest[name] = max(latest.get(name, stamp), stamp)
        return True

    def joint_states_until(self, names: Iterable[str]) -> int | None:
        """Stamp (ns) up to which a joint state of each of ``names`` has come (the
        earliest of their latest: each publisher's stream, an arm's and a gripper's, comes
        on its own), or None while one of them has none."""
        latest = self._joint_latest
        stamps = [latest.get(name) for name in names]
        return None if None in stamps else min(stamps, default=None)
