"""The ports the run drives, as protocols: what a ROS adapter (or a test's fake) gives.

- ``RunClock``: the run's time (sim time when the robot runs on it) and its waits;
- ``JointFeed``: the arm's latest joint states, merged per joint from any publishers;
- ``ArmPort``: a trajectory controller (its action, or its topic), one trajectory at a time;
- ``GripperPort``: a gripper's driver (its action, or its topic).

Adapters of this project: ``exploration_sequencer.ros_arm`` and ``ros_gripper``; the
sequencer picks one of each per run (``arm_interface``, ``gripper_interface``), so another
driver is one more adapter (MoveIt's simple controller manager has that shape).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

__all__ = ["ArmPort", "GripperOutcome", "GripperPort", "JointFeed", "JointPath", "RunClock"]


@dataclass(frozen=True)
class JointPath:
    """A joint trajectory as sent: the joints ``names``, from ``stamp_ns`` (the run's time,
    ns; 0: when the controller receives it), through ``points``: (s from the start,
    positions, velocities, accelerations), rad, rad/s, rad/s^2."""

    names: tuple[str, ...]
    points: tuple[tuple[float, Sequence[float], Sequence[float], Sequence[float]], ...]
    stamp_ns: int = 0

    @property
    def duration_ns(self) -> int:
        """ns from the start to the last point."""
        return round(self.points[-1][0] * 1e9)


@dataclass(frozen=True)
class GripperOutcome:
    """How a gripper command ended: position (m or rad), effort (N), and whether the
    fingers stalled (on an object) or reached the goal."""

    position: float
    effort: float
    stalled: bool
    reached_goal: bool


class RunClock(Protocol):
    def now_ns(self) -> int:
        """The run's time now, ns."""
        ...

    def wait(self, done: Callable[[], object], what: str, wall_timeout: float | None) -> None:
        """Until ``done()``; RunError when the robot stops answering, TimeoutRunError after
        ``wall_timeout`` s (None: no limit), CancelledRunError on a cancel."""
        ...

    def sleep_until(self, stamp_ns: int, what: str) -> None:
        """Until the run's time ``stamp_ns``."""
        ...


class JointFeed(Protocol):
    joints: Mapping[str, tuple[float, float]]
    """Each joint's latest (position, velocity)."""

    def rested_since(
        self, names: Sequence[str], resting: Callable[[str, float, float], bool]
    ) -> int | None:
        """The stamp (ns) from which every joint of ``names`` has been resting by its own
        samples, None if one is not resting now."""
        ...


class ArmPort(Protocol):
    def send(self, path: JointPath, what: str) -> None:
        """Send ``path`` (it replaces the running one); RunError when the controller does
        not take it."""
        ...

    def finished(self, wall_timeout: float) -> None:
        """Wait for the last path's result, within ``wall_timeout`` s: RunError unless the
        controller says it succeeded (nothing to wait for on a topic)."""
        ...

    def forget(self) -> None:
        """Drop the last path's result (the run goes on from where the arm is)."""
        ...


class GripperPort(Protocol):
    def command(self, position: float, max_effort: float, what: str) -> GripperOutcome | None:
        """Move the fingers to ``position`` with at most ``max_effort`` N; the outcome
        once they stop (None where the driver says nothing: a topic); RunError when the
        driver refuses or does not answer."""
        ...
