"""The arm's joints: position control along joint trajectories as ros2_control's
joint_trajectory_controller runs them (``wrench_sim.trajectory``), and whether the arm has
come to rest."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
import pybullet
from numpy.typing import NDArray

from wrench_sim.scene import Scene
from wrench_sim.trajectory import JointLimits, SplineTrajectory, trajectory_from_command

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
        self._trajectory: SplineTrajectory | None = None
        zeros = np.zeros(len(arm))
        self._set_point = (home.copy(), zeros, zeros)
        self._still_steps = 0
        for joint, q in zip(arm, home, strict=True):
            c.resetJointState(body, joint, q)
        self._hold(home, zeros)

    def plan(
        self,
        joint_names: Sequence[str],
        times: Sequence[float],
        positions: Sequence[Sequence[float]],
        stamp: float,
        now: float,
        velocities: Sequence[Sequence[float] | None] | None = None,
        accelerations: Sequence[Sequence[float] | None] | None = None,
    ) -> SplineTrajectory:
        """The trajectory a command stamped ``stamp`` (s, simulated; 0: now) arriving at
        ``now`` would run, from the measured state (``wrench_sim.trajectory``); ValueError
        for a malformed or unreachable command (see ``ArmWorld.command_arm``)."""
        positions_now, velocities_now, _ = self.joint_state()
        return trajectory_from_command(
            joint_names, times, positions, self.limits, stamp, now,
            (positions_now, velocities_now), velocities, accelerations,
        )  # fmt: skip

    def command(self, *args, **kwargs) -> float:
        """Follow the trajectory ``plan`` gives for these arguments, replacing any running
        one at once; returns the simulated time (s) at which its last waypoint is reached.
        On ValueError the running one goes on."""
        self._trajectory = self.plan(*args, **kwargs)
        self._still_steps = 0
        return self._trajectory.end_time

    def hold(self) -> None:
        """Stop where the arm is: the running trajectory ends, the measured positions are
        held (the controller's ``set_hold_position``)."""
        here = np.array(self.joint_state()[0])
        zeros = np.zeros_like(here)
        self._trajectory = None
        self._set_point = (here, zeros, zeros)
        self._hold(here, zeros)

    @property
    def final(self) -> NDArray[np.float64]:
        """rad; where the running trajectory ends (else the held set point)."""
        if self._trajectory is not None:
            return self._trajectory.final
        return self._set_point[0].copy()

    def update(self, now: float) -> None:
        """Before the step starting at ``now`` (s): set the motors to the running
        trajectory's point."""
        if self._trajectory is not None:
            self._follow(now)

    @property
    def set_point(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The controller's desired positions (rad) and velocities (rad/s) now."""
        return self._set_point[0].copy(), self._set_point[1].copy()

    @property
    def end_time(self) -> float | None:
        """s; when the running trajectory's last waypoint is due (None: none runs)."""
        return None if self._trajectory is None else self._trajectory.end_time

    @property
    def moving(self) -> bool:
        """A trajectory is running."""
        return self._trajectory is not None

    @property
    def settled(self) -> bool:
        """No trajectory is running and the joints have been still for 20 ms."""
        return self._trajectory is None and self._still_steps >= _SETTLE_STEPS

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
        # pybullet's own function: BulletClient's look-up costs as much as the call
        states = pybullet.getJointStates(
            scene.robot_body, scene.arm, physicsClientId=scene.client._client
        )
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
