"""Pushes on the held object: a force (N) at its COM and a pure couple (N m), given in
``world`` (a fixed direction) or in ``ft_sensor`` (turning with the hand), for a duration from
a start time.

Each step the pushes acting are summed, converted to the world frame and applied with
pybullet's ``applyExternalForce``/``applyExternalTorque`` in ``WORLD_FRAME`` (pybullet clears
external forces after every step; its ``LINK_FRAME`` torque on a base has been swapped with
the world frame in some versions, so it is not used). ``Pushes.applied_wrench`` is the push as
the sensor reads it, about the sensor origin in ``ft_sensor``: f = R^T F,
tau = R^T (T + (c - o) x F) for a push (F, T) in the world, R = R_world_sensor, c the object's
COM, o the sensor origin. The held arm gives way to a push and recovers (its joints are
position controlled); from then on the reading changes by ``applied_wrench`` (figures:
docs/design.md, Decisions; bench/README.md, A known push).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet
from numpy.typing import NDArray

from wrench_sim.config import PUSH_FRAMES, SENSOR_FRAME, TIME_STEP, WORLD_FRAME
from wrench_sim.scene import Scene

__all__ = ["Push", "Pushes"]


@dataclass
class Push:
    """A push on the held object: force (N) at its COM and couple (N m), in the world or in
    ``ft_sensor``, acting on the physics steps ``start_step <= k < end_step`` (step k runs from
    k to k + 1 ms)."""

    force: NDArray[np.float64]
    torque: NDArray[np.float64]
    frame: str
    start_step: int
    end_step: int
    started: bool = False


class Pushes:
    """The pushes waiting or acting on the object of ``scene``; ``event`` records their start
    and end for the user (``ArmWorld.events``)."""

    def __init__(self, scene: Scene, event: Callable[[str], None]) -> None:
        self._scene = scene
        self._event = event
        self._pushes: list[Push] = []
        # the last step's pushes: world force and torque, then ft_sensor force and torque
        self._applied: tuple[NDArray[np.float64], ...] | None = None

    def schedule(
        self,
        force: Sequence[float],
        torque: Sequence[float],
        frame: str,
        start_time: float,
        duration: float,
        step: int,
        held: bool,
    ) -> tuple[float, float]:
        """Add a push (see ``ArmWorld.apply_wrench``) at physics step ``step`` (now), the
        object ``held`` or not; returns its (start, end) in s, simulated."""
        if frame not in PUSH_FRAMES:
            raise ValueError(f"frame must be one of {list(PUSH_FRAMES)}, got {frame!r}")
        force_array = np.array(force, dtype=np.float64).reshape(3)
        torque_array = np.array(torque, dtype=np.float64).reshape(3)
        if not (np.all(np.isfinite(force_array)) and np.all(np.isfinite(torque_array))):
            raise ValueError("force and torque must be finite")
        if not math.isfinite(start_time):
            raise ValueError(f"start_time must be finite, got {start_time}")
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"duration must be > 0 s, got {duration}")
        if not held:
            raise ValueError("no object is held")
        start_step = max(step, math.ceil(start_time / TIME_STEP - 1e-6))
        end_step = start_step + max(1, round(duration / TIME_STEP))
        self._pushes.append(Push(force_array, torque_array, frame, start_step, end_step))
        return start_step * TIME_STEP, end_step * TIME_STEP

    @property
    def active(self) -> bool:
        """A push acted on the object during the last step."""
        return self._applied is not None

    @property
    def scheduled(self) -> bool:
        """A push is acting or waiting for its start time."""
        return bool(self._pushes)

    def applied_wrench(self) -> NDArray[np.float64]:
        """The pushes of the last step as the sensor reads them (6,); N, N m; ``ft_sensor``.

        The wrench the pushes add to the load on the sensor once the arm holds still, about the
        sensor origin: f = F_s, tau = T_s + p x F_s, with (F_s, T_s) the pushes in ``ft_sensor``
        at the current pose (a world push (F, T): F_s = R^T F, T_s = R^T T, R = R_world_sensor)
        and p the object's COM in ``ft_sensor``. Zero when no push acted.
        """
        if self._applied is None:
            return np.zeros(6)
        scene = self._scene
        force_world, torque_world, force, torque = self._applied
        origin, R = scene.sensor_pose()
        com = np.array(scene.client.getBasePositionAndOrientation(scene.object_body)[0])
        force = force + R.T @ force_world
        torque = torque + R.T @ torque_world
        return np.concatenate([force, torque + np.cross(R.T @ (com - origin), force)])

    def apply(self, step: int, held: bool) -> None:
        """Apply the sum of the pushes acting on the coming step ``step``, converted to the
        world; end those past their end, or all when the object is not ``held``."""
        if not self._pushes:
            return
        # world pushes, then sensor-frame pushes, summed per frame
        sums = {WORLD_FRAME: (np.zeros(3), np.zeros(3)), SENSOR_FRAME: (np.zeros(3), np.zeros(3))}
        active = False
        for push in list(self._pushes):
            if step < push.start_step:
                continue
            if step >= push.end_step or not held:
                self._pushes.remove(push)
                name = f"push from t = {push.start_step * TIME_STEP:.3f} s"
                if not push.started:
                    self._event(f"{name} dropped: no object held at its start")
                elif held:
                    self._event(f"{name} ended")
                else:
                    self._event(f"{name} ended early: the object was released")
                continue
            if not push.started:
                push.started = True
                self._event(f"push started, until t = {push.end_step * TIME_STEP:.3f} s")
            force, torque = sums[push.frame]
            force += push.force
            torque += push.torque
            active = True
        if not active:
            self._applied = None
            return
        force_world, torque_world = sums[WORLD_FRAME]
        force_sensor, torque_sensor = sums[SENSOR_FRAME]
        force, torque = force_world, torque_world
        scene = self._scene
        if force_sensor.any() or torque_sensor.any():
            R = scene.sensor_pose()[1]
            force, torque = force + R @ force_sensor, torque + R @ torque_sensor
        c = scene.client
        com = c.getBasePositionAndOrientation(scene.object_body)[0]
        c.applyExternalForce(scene.object_body, -1, force.tolist(), com, pybullet.WORLD_FRAME)
        c.applyExternalTorque(scene.object_body, -1, torque.tolist(), pybullet.WORLD_FRAME)
        self._applied = (force_world, torque_world, force_sensor, torque_sensor)
