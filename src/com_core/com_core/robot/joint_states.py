"""Joint states merged per joint from any number of publishers (no ROS).

A real arm's /joint_states comes from several publishers: the arm's
joint_state_broadcaster (1 kHz on a Franka), a gripper's own (30 Hz), or a merger that
restamps them all. Each message names only its publisher's joints, so no message is the
whole state. ``JointStates`` keeps every joint on its own: its latest (stamp ns, position
rad or m, velocity rad/s or m/s) and its samples of the last ``keep`` s (its own stamps),
from which

- ``latest`` is the merged state, each joint's latest sample whatever published it;
- ``mean_positions`` is a window's mean position of each joint over its own samples in
  the window, so a 30 Hz gripper and a 1 kHz arm each count for their joints;
- ``rested_since`` is when each of the given joints came to rest by its own samples.

A message without one velocity per name (a publisher that sends none) gives its joints
velocity 0; a non-finite velocity counts as 0 too, and a non-finite position is not kept.
A joint's sample stamped more than ``TIME_RESET_NS`` before its latest is a restarted
clock: that joint's samples start again from it. The methods may be called from another
thread than ``add``'s.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence

__all__ = ["TIME_RESET_NS", "JointStates"]

TIME_RESET_NS = 1_000_000_000
"""ns; a joint's sample stamped this much before its latest starts a new clock."""

Sample = tuple[int, float, float]
"""(stamp ns, position rad or m, velocity rad/s or m/s) of one joint."""


class JointStates:
    """Joint states merged per joint (see module); ``keep`` (s) is how far back each
    joint's samples go from its latest stamp."""

    def __init__(self, keep: float = 2.0) -> None:
        self.keep_ns = round(keep * 1e9)
        self._samples: dict[str, deque[Sample]] = {}
        self._latest: dict[str, tuple[float, float]] = {}
        self._lock = threading.Lock()

    def add(
        self,
        stamp_ns: int,
        names: Sequence[str],
        positions: Sequence[float],
        velocities: Sequence[float] = (),
    ) -> bool:
        """Merge one message's joints (a sensor_msgs/JointState's names, positions and
        velocities) at ``stamp_ns``; False (nothing kept) when the positions are not one
        per name. A sample stamped as one the joint already has replaces it."""
        if len(positions) != len(names):
            return False
        if len(velocities) != len(names):
            velocities = [0.0] * len(names)
        stamp = int(stamp_ns)
        with self._lock:
            latest = dict(self._latest)
            for name, q, v in zip(names, positions, velocities, strict=True):
                if not math.isfinite(q):
                    continue
                sample = (stamp, float(q), float(v) if math.isfinite(v) else 0.0)
                samples = self._samples.setdefault(name, deque())
                if samples and stamp < samples[-1][0] - TIME_RESET_NS:
                    samples.clear()
                _insert(samples, sample)
                while samples[0][0] < samples[-1][0] - self.keep_ns:
                    samples.popleft()
                latest[name] = samples[-1][1:]
            self._latest = latest  # a new dict: a reader's never changes under it
        return True

    @property
    def latest(self) -> Mapping[str, tuple[float, float]]:
        """The merged state: {name: (position, velocity)} of each joint's latest sample,
        in the order the joints were first heard; {} before any."""
        return self._latest

    def stamps(self) -> dict[str, int]:
        """Each joint's latest stamp, ns."""
        with self._lock:
            return {name: samples[-1][0] for name, samples in self._samples.items() if samples}

    def samples(self, name: str) -> list[Sample]:
        """The kept samples of joint ``name`` in stamp order; [] for a joint not heard."""
        with self._lock:
            return list(self._samples.get(name, ()))

    def mean_positions(self, start_ns: int, end_ns: int) -> dict[str, float]:
        """Each joint's mean position (rad, m) over its own samples stamped in
        [start_ns, end_ns): a window's own, not a reading taken after it, when the next
        move may have begun; a joint with none inside gives its latest position."""
        with self._lock:
            return {
                name: _mean_position(samples, start_ns, end_ns)
                for name, samples in self._samples.items()
                if samples
            }

    def rested_since(
        self, names: Iterable[str], resting: Callable[[str, float, float], bool]
    ) -> int | None:
        """The stamp (ns) from which every joint of ``names`` has been resting by its own
        samples (``resting(name, position, velocity)`` true for each since, back to its
        oldest kept): the latest of the joints' own first resting stamps. None when a
        joint has no sample or its latest is not resting, or ``names`` is empty."""
        since = None
        with self._lock:
            for name in names:
                first = None
                for stamp, q, v in reversed(self._samples.get(name, ())):
                    if not resting(name, q, v):
                        break
                    first = stamp
                if first is None:
                    return None
                since = first if since is None else max(since, first)
        return since


def _insert(samples: deque[Sample], sample: Sample) -> None:
    """Put ``sample`` into ``samples`` (in stamp order) where its stamp goes; one of the
    same stamp is replaced."""
    k = len(samples)
    while k and samples[k - 1][0] > sample[0]:
        k -= 1
    if k and samples[k - 1][0] == sample[0]:
        samples[k - 1] = sample
    elif k == len(samples):
        samples.append(sample)
    else:
        samples.insert(k, sample)


def _mean_position(samples: deque[Sample], start_ns: int, end_ns: int) -> float:
    inside = [q for stamp, q, _ in samples if start_ns <= stamp < end_ns]
    return sum(inside) / len(inside) if inside else samples[-1][1]
