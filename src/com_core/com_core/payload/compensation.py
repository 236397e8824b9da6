"""The compensated wrench stream: each sensor sample less the bias and the gravity wrench of
the hand and the payload at that sample's orientation (docs/design.md, Compensated wrench).

A ``Compensator`` holds a ``payload.Payload`` (from an estimate, or a payload file) and the
robot model (``kinematics.RobotModel``). At each joint state (stamp t_k, positions q_k,
velocities v_k) it takes the payload's wrench there, W_k = ``payload.payload_wrench`` at
the sensor frame's orientation from forward kinematics, and its rate, dW_k = (W(q_k +
v_k h) - W_k) / h. For a sample stamped t it returns

    w_contact = w - W(t)      (N, N m; sensor frame)

(w corrected first by the sensor's hysteresis gain and calibration in place, when it has
them: ``correction``, ``sensing.calibration``) with W(t) interpolated linearly between the
joint states around t or, past the latest (a sample usually arrives before the joint
state after it), W_k + dW_k (t - t_k), for at most ``max_age`` s; a sample further out
is not compensated and is counted (``stale``): its orientation is not known. Linear in
time between 100 Hz joint states, W is off by |W| (omega dt)^2 / 8 at most: 0.15 mN for
12 N turning at 1 rad/s, against 100 mN of a sample's noise; and the kinematics run at
the joint states' rate, not the sensor's. A faster arm (Franka's 1 kHz) is kept every
``min_spacing`` (4 ms, 250 Hz) only: denser states would change W by less than 0.04 mN
there and cost the kinematics four times over.

In motion: with a payload whose hand's inertia is known (an exploration in motion; the
object's too, or, when the motion did not identify it, a point mass at its COM), W_k is
their whole wrench, W_k = Y(q_k, v_k, a_k) (pi_hand + pi_object) + b
(``robot.dynamics``: gravity and the inertial wrench), a_k the joint accelerations by
the backward difference of the velocities of the last two kept states, and a sample
stamped t takes W at t - ``payload.delay`` (the wrench's stamps lag the joint states'),
and the robot model's gravity (an exploration in motion fits no mounting nor base tilt;
a payload's are not applied here). The backward difference lags the acceleration by half
the spacing of the kept states (2 ms at 4 ms): 0.3 rad/s^2 at the excitation's jerk.
Without the hand's inertia the wrench is static: the inertial wrench of the hand and the
payload while the arm accelerates is not removed (docs/design.md says how large it is in
the exploration's moves). A sample costs a few float operations: the estimator node
calls this per message, inside the 1 ms its latency may add.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from com_core.payload.model import Payload, payload_wrench
from com_core.robot.dynamics import inertial_parameters, sensor_regressor
from com_core.robot.model import RobotModel

__all__ = ["MAX_JOINT_STATE_AGE", "RATE_STEP", "Compensator"]

MAX_JOINT_STATE_AGE = 0.05
"""s; a sample more than this past the latest joint state (or before the oldest kept) is
not compensated: 5 periods of a 100 Hz joint state stream."""
RATE_STEP = 1e-3
"""s; the step h of the payload wrench's rate along the joint velocities."""


@dataclass
class Compensator:
    """Compensates samples with ``payload`` at the orientation ``robot`` gives for the
    latest joint states (see module); counts what it compensated and what it left out.
    ``correction`` (6 rows of 6): what corrects a reading (the sensor's calibration in
    place and its hysteresis's gain, ``sensing.calibration.reading_correction``), each
    sample read through it first; None: as read.

    ``add_joint_state`` takes a sensor_msgs/JointState's content (names in any order;
    velocities optional: without them W is held past the latest state); states come in
    time order (one stamped before the latest restarts the track, as a restarted clock
    does)."""

    payload: Payload
    robot: RobotModel
    source: str = ""
    max_age: float = MAX_JOINT_STATE_AGE
    correction: tuple[tuple[float, ...], ...] | None = None
    min_spacing: float = 0.004
    keep: int = 16
    compensated: int = 0
    stale: int = 0
    # per joint state: stamp ns, W and its rate (6 floats each), and the state (q, v)
    # itself, from which another payload's W is computed (``take_over``)
    _track: deque[
        tuple[int, list[float], list[float], NDArray[np.float64], NDArray[np.float64] | None]
    ] = field(default_factory=deque, repr=False)
    _order: tuple[tuple[str, ...], list[int] | None] = field(default=((), None), repr=False)
    _load: NDArray[np.float64] | None = field(default=None, repr=False)  # pi, in motion

    def add_joint_state(
        self,
        stamp_ns: int,
        names: Sequence[str],
        positions: Sequence[float],
        velocities: Sequence[float] = (),
    ) -> bool:
        """Keep a joint state; False (and nothing kept) when it lacks a joint that moves
        the sensor (``RobotModel.chain_names``; the others hold 0), or its positions are
        not one finite number per name. Velocities of another length, or not finite, count
        as absent. A state stamped less than ``min_spacing`` s after the latest kept (or
        as it: a republished one) is not kept."""
        names = tuple(names)
        if len(positions) != len(names) or not all(map(math.isfinite, positions)):
            return False
        if names != self._order[0]:
            index = {name: k for k, name in enumerate(names)}
            chain = all(n in index for n in self.robot.chain_names)
            # each model joint's index in the message; len(names): not in it (holds 0)
            order = [index.get(n, len(names)) for n in self.robot.joint_names]
            self._order = (names, order if chain else None)
        order = self._order[1]
        if order is None:
            return False
        q = np.append(np.asarray(positions, dtype=np.float64), 0.0)[order]
        usable = len(velocities) == len(names) and all(map(math.isfinite, velocities))
        v = np.append(np.asarray(velocities, dtype=np.float64), 0.0)[order] if usable else None
        if self._track and 0 <= int(stamp_ns) - self._track[-1][0] < self.min_spacing * 1e9:
            return True
        self._add(int(stamp_ns), q, v)
        return True

    def _add(self, stamp: int, q: NDArray[np.float64], v: NDArray[np.float64] | None) -> None:
        if self._track and stamp < self._track[-1][0]:  # a restarted clock
            self._track.clear()
        a = None
        if v is not None and self._track:
            before, *_, v_before = self._track[-1]
            dt = (stamp - before) * 1e-9
            a = (v - v_before) / dt if v_before is not None and 0 < dt <= self.max_age else None
        wrench = self._wrench(q, v, a)
        rate = (
            (self._wrench(q + v * RATE_STEP, v, a) - wrench) / RATE_STEP
            if v is not None and np.any(v)
            else np.zeros(6)
        )
        self._track.append((stamp, wrench.tolist(), rate.tolist(), q, v))
        if len(self._track) > self.keep:
            self._track.popleft()

    def _wrench(
        self,
        q: NDArray[np.float64],
        v: NDArray[np.float64] | None,
        a: NDArray[np.float64] | None,
    ) -> NDArray[np.float64]:
        """W at joint positions q, velocities v and accelerations a (None: zero): the
        payload's static wrench, or with its inertias its whole wrench (see module)."""
        p = self.payload
        if not p.in_motion:
            return payload_wrench(p, self.robot.sensor_rotation_of(q))
        if self._load is None:
            inertia = np.zeros((3, 3)) if p.inertia is None else p.inertia  # a point mass
            self._load = inertial_parameters(p.mass, p.com, inertia) + inertial_parameters(
                p.hand_mass, p.hand_com, p.hand_inertia
            )
        still = np.zeros_like(q)
        Y = sensor_regressor(self.robot, q, still if v is None else v, still if a is None else a)
        return Y @ self._load + p.bias

    def take_over(self, previous: Compensator) -> None:
        """Go on from ``previous`` (another payload, the robot model received again): its
        joint states, for a model of the same joints, and its counts."""
        if previous.robot.joint_names == self.robot.joint_names:
            for stamp, _, _, q, v in previous._track:
                self._add(stamp, q, v)
        self.compensated, self.stale = previous.compensated, previous.stale

    def payload_wrench_at(self, stamp_ns: int) -> list[float] | None:
        """W (6,; N, N m): the bias, the hand and the payload at the orientation at
        ``stamp_ns``, or None when the joints there are not known (see module)."""
        track = self._track
        if not track or stamp_ns < track[0][0]:
            return None
        latest, wrench, rate, *_ = track[-1]
        if stamp_ns >= latest:
            age = (stamp_ns - latest) * 1e-9
            if age > self.max_age:
                return None
            return [w + r * age for w, r in zip(wrench, rate, strict=True)]
        k = len(track) - 1
        while track[k - 1][0] > stamp_ns:  # from the newest: samples come just after states
            k -= 1
        (a, before, *_), (b, after, *_) = track[k - 1], track[k]
        if (b - a) * 1e-9 > self.max_age:
            return None
        u = (stamp_ns - a) / (b - a)
        return [x + u * (y - x) for x, y in zip(before, after, strict=True)]

    def compensate(self, stamp_ns: int, wrench: Sequence[float]) -> list[float] | None:
        """The contact wrench (6,; N, N m, sensor frame) of a sample, or None (counted in
        ``stale``) when its orientation is not known."""
        gravity = self.payload_wrench_at(stamp_ns - round(self.payload.delay * 1e9))
        if gravity is None:
            self.stale += 1
            return None
        self.compensated += 1
        if self.correction is not None:
            wrench = [sum(c * w for c, w in zip(row, wrench, strict=True))
                      for row in self.correction]  # fmt: skip
        return [w - g for w, g in zip(wrench, gravity, strict=True)]
