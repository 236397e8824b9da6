"""What differs between robots: one ROS 2 parameters file per arm (docs/design.md, Robots).

``config/<robot>.yaml`` (in this package: ``config/panda.yaml``, ``config/xarm6.yaml``)
holds, under ``/**: ros__parameters:`` so that every node reads the keys it uses:

- ``robot``: the arm's name; ``hand_id``: names the hand (a cached tare and a payload
  file serve this hand only); ``sensor_id``: names the F/T sensor and its settings (its
  serial, and what changes its readings: a filter, a new calibration), so that a cached
  tare or hand motion serves the sensor it was read by only; optional, '' (an unnamed
  sensor) when a file lacks it.
- ``urdf``: the URDF the sim loads (a file, ``pybullet_data:<path>`` in pybullet_data, or
  ``com_core:<path>`` in CONFIG_DIR, where the URDFs written for shipped arms lie beside
  their files); a real arm's nodes take it from /robot_description instead.
- ``base_frame``, ``sensor_frame``: URDF frames; the sensor frame is the F/T sensor's,
  the link after the flange's fixed joint. ``grasp_frame`` and ``grasp_offset`` (m, in
  grasp_frame): the grasp centre, where a grasped object's centre sits and the point the
  tilts turn about.
- ``arm_joints``: the joints a trajectory moves, in the controller's order;
  ``home_joints``, ``pick_joints``: rad, in that order (home: the hand above the object;
  pick: the object between the open pads).
- ``gripper_joints``: the gripper's joints in /joint_states; ``gripper_open``,
  ``gripper_closed``: its command (std_msgs/Float64MultiArray, one value) and joint
  position open and closed (m or rad). ``finger_gap``: m, each pad's distance from the
  centre at open and at closed (the sim's virtual fingers, linear between).
- ``joint_state_rate``: Hz, how often the arm publishes /joint_states (Franka's FCI 1 kHz,
  UR's RTDE 500 Hz), at most the sim's 1 kHz; optional, 100 Hz when a file lacks it.
- ``gripper_action``: the gripper's control_msgs/action/GripperCommand action (its position
  in the units of ``gripper_open``: m per finger on the Panda, as franka_gripper's, rad on
  the xArm); optional, ``/gripper_controller/gripper_cmd`` when a file lacks it.
- ``gripper_joint_state_rate``: Hz, how often the gripper's own publisher sends its joints'
  states on /joint_states (a second publisher beside the arm's, as real grippers' drivers
  are; franka_ros2 merges both at 30 Hz); optional, 30 Hz.
- ``arm_action``: the arm's control_msgs/action/FollowJointTrajectory action (a
  joint_trajectory_controller's ``<controller>/follow_joint_trajectory``); optional,
  ``/arm_controller/follow_joint_trajectory``.
- ``goal_tolerance`` (rad) and ``stopped_velocity_tolerance`` (rad/s): when the arm has
  arrived and rests, for every arm joint: the controller's goal tolerance, which the
  sequencer sends with each trajectory and waits for before a window; optional, 5 mrad and
  5 mrad/s.
- ``max_joint_acceleration``: rad/s^2 per arm joint, the arm's own acceleration limits as
  its maker publishes them (its controller aborts a motion beyond them: Franka's); every
  move (``Choreography.motion_time``) and the excitation in motion stay within them.
  Optional: a file without it states none (UR and UFACTORY publish none), and the nodes
  declare it empty, so that no arm inherits the default arm's.

``robot_problems`` checks a configuration against a robot model (every frame and joint
in its URDF, home and pick within the joint limits) and says what is wrong by name.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from com_core.robot.model import RobotModel

__all__ = [
    "BAG_ROBOT_FILE",
    "CONFIG_DIR",
    "DEFAULT_ARM_ACTION",
    "DEFAULT_GRIPPER_ACTION",
    "ROBOTS",
    "RobotConfig",
    "RobotConfigError",
    "declared_parameters",
    "default_robot_config",
    "grasp_point",
    "read_robot_config",
    "robot_config_path",
    "robot_problems",
    "urdf_file",
    "write_robot_config",
]

CONFIG_DIR = Path(__file__).resolve().parents[1] / "config"
BAG_ROBOT_FILE = "robot.yaml"
"""The robot configuration of a run, beside its bag (the replay reads its frames)."""
ROBOTS = tuple(sorted(path.stem for path in CONFIG_DIR.glob("*.yaml")))
"""The arms whose files ship in CONFIG_DIR."""
DEFAULT_ROBOT = "panda"
"""Every node's arm when no configuration file is given."""
SHIPPED_URDF = "com_core:"
"""A ``urdf`` of ``com_core:<path>`` names a file in CONFIG_DIR (``urdf_file``)."""
DEFAULT_GRIPPER_ACTION = "/gripper_controller/gripper_cmd"
"""The gripper's GripperCommand action when a configuration names none (the name a
ros2_control gripper action controller called ``gripper_controller`` serves)."""
DEFAULT_ARM_ACTION = "/arm_controller/follow_joint_trajectory"
"""The arm's FollowJointTrajectory action when a configuration names none (the name a
joint_trajectory_controller called ``arm_controller`` serves)."""


class RobotConfigError(ValueError):
    """A robot configuration that cannot serve; the message names the file and the key."""


@dataclass(frozen=True)
class RobotConfig:
    """One arm's configuration (see module); angles rad, lengths m."""

    robot: str
    urdf: str
    base_frame: str
    sensor_frame: str
    grasp_frame: str
    grasp_offset: tuple[float, ...]
    arm_joints: tuple[str, ...]
    gripper_joints: tuple[str, ...]
    gripper_open: float
    gripper_closed: float
    finger_gap: tuple[float, ...]
    home_joints: tuple[float, ...]
    pick_joints: tuple[float, ...]
    hand_id: str
    sensor_id: str = ""
    joint_state_rate: float = 100.0
    gripper_action: str = DEFAULT_GRIPPER_ACTION
    gripper_joint_state_rate: float = 30.0
    arm_action: str = DEFAULT_ARM_ACTION
    goal_tolerance: float = 5e-3
    stopped_velocity_tolerance: float = 5e-3
    max_joint_acceleration: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for key in ("robot", "urdf", "base_frame", "sensor_frame", "grasp_frame", "hand_id",
                    "gripper_action", "arm_action"):  # fmt: skip
            if not (isinstance(getattr(self, key), str) and getattr(self, key)):
                raise RobotConfigError(f"{key} must be a non-empty string")
        for key in ("arm_joints", "gripper_joints"):
            names = getattr(self, key)
            if not names or not all(isinstance(n, str) and n for n in names):
                raise RobotConfigError(f"{key} must be a non-empty list of joint names")
            if len(set(names)) != len(names):
                raise RobotConfigError(f"{key} names a joint twice: {list(names)}")
        if shared := set(self.arm_joints) & set(self.gripper_joints):
            raise RobotConfigError(
                f"{', '.join(sorted(shared))} in both arm_joints and gripper_joints"
            )
        for key, size in (
            ("grasp_offset", 3),
            ("finger_gap", 2),
            ("home_joints", len(self.arm_joints)),
            ("pick_joints", len(self.arm_joints)),
        ):
            values = getattr(self, key)
            if len(values) != size or not all(_finite(v) for v in values):
                raise RobotConfigError(f"{key} must be {size} finite numbers, got {list(values)}")
        if not (_finite(self.gripper_open) and _finite(self.gripper_closed)):
            raise RobotConfigError("gripper_open and gripper_closed must be finite numbers")
        if self.gripper_open == self.gripper_closed:
            raise RobotConfigError("gripper_open and gripper_closed must differ")
        if not 0.0 <= self.finger_gap[1] < self.finger_gap[0]:
            raise RobotConfigError("finger_gap must be [open, closed] m with open > closed >= 0")
        for key in ("joint_state_rate", "gripper_joint_state_rate"):
            rate = getattr(self, key)
            if not (_finite(rate) and 0.0 < rate <= 1000.0):
                raise RobotConfigError(
                    f"{key} must be in (0, 1000] Hz (the sim steps at 1 kHz), got {rate!r}"
                )
        for key in ("goal_tolerance", "stopped_velocity_tolerance"):
            if not (_finite(getattr(self, key)) and getattr(self, key) > 0.0):
                raise RobotConfigError(f"{key} must be > 0, got {getattr(self, key)!r}")
        limits = self.max_joint_acceleration
        if limits and (len(limits) != len(self.arm_joints)
                       or not all(_finite(v) and v > 0.0 for v in limits)):  # fmt: skip
            raise RobotConfigError(
                f"max_joint_acceleration must be {len(self.arm_joints)} numbers > 0 (rad/s^2, "
                f"one per arm joint) or none, got {list(limits)}"
            )

    @classmethod
    def from_parameters(cls, values: Mapping[str, Any]) -> RobotConfig:
        """The configuration of parameter values by key (extra keys are ignored)."""
        missing = [key for key in KEYS if key not in values and key not in OPTIONAL_KEYS]
        if missing:
            raise RobotConfigError(f"missing key(s) {', '.join(missing)}")
        fields = {}
        for key, field in cls.__dataclass_fields__.items():
            if key not in values:
                continue  # an optional key: its default
            value = values[key]
            if str(field.type).startswith("tuple"):  # a list, or rclpy's array.array
                if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
                    raise RobotConfigError(f"{key} must be a list, got {value!r}")
                value = tuple(value)
            elif isinstance(value, int) and not isinstance(value, bool):
                value = float(value)
            fields[key] = value
        return cls(**fields)

    def parameters(self) -> dict[str, Any]:
        """The configuration as ROS 2 parameter values (lists, floats, strings)."""
        return {
            key: list(value) if isinstance(value, tuple) else value
            for key, value in asdict(self).items()
        }

    def gripper_closed_fraction(self, position: float) -> float:
        """How far the gripper is closed at joint ``position``: 0 open, 1 closed."""
        return (position - self.gripper_open) / (self.gripper_closed - self.gripper_open)


KEYS = tuple(RobotConfig.__dataclass_fields__)
"""Every key of a robot configuration, in the file's order."""
OPTIONAL_KEYS = frozenset(
    {"sensor_id", "joint_state_rate", "gripper_action", "gripper_joint_state_rate", "arm_action",
     "goal_tolerance", "stopped_velocity_tolerance", "max_joint_acceleration"}
)  # fmt: skip
"""Keys a file may leave out (added after files were written): their defaults stand."""
ARM_OWN_KEYS = frozenset({"max_joint_acceleration"})
"""Optional keys only an arm's own file can tell: the nodes declare them empty."""


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@functools.cache
def default_robot_config() -> RobotConfig:
    """The configuration of DEFAULT_ROBOT: every node's defaults."""
    return read_robot_config(DEFAULT_ROBOT)


def declared_parameters() -> dict[str, Any]:
    """The values the nodes declare the configuration's keys with: DEFAULT_ROBOT's, but
    ARM_OWN_KEYS empty (a file that leaves them out states none)."""
    values = default_robot_config().parameters()
    return {key: [] if key in ARM_OWN_KEYS else value for key, value in values.items()}


def robot_config_path(robot: str) -> Path:
    """The file of ``robot``: a path to a file as it is, else ``CONFIG_DIR/<robot>.yaml``."""
    path = Path(robot)
    if path.suffix in (".yaml", ".yml") or path.exists():
        return path
    return CONFIG_DIR / f"{robot}.yaml"


def read_robot_config(robot: str) -> RobotConfig:
    """The configuration in ``robot``'s file (``robot_config_path``): the ``/**`` section's
    ros__parameters. RobotConfigError names the file and what is wrong."""
    path = robot_config_path(robot)
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8"))
        values = document["/**"]["ros__parameters"]
        return RobotConfig.from_parameters(values)
    except OSError as error:
        known = ", ".join(ROBOTS)
        raise RobotConfigError(
            f"{path}: cannot read it ({error}); known robots: {known}"
        ) from error
    except (yaml.YAMLError, KeyError, TypeError) as error:
        raise RobotConfigError(
            f"{path}: not a ROS 2 parameters file with a '/**: ros__parameters:' section "
            f"({error!r})"
        ) from error
    except RobotConfigError as error:
        raise RobotConfigError(f"{path}: {error}") from error


def write_robot_config(config: RobotConfig, path: Path) -> None:
    """Write ``config`` as a ROS 2 parameters file (``/**`` section) that
    ``read_robot_config`` reads back to the same values."""
    values = {key: value for key, value in config.parameters().items() if value != []}
    document = {"/**": {"ros__parameters": values}}
    path.write_text(f"# robot configuration {config.robot}\n" + yaml.safe_dump(document))


def urdf_file(config: RobotConfig) -> Path:
    """The file of the configuration's ``urdf``: a path, ``pybullet_data:<path>`` inside
    the pybullet_data package, or ``com_core:<path>`` inside CONFIG_DIR."""
    prefix = "pybullet_data:"
    if config.urdf.startswith(prefix):
        import pybullet_data

        return Path(pybullet_data.getDataPath()) / config.urdf[len(prefix) :]
    if config.urdf.startswith(SHIPPED_URDF):
        return CONFIG_DIR / config.urdf[len(SHIPPED_URDF) :]
    return Path(config.urdf)


def robot_problems(config: RobotConfig, robot: RobotModel) -> list[str]:
    """What keeps ``robot`` (the URDF's model) from serving ``config``, each naming the
    key and the frame, joint or value: frames and arm joints the URDF lacks, home and pick
    poses outside the joint limits. Empty when it serves. The gripper's joints may be
    missing: a URDF may draw the gripper fixed (the sim's rigid mode does)."""
    model, problems = robot.model, []
    for key in ("base_frame", "sensor_frame", "grasp_frame"):
        if not model.existFrame(getattr(config, key)):
            problems.append(f"{key} {getattr(config, key)!r} is not a frame of the URDF")
    missing = [name for name in config.arm_joints if not model.existJointName(name)]
    if missing:
        problems.append(f"arm_joints: the URDF has no joint {', '.join(map(repr, missing))}")
    if problems:
        return problems
    sensor, grasp = (model.frames[model.getFrameId(config.sensor_frame)],
                     model.frames[model.getFrameId(config.grasp_frame)])  # fmt: skip
    if grasp.parentJoint != sensor.parentJoint:
        problems.append(
            f"grasp_frame {config.grasp_frame!r} moves relative to sensor_frame "
            f"{config.sensor_frame!r} (a joint between them): the grasp centre must be rigid"
        )
    limits = robot.joint_limits()
    for key in ("home_joints", "pick_joints"):
        for name, value in zip(config.arm_joints, getattr(config, key), strict=True):
            lower, upper, _ = limits[name]
            if not lower - 1e-9 <= value <= upper + 1e-9:
                problems.append(
                    f"{key}: {name} = {value:.4f} rad is outside its limits "
                    f"[{lower:.4f}, {upper:.4f}]"
                )
    return problems


def grasp_point(config: RobotConfig, robot: RobotModel) -> NDArray[np.float64]:
    """The grasp centre (3,), m, in the sensor frame: grasp_frame's origin moved by
    grasp_offset (along grasp_frame's axes). The frames are rigidly joined (a fixed joint
    or the same link); taken at the home pose."""
    home = dict(zip(config.arm_joints, config.home_joints, strict=True))
    transform = robot.frame_in_sensor(config.grasp_frame, home)
    return transform[:3, 3] + transform[:3, :3] @ np.asarray(config.grasp_offset)
