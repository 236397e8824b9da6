"""The compensated wrench stream: each sensor sample less the bias and the gravity wrench of
the hand and the payload at that sample's orientation (docs/design.md, Compensated wrench).

A ``Compensator`` holds a ``payload.Payload`` (from an estimate, or a payload file), the
robot model (``kinematics.RobotModel``) and the latest joint states (``JointTrack``). For
a sample stamped t it takes the joint positions at t (interpolated between the joint
states around t; past the latest one, extrapolated with its velocities), the sensor
frame's orientation there by forward kinematics, and returns

    w_contact = w - b - A(g_s(t)) (theta_hand + theta_payload)      (N, N m; sensor frame)

with ``payload.payload_wrench``. The wrench is static: the inertial wrench of the hand
and the payload while the arm accelerates is not removed (docs/design.md says how large
it is in the exploration's moves). A sample whose joint state is older than ``max_age``
is not compensated and is counted (``stale``): its orientation is not known.

Plain numpy and pinocchio (through ``RobotModel``); the estimator node calls it per
message, so a sample costs one forward kinematics only when the joints moved.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .kinematics import RobotModel
from .payload import Payload, payload_wrench

__all__ = ["MAX_JOINT_STATE_AGE", "Compensator", "JointTrack"]

MAX_JOINT_STATE_AGE = 0.05
"""s; a sample more than this past the latest joint state (or before the oldest kept) is
not compensated: 5 periods of a 100 Hz joint state stream."""


@dataclass
class JointTrack:
    """The latest joint states of ``names`` (a robot model's joints, in its order), and the
    positions at a stamp.

    ``add`` takes a sensor_msgs/JointState's content (names in any order; velocities
    optional); states must come in time order (a state stamped before the latest one
    restarts the track, as a restarted clock does)."""

    names: Sequence[str]
    max_age: float = MAX_JOINT_STATE_AGE
    keep: int = 16
    _stamps: deque[int] = field(default_factory=deque, repr=False)
    _positions: deque[NDArray[np.float64]] = field(default_factory=deque, repr=False)
    _velocity: NDArray[np.float64] | None = field(default=None, repr=False)
    _order: tuple[tuple[str, ...], list[int] | None] = field(default=((), None), repr=False)

    def add(
        self,
        stamp_ns: int,
        names: Sequence[str],
        positions: Sequence[float],
        velocities: Sequence[float] = (),
    ) -> bool:
        """Keep a joint state; False (and nothing kept) when it lacks one of ``names``."""
        names = tuple(names)
        if names != self._order[0]:
            index = {name: k for k, name in enumerate(names)}
            self._order = (names, [index[n] for n in self.names if n in index])
            if len(self._order[1] or ()) != len(self.names):
                self._order = (names, None)
        order = self._order[1]
        if order is None:
            return False
        if self._stamps and stamp_ns <= self._stamps[-1]:
            self._stamps.clear()
            self._positions.clear()
        self._stamps.append(int(stamp_ns))
        self._positions.append(np.asarray(positions, dtype=np.float64)[order])
        self._velocity = (
            np.asarray(velocities, dtype=np.float64)[order]
            if len(velocities) == len(names)
            else None
        )
        if len(self._stamps) > self.keep:
            self._stamps.popleft()
            self._positions.popleft()
        return True

    @property
    def latest_stamp(self) -> int | None:
        return self._stamps[-1] if self._stamps else None

    def at(self, stamp_ns: int) -> NDArray[np.float64] | None:
        """Joint positions (rad, m; ``names`` order) at ``stamp_ns``: interpolated between
        the states around it, or extrapolated from the latest with its velocities (held
        without them) up to ``max_age`` s past it; None further out, or before the
        oldest state kept."""
        stamps = self._stamps
        if not stamps or stamp_ns < stamps[0]:
            return None
        latest = stamps[-1]
        if stamp_ns >= latest:
            age = (stamp_ns - latest) * 1e-9
            if age > self.max_age:
                return None
            if self._velocity is None or age == 0.0:
                return self._positions[-1]
            return self._positions[-1] + self._velocity * age
        k = len(stamps) - 1
        while stamps[k - 1] > stamp_ns:  # from the newest: samples come just after states
            k -= 1
        a, b = stamps[k - 1], stamps[k]
        if (b - a) * 1e-9 > self.max_age:
            return None
        u = (stamp_ns - a) / (b - a)
        return self._positions[k - 1] + u * (self._positions[k] - self._positions[k - 1])


@dataclass
class Compensator:
    """Compensates samples with ``payload`` at the orientation ``robot`` gives for the
    joints of ``track`` (see module); counts what it compensated and what it left out."""

    payload: Payload
    robot: RobotModel
    track: JointTrack
    source: str = ""
    compensated: int = 0
    stale: int = 0
    _last: tuple[NDArray[np.float64], NDArray[np.float64]] | None = field(default=None, repr=False)

    @staticmethod
    def of(
        payload: Payload, robot: RobotModel, source: str, max_age: float = MAX_JOINT_STATE_AGE
    ) -> Compensator:
        return Compensator(payload, robot, JointTrack(robot.joint_names, max_age), source)

    def payload_wrench_at(self, stamp_ns: int) -> NDArray[np.float64] | None:
        """The wrench (6,) of the bias, the hand and the payload at the orientation at
        ``stamp_ns``, or None when the joints are stale."""
        q = self.track.at(stamp_ns)
        if q is None:
            return None
        if self._last is not None and np.array_equal(self._last[0], q):
            return self._last[1]  # at rest: no forward kinematics
        wrench = payload_wrench(self.payload, self.robot.sensor_rotation_of(q))
        self._last = (q, wrench)
        return wrench

    def compensate(self, stamp_ns: int, wrench: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """The contact wrench (6,; N, N m, sensor frame) of a sample, or None (counted in
        ``stale``) when its orientation is not known."""
        gravity = self.payload_wrench_at(stamp_ns)
        if gravity is None:
            self.stale += 1
            return None
        self.compensated += 1
        return wrench - gravity
