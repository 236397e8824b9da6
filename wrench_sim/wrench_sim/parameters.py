"""The sim node's parameters: names, defaults, descriptions, and why a value is refused.

Besides the scene's and the sensor's, the node reads every key of a robot configuration
(``com_core.robot.config.KEYS``), read-only, the Panda's by default: give another arm's file
with ``--ros-args --params-file <file>`` (e.g. com_core's ``config/xarm6.yaml``).
"""

from __future__ import annotations

import math
from dataclasses import fields

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from com_core.contract import APPLY_WRENCH_TOPIC
from com_core.robot.config import KEYS, default_robot_config
from com_core.sensing.sensor_profiles import DEFAULT_PROFILE, PROFILES, SensorProfile
from wrench_sim.objects import SHAPES, com_offset_problem
from wrench_sim.physics import GRASP_MODES

__all__ = [
    "PARAMETERS",
    "PROFILE_PARAMETERS",
    "SENSOR_PARAMETERS",
    "check_parameter",
    "declare_parameters",
    "is_unset",
    "sensor_profile",
]

_START = "read at start-up"
_PROFILE = math.nan
_OF = "NaN: the sensor_profile's"
PARAMETERS = [  # name, default, description, read-only, lower bound of a float
    ("object", "box", f"shape: {sorted(SHAPES)}; {_START}", True, None),
    ("object_mass", 0.1, f"object mass, kg; {_START}", True, 1e-6),
    ("object_com_offset", Parameter.Type.DOUBLE_ARRAY, "COM minus geometric centre, 3 values, m, "
     "object frame, inside wrench_sim.objects.holdable_com_range(object) (box |x|, |y| <= 0.02; "
     "cylinder hypot(x, y) <= 0.02; mug hypot(x, y) <= 0.0224; |z| <= half height); unset: "
     f"drawn from the seed; {_START}", True, None),
    ("seed", 0, f"seeds the COM draw, sensor noise and grasp shifts; {_START}", True, None),
    ("grasp_mode", "rigid", f"rigid | friction; {_START}", True, None),
    ("slip_sigma", 0.0, "rigid mode: sigma of the object's shift at each new tilt, m", False, 0.0),
    ("hand_mass", 0.0, "mass of the links beyond the sensor (hand or gripper, fingers), kg; "
     f"0 = the URDF's; {_START}", True, 0.0),
    ("grip_force", 5.0, f"friction mode: force limit per finger, N; {_START}", True, 1e-6),
    ("gui", False, f"open the pybullet window; {_START}", True, None),
    ("sensor_mount_rpy", [0.0, 0.0, 0.0], "the F/T sensor mounted off its URDF frame "
     "(sensor_frame) by roll, pitch, yaw (rad, fixed axes x, y, z): its readings and the "
     f"ground truth are in the mounted frame; {_START}", True, None),
    ("sensor_profile", DEFAULT_PROFILE, f"the sensor's parts: {sorted(PROFILES)} "
     f"(com_core.sensing.sensor_profiles); each part below, when set, overrides it; "
     f"{_START}", True, None),
    ("sigma_f", _PROFILE, "sensor noise per published force sample, N; " + _OF, False, None),
    ("sigma_tau", _PROFILE, "sensor noise per published torque sample, N m; " + _OF, False, None),
    ("correlation_time", _PROFILE, "s; the sensor's first-order low-pass (its noise AR(1) at "
     "the publish rate; 0: white); " + _OF, False, None),
    ("bias_f", 0.0, "sensor bias on each force axis, N", False, None),
    ("bias_tau", 0.0, "sensor bias on each torque axis, N m", False, None),
    ("bias_drift", [0.0] * 6, "sensor bias drift from sim time 0, per axis: forces N/s, "
     "torques N m/s (a sensor warming up)", False, None),
    ("resolution_f", _PROFILE, "force quantisation step, N; 0 = none; " + _OF, False, None),
    ("resolution_tau", _PROFILE, "torque quantisation step, N m; 0 = none; " + _OF, False, None),
    ("limit_f", _PROFILE, "force range (saturation), N; 0 = none; " + _OF, False, None),
    ("limit_tau", _PROFILE, "torque range (saturation), N m; 0 = none; " + _OF, False, None),
    ("sensor_serial", 0, "which sensor: its calibration error is drawn from this, the same in "
     f"every run of one sensor whatever the seed; {_START}", True, None),
    ("calibration_accuracy", _PROFILE, "fraction of full scale (limit_f, limit_tau), 95 %: the "
     f"calibration error drawn from the seed; {_OF}; {_START}", True, None),
    ("warmup_f", _PROFILE, f"N: spread of each force axis's warm-up offset; {_OF}; {_START}",
     True, None),
    ("warmup_tau", _PROFILE, f"N m: the same for torques; {_OF}; {_START}", True, None),
    ("warmup_time", _PROFILE, f"s: the warm-up's time constant; {_OF}; {_START}", True, None),
    ("random_walk_f", _PROFILE, f"N/sqrt(s): the bias's random walk; {_OF}; {_START}", True,
     None),
    ("random_walk_tau", _PROFILE, f"N m/sqrt(s): the same for torques; {_OF}; {_START}", True,
     None),
    ("vibration_hz", [-1.0], "Hz: the arm's structural modes ([-1.0]: the profile's; [0.0]: "
     f"none); {_START}", True, None),
    ("vibration_damping", [-1.0], "damping ratio per mode ([-1.0]: the profile's); "
     f"{_START}", True, None),
    ("rate", 1000.0, "wrench publish rate, Hz; must divide 1000", False, 1.0),
    ("clock_rate", 250.0, f"/clock publish rate, Hz (sim); must divide 1000; {_START}", True,
     1.0),
    ("real_time_factor", 0.0, "sim s per wall s; 0 = as fast as possible", False, 0.0),
    ("push_duration", 1.0, f"how long each push on {APPLY_WRENCH_TOPIC} acts on the held "
     "object, s of sim time, > 0 (whole 1 ms steps, at least one); for pushes received from "
     "then on", False, 0.0),
] + [
    (key, value, f"robot configuration (com_core.robot.config); {_START}", True, None)
    for key, value in default_robot_config().parameters().items()
]  # fmt: skip
PROFILE_PARAMETERS = tuple(f.name for f in fields(SensorProfile) if f.name != "vibration_gain")
"""The sensor parts a parameter of the same name overrides (NaN, [-1.0]: the profile's)."""
SENSOR_PARAMETERS = (*PROFILE_PARAMETERS, "bias_f", "bias_tau")
"""The parameters the sensor model is built from."""


def is_unset(value: object) -> bool:
    """The parameter leaves its part to the profile (NaN, or [-1.0] for a list)."""
    if isinstance(value, float):
        return math.isnan(value)
    return list(value) == [-1.0] if isinstance(value, (list, tuple)) else False


def sensor_profile(values: dict) -> SensorProfile:
    """The profile ``values['sensor_profile']`` with every part set in ``values``."""
    parts = {
        name: tuple(v) if isinstance(v, (list, tuple)) else v
        for name, v in values.items()
        if name in PROFILE_PARAMETERS and not is_unset(v)
    }
    if parts.get("vibration_hz") == (0.0,):
        parts["vibration_hz"], parts["vibration_damping"] = (), ()
    return PROFILES[values["sensor_profile"]].with_overrides(**parts)


def check_parameter(parameter: Parameter, shape: str | None = None) -> str | None:
    """Reason why a parameter value is refused, or None when it is fine.

    ``shape`` is the ``object`` parameter's value if known: ``object_com_offset`` must then lie
    in ``holdable_com_range(shape)``.
    """
    name, value = parameter.name, parameter.value
    if name == "sensor_profile" and value not in PROFILES:
        return f"sensor_profile {value!r} is none of {sorted(PROFILES)}"
    if name in PROFILE_PARAMETERS and not is_unset(value):
        values = list(value) if isinstance(value, (list, tuple)) else [value]
        if not all(isinstance(v, float) and math.isfinite(v) and v >= 0 for v in values):
            return f"{name}={value!r} refused: finite values >= 0 (NaN or [-1.0]: the profile's)"
        if name == "calibration_accuracy" and value >= 1.0:
            return f"calibration_accuracy={value!r} refused: a fraction in [0, 1)"
        if name == "vibration_damping" and any(v >= 1.0 for v in values):
            return f"vibration_damping={value!r} refused: damping ratios in [0, 1)"
    if name == "object" and value not in SHAPES:
        return f"object must be one of {sorted(SHAPES)}"
    if name == "grasp_mode" and value not in GRASP_MODES:
        return f"grasp_mode must be one of {list(GRASP_MODES)}"
    if name == "object_com_offset" and value is not None:
        if len(value) != 3:
            return "object_com_offset must be 3 values (m), or unset to draw it from the seed"
        if shape in SHAPES:
            return com_offset_problem(shape, value)
    if name == "sensor_mount_rpy" and (
        len(value) != 3 or not all(math.isfinite(v) and abs(v) < math.pi for v in value)
    ):
        return "sensor_mount_rpy must be 3 finite angles (rad) within +-pi"
    if name == "bias_drift" and (len(value) != 6 or not all(map(math.isfinite, value))):
        return "bias_drift must be 6 finite rates (3 forces N/s, 3 torques N m/s)"
    if name in ("rate", "clock_rate") and not (
        0.0 < value <= 1000.0 and abs(1000.0 / value % 1) < 1e-9
    ):
        return f"{name} must divide the 1000 Hz physics rate (1000, 500, 250, 200, 100, ... Hz)"
    if name == "push_duration" and not value > 0.0:
        return "push_duration must be > 0 s"
    if isinstance(value, float) and not math.isfinite(value) and name not in PROFILE_PARAMETERS:
        return f"{name} must be finite"
    return None


def declare_parameters(node: Node) -> None:
    """Declare every parameter of ``PARAMETERS`` on ``node`` with its descriptor."""
    for name, default, description, read_only, low in PARAMETERS:
        ranges = [FloatingPointRange(from_value=low, to_value=math.inf)] if low is not None else []
        descriptor = ParameterDescriptor(
            description=description,
            read_only=read_only,
            floating_point_range=ranges,
            dynamic_typing=name in KEYS,  # a robot file's 0 for 0.0
        )
        node.declare_parameter(name, default, descriptor)
