"""The arm's joints: position control along quintic joint trajectories
(``wrench_sim.trajectory``), and whether the arm has come to rest."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
import pybullet
from numpy.typing import NDArray

from wrench_sim.scene import Scene
from wrench_sim.trajectory import JointLimits, QuinticTrajectory, trajectory_from_command

__all__ = ["ArmDriver"]

_POSITION_GAIN = 0.1
_VELOCITY_GAIN = 1.0
_SETTLE_SPEED = 2e-3  # rad/s; arm at rest below this joint speed...
_SETTLE_STEPS = 20  # ...for this many steps


class ArmDriver:
    """Drives the arm's joints of ``scene`` with pybullet's position control, at the URDF's
    effort limits, and puts them at ``home`` (rad, ``arm_joints`` order), held there."""

    def __init__(self, scene: Scene, home: NDArray[np.float64]) -> None:
        self._scene = scene
        c, body, arm = scene.client, scene.robot_body, scene.arm
        # Bound once: BulletClient looks the function up on every call, a hot path here.
        self._set_motors = functools.partial(
            pybullet.setJointMotorControlArray, physicsClientId=c._client
        )
        self.limits = JointLimits(
            scene.config.robot.arm_joints,
            np.array([c.getJointInfo(body, j)[8] for j in arm]),
            np.array([c.getJointInfo(body, j)[9] for j in arm]),
            np.array([c.getJointInfo(body, j)[11] for j in arm]),
        )
        self._efforts = [c.getJointInfo(body, j)[10] for j in arm]
        self._trajectory: QuinticTrajectory | None = None
        self._queued: QuinticTrajectory | None = None  # starts later (command)
        zeros = np.zeros(len(arm))
        self._set_point = (home.copy(), zeros, zeros)
        self._still_steps = 0
        for joint, q in zip(arm, home, strict=True):
            c.resetJointState(body, joint, q)
        self._hold(home, zeros)

    def command(
        self,
        joint_names: Sequence[str],
        times: Sequence[float],
        positions: Sequence[Sequence[float]],
        start_time: float,
        now: float,
        velocities: Sequence[Sequence[float]] | None = None,
        accelerations: Sequence[Sequence[float]] | None = None,
    ) -> float:
        """Follow a joint trajectory from ``start_time`` (s, simulated; ``now`` if earlier),
        replacing any running or queued one; a running one goes on until then. Returns the
        simulated time (s) at which the last waypoint is reached; raises ValueError for a
        malformed or unreachable command (see ``ArmWorld.command_arm``)."""
        start = max(start_time, now)
        running = self._trajectory
        state = running.sample(start) if running and start > now else self._set_point
        trajectory = trajectory_from_command(
            joint_names, times, positions, self.limits, start, state, velocities, accelerations
        )
        if start > now:
            self._queued = trajectory
        else:
            self._trajectory, self._queued = trajectory, None
        self._still_steps = 0
        return trajectory.end_time

    def update(self, now: float) -> None:
        """Before the step starting at ``now`` (s): start a queued trajectory that is due and
        set the motors to the running one's point."""
        if self._queued is not None and now >= self._queued.start_time:
            self._trajectory, self._queued = self._queued, None
        if self._trajectory is not None:
            self._follow(now)

    @property
    def moving(self) -> bool:
        """A trajectory is running."""
        return self._trajectory is not None

    @property
    def idle(self) -> bool:
        """No trajectory is running or queued."""
        return self._trajectory is None and self._queued is None

    @property
    def settled(self) -> bool:
        """No trajectory is running and the joints have been still for 20 ms."""
        return self.idle and self._still_steps >= _SETTLE_STEPS

    def track_rest(self, steps: int) -> None:
        """Count the ``steps`` since the last call as still if no trajectory runs and every
        joint is slower than 2e-3 rad/s now."""
        scene = self._scene
        speeds = [
            abs(state[1]) for state in scene.client.getJointStates(scene.robot_body, scene.arm)
        ]
        if self._trajectory is None and max(speeds) < _SETTLE_SPEED:
            self._still_steps += steps
        else:
            self._still_steps = 0

    def joint_state(self) -> tuple[list[float], list[float], list[float]]:
        """Positions (rad), velocities (rad/s) and efforts (N m) of ``arm_joints``."""
        scene = self._scene
        states = scene.client.getJointStates(scene.robot_body, scene.arm)
        return [s[0] for s in states], [s[1] for s in states], [s[3] for s in states]

    def _follow(self, t: float) -> None:
        assert self._trajectory is not None
        position, velocity, acceleration = self._trajectory.sample(t)
        self._set_point = (position, velocity, acceleration)
        self._hold(position, velocity)
        if t >= self._trajectory.end_time:
            self._trajectory = None

    def _hold(self, position: NDArray[np.float64], velocity: NDArray[np.float64]) -> None:
        arm = self._scene.arm
        self._set_motors(
            self._scene.robot_body,
            arm,
            pybullet.POSITION_CONTROL,
            targetPositions=position.tolist(),
            targetVelocities=velocity.tolist(),
            forces=self._efforts,
            positionGains=[_POSITION_GAIN] * len(arm),
            velocityGains=[_VELOCITY_GAIN] * len(arm),
        )
