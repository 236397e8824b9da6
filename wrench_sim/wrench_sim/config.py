"""The simulation's settings: the physics step, the grasp modes, the frames a push may be
given in, and ``SimConfig``, the scene an ``ArmWorld`` builds."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from com_core.robot.config import RobotConfig, default_robot_config
from wrench_sim.objects import SHAPES

__all__ = [
    "GRASP_MODES",
    "PUSH_FRAMES",
    "SENSOR_FRAME",
    "STEP_NS",
    "TIME_STEP",
    "WORLD_FRAME",
    "SimConfig",
    "check_slip_sigma",
]

TIME_STEP = 1e-3
"""s; physics step (1 kHz)."""
STEP_NS = 1_000_000
"""ns; physics step."""
GRASP_MODES = ("rigid", "friction")
WORLD_FRAME = "world"
SENSOR_FRAME = "ft_sensor"
PUSH_FRAMES = (WORLD_FRAME, SENSOR_FRAME)
"""The frames a push (``ArmWorld.apply_wrench``) may be given in."""


def check_slip_sigma(sigma: float, rigid: bool) -> float:
    """``sigma`` (m, the grasp shifts' standard deviation, ``wrench_sim.slip``) as a float;
    ValueError unless finite and >= 0, and 0 when the grasp mode is not ``rigid``."""
    if not (np.isfinite(sigma) and sigma >= 0.0):
        raise ValueError(f"slip_sigma must be >= 0 m, got {sigma}")
    if sigma > 0.0 and not rigid:
        raise ValueError("slip_sigma applies to grasp_mode 'rigid' (friction mode slips)")
    return float(sigma)


@dataclass(frozen=True)
class SimConfig:
    """The scene: robot, object, grasp mode and hand.

    Attributes
    ----------
    robot : the arm (``com_core.robot.config``); default the Panda's configuration.
    object_shape : 'box', 'cylinder' or 'mug'.
    object_mass : kg.
    object_com_offset : m, object frame, COM minus geometric centre, inside
        ``objects.holdable_com_range(object_shape)`` (``ArmWorld`` refuses others with a
        ValueError stating the range); None draws it from ``seed`` (uniform inside the body's
        inner half, which lies in that range).
    seed : seeds the COM draw, the sensor noise and the grasp shifts (separate streams).
    grasp_mode : 'rigid' (a fixed constraint; the paper's immobilised object) or 'friction'
        (finger contact; the object may slip; two prismatic fingers only, the Panda's).
    slip_sigma : m; rigid mode only: at each new tilt the object is re-attached shifted by a
        N(0, slip_sigma^2 I) vector in ``ft_sensor`` (the paper's reconfiguration).
    hand_mass : kg; total mass of the links beyond the sensor (hand or gripper, fingers),
        0 = the URDF's (Panda 1.01 kg). Scales their masses alike, so their COM is unchanged.
    grip_force : N; friction mode: force limit of each finger's position controller.
    home_joints : rad; the arm's initial joint positions, one per ``robot.arm_joints``;
        None = ``robot.home_joints``.
    gui : open pybullet's window instead of running headless (DIRECT).
    vibration : the arm's structural modes, (frequency Hz, damping ratio) each
        (``wrench_sim.vibration``); empty: a rigid arm. vibration_gain : their participation.
    """

    robot: RobotConfig = field(default_factory=default_robot_config)
    object_shape: str = "box"
    object_mass: float = 0.1
    object_com_offset: tuple[float, float, float] | None = None
    seed: int = 0
    grasp_mode: str = "rigid"
    slip_sigma: float = 0.0
    hand_mass: float = 0.0
    grip_force: float = 5.0
    home_joints: tuple[float, ...] | None = None
    gui: bool = False
    vibration: tuple[tuple[float, float], ...] = ()
    vibration_gain: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.robot, RobotConfig):
            raise ValueError(f"robot must be a RobotConfig, got {type(self.robot).__name__}")
        if self.object_shape not in SHAPES:
            raise ValueError(f"object must be one of {sorted(SHAPES)}, got {self.object_shape!r}")
        if self.grasp_mode not in GRASP_MODES:
            raise ValueError(f"grasp_mode must be one of {GRASP_MODES}, got {self.grasp_mode!r}")
        check_slip_sigma(self.slip_sigma, self.grasp_mode == "rigid")
        if not (np.isfinite(self.hand_mass) and self.hand_mass >= 0.0):
            raise ValueError(
                f"hand_mass must be >= 0 kg (0 = from the URDF), got {self.hand_mass}"
            )
        if not (np.isfinite(self.grip_force) and self.grip_force > 0.0):
            raise ValueError(f"grip_force must be > 0 N, got {self.grip_force}")
        joints = len(self.robot.arm_joints)
        if self.home_joints is not None and (
            len(self.home_joints) != joints or not np.all(np.isfinite(self.home_joints))
        ):
            raise ValueError(
                f"home_joints must be {joints} finite values (rad, "
                f"{', '.join(self.robot.arm_joints)}), got {self.home_joints}"
            )
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")

    @property
    def home(self) -> tuple[float, ...]:
        """rad; the arm's initial joint positions (``home_joints`` or the robot's)."""
        return self.robot.home_joints if self.home_joints is None else tuple(self.home_joints)
