"""The grasp shifts of ``rigid`` mode (the paper's reconfiguration): once the arm has settled
at a new tilt (the hand turned by more than 0.02 rad since the grasp or the last shift), the
object is re-attached shifted by an N(0, slip_sigma^2 I) vector in ``ft_sensor``.

In ``friction`` mode the object slips by itself (``wrench_sim.gripper``); the shifts do not
apply there.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from wrench_sim.gripper import RigidGripper
from wrench_sim.scene import Scene

__all__ = ["GraspShifts"]

_NEW_TILT_ANGLE = 0.02  # rad; hand rotation since the last shift that makes a new tilt


class GraspShifts:
    """Shifts the object held by ``gripper`` at each new tilt (see module).

    Parameters
    ----------
    scene : the scene.
    rng : the shifts' stream (``random_streams(seed)["slip"]``).
    sigma : m; 0: no shifts.
    event : records a line for the user (``ArmWorld.events``).
    """

    def __init__(
        self,
        scene: Scene,
        rng: np.random.Generator,
        sigma: float,
        event: Callable[[str], None],
    ) -> None:
        self._scene = scene
        self._rng = rng
        self.sigma = sigma
        """m; the shifts' standard deviation per axis."""
        self._event = event
        self._R_at_shift: NDArray[np.float64] | None = None  # R_world_sensor

    def grasped(self) -> None:
        """The object was just grasped: tilts count from the hand's orientation now."""
        self._R_at_shift = self._scene.sensor_pose()[1]

    def check(self, gripper: RigidGripper) -> None:
        """With the arm settled and the object held: shift it if the hand has turned by more
        than 0.02 rad since the grasp or the last shift."""
        R = self._scene.sensor_pose()[1]
        assert self._R_at_shift is not None
        cos_angle = (np.trace(self._R_at_shift.T @ R) - 1.0) / 2.0
        if np.arccos(np.clip(cos_angle, -1.0, 1.0)) > _NEW_TILT_ANGLE:
            self._shift(gripper, R)

    def _shift(self, gripper: RigidGripper, R_world_sensor: NDArray[np.float64]) -> None:
        """Re-attach the object shifted by N(0, sigma^2 I) in ft_sensor (a new tilt)."""
        scene = self._scene
        c = scene.client
        shift = self._rng.normal(0.0, self.sigma, 3)
        gripper.detach()
        position, orientation = c.getBasePositionAndOrientation(scene.object_body)
        c.resetBasePositionAndOrientation(
            scene.object_body,
            (np.asarray(position) + R_world_sensor @ shift).tolist(),
            orientation,
        )
        gripper.attach()
        self._R_at_shift = R_world_sensor
        self._event(
            f"{scene.object.shape} shifted in the grasp by "
            f"({', '.join(f'{1e3 * s:.2f}' for s in shift)}) mm in ft_sensor (new tilt)"
        )
