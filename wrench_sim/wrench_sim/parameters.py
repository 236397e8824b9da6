"""The sim node's parameters: name, default, meaning and range (``com_core.inputs``).

Besides the scene's and the sensor's, the node reads every key of a robot configuration
(``com_core.robot.config.KEYS``), read-only, the Panda's by default: give another arm's file
with ``--ros-args --params-file <file>`` (e.g. com_core's ``config/xarm6.yaml``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from com_core.contract import APPLY_WRENCH_TOPIC
from com_core.inputs import Input, InputError, refusal, table_of
from com_core.robot.config import declared_parameters
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
_OF = "NaN: the sensor_profile's"
_PROFILE = dict(keep=(math.nan,), low=0.0)  # a sensor part: NaN leaves the profile's


def _divides_physics(rate: float) -> str:
    return "" if abs(1000.0 / rate % 1) < 1e-9 else "must divide the 1000 Hz physics rate"


_RATE = dict(unit="Hz", low=1.0, high=1000.0, check=_divides_physics,
             fix="1000, 500, 250, 200, 100, ... Hz")  # fmt: skip

PARAMETERS = table_of([
    Input("object", "box", f"shape; {_START}", kind="str", choices=tuple(sorted(SHAPES)),
          read_only=True),
    Input("object_mass", 0.1, f"object mass; {_START}", unit="kg", low=1e-3, high=5.0,
          read_only=True, fix="an object the arm carries (Panda 3 kg, xArm6 5 kg)"),
    Input("object_com_offset", Parameter.Type.DOUBLE_ARRAY, "COM minus geometric centre, "
          "object frame, inside wrench_sim.objects.holdable_com_range(object) (box |x|, |y| "
          "<= 0.02; cylinder hypot(x, y) <= 0.02; mug hypot(x, y) <= 0.0224; |z| <= half "
          f"height); unset: drawn from the seed; {_START}", kind="floats", unit="m",
          low=-0.1, high=0.1, lengths=(3,), keep=(None,), read_only=True),
    Input("reference_weight", False, "the object is a reference weight stated as object_mass: "
          "its true mass is off it within OIML class M1's tolerance, drawn from the seed "
          f"(wrench_sim.objects.reference_weight_mass); {_START}", kind="bool", read_only=True),
    Input("seed", 0, f"seeds the COM draw, sensor noise and grasp shifts; {_START}",
          kind="int", low=0, high=2**31 - 1, read_only=True),
    Input("grasp_mode", "rigid", _START, kind="str", choices=GRASP_MODES, read_only=True),
    Input("slip_sigma", 0.0, "rigid mode: sigma of the object's shift at each new tilt",
          unit="m", low=0.0, high=0.01),
    Input("hand_mass", 0.0, "mass of the links beyond the sensor (hand or gripper, fingers); "
          f"0 = the URDF's; {_START}", unit="kg", low=0.0, high=10.0, read_only=True),
    Input("grip_force", 5.0, f"friction mode: force limit per finger; {_START}", unit="N",
          low=0.1, high=1000.0, read_only=True),
    Input("gui", False, f"open the pybullet window; {_START}", kind="bool", read_only=True),
    Input("sensor_mount_rpy", [0.0, 0.0, 0.0], "the F/T sensor mounted off its URDF frame "
          "(sensor_frame) by roll, pitch, yaw (fixed axes x, y, z): its readings and the "
          f"ground truth are in the mounted frame; {_START}", kind="floats", unit="rad",
          low=-math.pi, high=math.pi, low_open=True, high_open=True, lengths=(3,),
          read_only=True),
    Input("sensor_profile", DEFAULT_PROFILE, "the sensor's parts "
          "(com_core.sensing.sensor_profiles); each part below, when set, overrides it; "
          f"{_START}", kind="str", choices=tuple(sorted(PROFILES)), read_only=True),
    Input("sigma_f", math.nan, f"sensor noise per published force sample; {_OF}", unit="N",
          high=100.0, **_PROFILE),
    Input("sigma_tau", math.nan, f"sensor noise per published torque sample; {_OF}",
          unit="N m", high=10.0, **_PROFILE),
    Input("correlation_time", math.nan, "the sensor's first-order low-pass (its noise AR(1) "
          f"at the publish rate; 0: white); {_OF}", unit="s", high=1.0, **_PROFILE),
    Input("bias_f", 0.0, "sensor bias on each force axis", unit="N", low=-1000.0, high=1000.0),
    Input("bias_tau", 0.0, "sensor bias on each torque axis", unit="N m", low=-100.0,
          high=100.0),
    Input("bias_drift", [0.0] * 6, "sensor bias drift from sim time 0, per axis: forces N/s, "
          "torques N m/s (a sensor warming up)", kind="floats", low=-10.0, high=10.0,
          lengths=(6,)),
    Input("resolution_f", math.nan, f"force quantisation step; 0 = none; {_OF}", unit="N",
          high=100.0, **_PROFILE),
    Input("resolution_tau", math.nan, f"torque quantisation step; 0 = none; {_OF}",
          unit="N m", high=10.0, **_PROFILE),
    Input("limit_f", math.nan, f"force range (saturation); 0 = none; {_OF}", unit="N",
          high=1e5, **_PROFILE),
    Input("limit_tau", math.nan, f"torque range (saturation); 0 = none; {_OF}", unit="N m",
          high=1e4, **_PROFILE),
    Input("sensor_serial", 0, "which sensor: its calibration error is drawn from this, the "
          f"same in every run of one sensor whatever the seed; {_START}", kind="int", low=0,
          high=2**31 - 1, read_only=True),
    Input("calibration_accuracy", math.nan, "fraction of full scale (limit_f, limit_tau), "
          f"95 %: the calibration error drawn from the seed; {_OF}; {_START}", high=1.0,
          high_open=True, read_only=True, **_PROFILE),
    Input("warmup_f", math.nan, f"spread of each force axis's warm-up offset; {_OF}; "
          f"{_START}", unit="N", high=100.0, read_only=True, **_PROFILE),
    Input("warmup_tau", math.nan, f"the same for torques; {_OF}; {_START}", unit="N m",
          high=10.0, read_only=True, **_PROFILE),
    Input("warmup_time", math.nan, f"the warm-up's time constant; {_OF}; {_START}", unit="s",
          high=1e6, read_only=True, **_PROFILE),
    Input("random_walk_f", math.nan, f"the bias's random walk; {_OF}; {_START}",
          unit="N/sqrt(s)", high=10.0, read_only=True, **_PROFILE),
    Input("random_walk_tau", math.nan, f"the same for torques; {_OF}; {_START}",
          unit="N m/sqrt(s)", high=1.0, read_only=True, **_PROFILE),
    Input("vibration_hz", [-1.0], "the arm's structural modes ([-1.0]: the profile's; [0.0]: "
          f"none); {_START}", kind="floats", unit="Hz", low=0.0, high=500.0, low_open=True,
          high_open=True, keep=([-1.0], [0.0]), read_only=True),
    Input("vibration_damping", [-1.0], f"damping ratio per mode ([-1.0]: the profile's); "
          f"{_START}", kind="floats", low=0.0, high=1.0, high_open=True, keep=([-1.0],),
          read_only=True),
    Input("hysteresis", [-1.0], "the gauges' band between loading and unloading over the "
          "range, per axis fx fy fz tx ty tz (wrench_sim.gauges; [-1.0]: the profile's; "
          f"[0.0]: none); {_START}", kind="floats", unit="N, N m", low=0.0, high=1e4,
          lengths=(6,), keep=([-1.0], [0.0]), read_only=True),
    Input("nonlinearity", [-1.0], "the gauges' largest deviation from the line through zero "
          "and full scale, per axis (as hysteresis)", kind="floats", unit="N, N m", low=0.0,
          high=1e4, lengths=(6,), keep=([-1.0], [0.0]), read_only=True),
    Input("sensitivity_drift", math.nan, "each axis's gain moves up to this much per kelvin "
          f"the sensor warms; {_OF}; {_START}", unit="1/K", high=0.1, read_only=True,
          **_PROFILE),
    Input("warmup_kelvin", math.nan, "how far the sensor warms from power-on, with "
          f"warmup_time; {_OF}; {_START}", unit="K", high=100.0, read_only=True, **_PROFILE),
    Input("link_model_error", math.nan, "a wrench estimated from the joint torques (no "
          "wrist sensor): the arm model's error in each link's inertial parameters, a "
          f"fraction of each, 1 sigma (wrench_sim.joint_torques; 0: a wrist sensor); {_OF}; "
          f"{_START}", high=1.0, read_only=True, **_PROFILE),
    Input("joint_torque_offset", math.nan, "the same: each joint torque sensor's offset, 1 "
          f"sigma; {_OF}; {_START}", unit="N m", high=100.0, read_only=True, **_PROFILE),
    Input("rate", 1000.0, "wrench publish rate", **_RATE),
    Input("clock_rate", 250.0, f"/clock publish rate (sim); {_START}", read_only=True, **_RATE),
    Input("real_time_factor", 0.0, "sim s per wall s; 0 = as fast as possible", low=0.01,
          high=1000.0, keep=(0.0,)),
    Input("push_duration", 1.0, f"how long each push on {APPLY_WRENCH_TOPIC} acts on the held "
          "object, s of sim time (whole 1 ms steps, at least one); for pushes received from "
          "then on", unit="s", low=1e-3, high=60.0),
])  # fmt: skip
"""The sim's own parameters by name; the robot configuration's keys come besides them."""
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
    """The profile ``values['sensor_profile']`` with every part set in ``values``;
    InputError when the parts make no sensor (``SensorProfile.problems``)."""
    parts = {
        name: tuple(v) if isinstance(v, (list, tuple)) else v
        for name, v in values.items()
        if name in PROFILE_PARAMETERS and not is_unset(v)
    }
    if parts.get("vibration_hz") == (0.0,):
        parts["vibration_hz"], parts["vibration_damping"] = (), ()
    for name in ("hysteresis", "nonlinearity"):
        if parts.get(name) == (0.0,):
            parts[name] = ()
    profile = PROFILES[values["sensor_profile"]].with_overrides(**parts)
    if problems := profile.problems():
        raise InputError("; ".join(problems))
    return profile


def check_parameter(
    name: str, value: Any, others: Mapping[str, Any] | None = None, called: str = ""
) -> str:
    """Why the parameter ``name`` refuses ``value`` ('' when it takes it), naming it
    ``called`` when given (a flag): its row's check, and with the values of ``others``
    (``object``, ``grasp_mode``, when known): an ``object_com_offset`` inside
    ``holdable_com_range(object)``, a ``slip_sigma`` only in rigid mode. A robot
    configuration's keys are checked by ``RobotConfig``."""
    row = PARAMETERS.get(name)
    if row is None:
        return ""
    if why := row.problem(value, called):
        return why
    others = others or {}
    if name == "object_com_offset" and value is not None and others.get("object") in SHAPES:
        return com_offset_problem(others["object"], value) or ""
    if name == "slip_sigma" and value > 0 and others.get("grasp_mode", "rigid") != "rigid":
        return refusal(called or name, value, "applies to grasp_mode 'rigid' (friction mode "
                       "slips)", "leave it 0 with grasp_mode 'friction'")  # fmt: skip
    return ""


def declare_parameters(node: Node) -> None:
    """Declare every parameter of ``PARAMETERS`` on ``node`` with its descriptor, and the
    robot configuration's keys (read-only; the Panda's by default)."""
    for row in PARAMETERS.values():
        descriptor = ParameterDescriptor(**row.descriptor())
        # declared by its type, without a value (object_com_offset): rclpy types it statically
        descriptor.dynamic_typing = not isinstance(row.default, Parameter.Type)
        node.declare_parameter(row.name, row.default, descriptor)
    robot = ParameterDescriptor(
        description=f"robot configuration (com_core.robot.config); {_START}",
        read_only=True,
        dynamic_typing=True,  # a robot file's 0 for 0.0
    )
    for key, value in declared_parameters().items():
        node.declare_parameter(key, value, robot)
