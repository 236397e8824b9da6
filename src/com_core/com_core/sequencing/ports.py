"""The ports the run drives, as protocols: what a ROS adapter (or a test's fake) gives.

- ``RunClock``: the run's time (sim time when the robot runs on it) and its waits;
- ``JointFeed``: the arm's latest joint states, merged per joint from any publishers;
- ``ArmPort``: a trajectory controller (its action, or its topic), one trajectory at a time;
- ``GripperPort``: a gripper's driver (its action, or its topic);
- ``LabelSink``: the pose labels the estimator and the recorder read;
- ``RunRecorder``: the run's bag, and the wrenches it sees while a step runs;
- ``EstimatorPort``: the estimator's settings, reset, payload files and answers;
- ``RunLog``: where the run says what it does.

Adapters of this project: ``exploration_sequencer.ros_arm``, ``ros_gripper``,
``ros_labels``, ``ros_estimator``, ``io_node`` (clock and joint states) and
``recorder_process``; the sequencer picks an arm and a gripper adapter per run
(``arm_interface``, ``gripper_interface``), so another driver is one more adapter
(MoveIt's simple controller manager has that shape).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

__all__ = [
    "ArmPort",
    "EstimatorAnswer",
    "EstimatorPort",
    "GripperOutcome",
    "GripperPort",
    "JointFeed",
    "JointPath",
    "LabelSink",
    "RunClock",
    "RunLog",
    "RunRecorder",
]


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


@dataclass(frozen=True)
class EstimatorAnswer:
    """The estimator's answer to a run: its ``status`` (OK, WARN or ERROR), ``message``,
    ``values`` (its diagnostic keys, ``com_core.estimation.runs.solution``) and the ``frame``
    of its estimate."""

    status: str
    message: str
    values: Mapping[str, str]
    frame: str


class RunClock(Protocol):
    cancel: threading.Event
    """Once set, every ``wait`` raises CancelledRunError."""
    sim_timeout: float
    """s (wall) ``wait`` goes without the arm's joint states before RunError."""

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
    arm_joints: frozenset[str]
    """The joints whose states say the arm answers (empty: any joint)."""

    def joints_over(self, start_ns: int, end_ns: int) -> dict[str, float]:
        """Each joint's mean position (rad, m) over its states stamped in [start, end)."""
        ...

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


class LabelSink(Protocol):
    def publish(self, stamp_ns: int, label: str) -> None:
        """Publish ``label`` from ``stamp_ns`` (the run's time) and wait until its readers
        have it (a warning when one does not acknowledge it in time)."""
        ...


class RunRecorder(Protocol):
    recording: bool
    latest_ns: int
    """Newest stamp (ns) of a captured topic's messages; 0 before one."""

    def start(self, bag_dir: Path) -> None:
        """Begin recording to ``bag_dir`` (which must not exist)."""
        ...

    def stop(self) -> dict[str, int]:
        """Close the bag; messages written per topic. RuntimeError when the recording
        failed."""
        ...

    def failure(self) -> str:
        """Why the recording's writer stopped ('' while it writes), e.g. a full disk."""
        ...

    def capture(self, topic: str) -> None:
        """Also keep ``topic``'s raw (CDR) messages until ``release``."""
        ...

    def release(self, topic: str) -> list[bytes]:
        """Stop keeping ``topic``'s messages; the ones kept since ``capture``."""
        ...


class EstimatorPort(Protocol):
    def settings(self, names: Sequence[str]) -> dict[str, Any]:
        """The estimator's parameters ``names`` by name."""
        ...

    def set(self, name: str, value: object) -> None:
        """Set the parameter ``name`` for this run; RunError when it is refused."""
        ...

    def restore(self) -> None:
        """The parameters a run set, as they were (a failure is logged)."""
        ...

    def reset(self) -> None:
        """A new exploration on the estimator."""
        ...

    def save_payload(self, bag: Path) -> None:
        """Its payload files beside the bag (a failure is logged)."""
        ...

    def heard(self) -> tuple[int, int]:
        """(the stamp of the latest wrench, and of the latest label, it has heard), ns;
        a large negative number before one."""
        ...

    def clear_answers(self) -> None:
        """Forget its answers so far: only the run's from here on."""
        ...

    def answer(self, done_ns: int) -> EstimatorAnswer | None:
        """Its answer to the ``done`` label stamped ``done_ns``, None before it comes."""
        ...


class RunLog(Protocol):
    def info(self, message: str) -> object: ...

    def warning(self, message: str) -> object: ...

    def error(self, message: str) -> object: ...
