"""A FollowJointTrajectory goal's tolerances and how it ends, as ros2_control's
joint_trajectory_controller (Jazzy) judges them; no ROS.

While the trajectory runs, each joint's measured position must stay within its path
tolerance of the desired one, else the goal aborts with PATH_TOLERANCE_VIOLATED. From its
end time on, each joint within its goal tolerance (position of the last point, and a speed
under the velocity tolerance) succeeds it; still outside ``goal_time_tolerance`` s after the
end, it aborts with GOAL_TOLERANCE_VIOLATED (0: waits as long as it takes). A tolerance of 0
in the goal takes the controller's default; a negative one is not checked.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "GOAL_TOLERANCE_VIOLATED",
    "PATH_TOLERANCE_VIOLATED",
    "SUCCESSFUL",
    "Tolerance",
    "TrajectoryGoal",
]

# control_msgs/action/FollowJointTrajectory's result codes
SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5


@dataclass(frozen=True)
class Tolerance:
    """One joint's tolerance: position (rad) and velocity (rad/s); 0 or less: unchecked."""

    position: float = 0.0
    velocity: float = 0.0


def tolerances(
    names: Sequence[str], given: Mapping[str, tuple[float, float]], default: Tolerance
) -> list[Tolerance]:
    """Each joint's tolerance: ``given`` by name (position, velocity; 0: the ``default``'s,
    negative: unchecked), else the ``default``."""
    out = []
    for name in names:
        position, velocity = given.get(name, (0.0, 0.0))
        out.append(Tolerance(
            default.position if position == 0.0 else position,
            default.velocity if velocity == 0.0 else velocity,
        ))  # fmt: skip
    return out


def _outside(
    names: Sequence[str],
    tolerance: Sequence[Tolerance],
    error: NDArray[np.float64],
    speed: NDArray[np.float64] | None,
) -> str | None:
    """The first joint outside its tolerance, said with its error; None when all are in."""
    for name, t, e, v in zip(names, tolerance, error, speed if speed is not None else error,
                             strict=True):  # fmt: skip
        if t.position > 0.0 and abs(e) > t.position:
            return f"{name} is {e:+.3g} rad from where it should be (tolerance {t.position:g})"
        if speed is not None and t.velocity > 0.0 and abs(v) > t.velocity:
            return f"{name} still moves at {v:+.3g} rad/s (tolerance {t.velocity:g})"
    return None


class TrajectoryGoal:
    """A running goal over the joints ``names``: its trajectory ends at ``end_time`` (s);
    ``path`` and ``goal`` tolerances per joint; ``goal_time`` s of leeway after the end (0:
    no limit). ``check`` says when and how it ends."""

    def __init__(
        self,
        names: Sequence[str],
        end_time: float,
        path: Sequence[Tolerance],
        goal: Sequence[Tolerance],
        goal_time: float,
    ) -> None:
        self.names = tuple(names)
        self.end_time = end_time
        self._path, self._goal, self._goal_time = list(path), list(goal), goal_time

    def check(
        self,
        now: float,
        desired: NDArray[np.float64],
        positions: NDArray[np.float64],
        velocities: NDArray[np.float64],
        final: NDArray[np.float64],
    ) -> tuple[int, str] | None:
        """At sim time ``now`` (s), with the ``desired`` positions, the measured
        ``positions`` and ``velocities`` and the trajectory's ``final`` positions (rad, rad/s,
        in ``names`` order): None while the goal runs, else (error code, error string)."""
        if now < self.end_time:
            why = _outside(self.names, self._path, positions - desired, None)
            return None if why is None else (PATH_TOLERANCE_VIOLATED, f"path tolerance: {why}")
        why = _outside(self.names, self._goal, positions - final, velocities)
        if why is None:
            return SUCCESSFUL, ""
        late = now - self.end_time
        if self._goal_time > 0.0 and late > self._goal_time:
            return GOAL_TOLERANCE_VIOLATED, f"goal tolerance, {late:.3f} s after the end: {why}"
        return None
