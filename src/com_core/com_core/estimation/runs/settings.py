"""The estimator's settings: one table, one check, one mapping to an ``Exploration``.

The estimator node declares them as ROS parameters and the offline replay as command
line options (``--sigma-f`` for ``sigma_f``), both from ``SETTINGS``, and both build
their explorations with ``exploration_from``: "the replay uses the node's defaults"
holds by construction. ``tare_cache`` names a file of cached tare windows (its current
entry, ``com_core.estimation.runs.tare_cache``), read by ``load_cached_tares`` once per
exploration, when it is solved (a sequencer may take or choose the tare during the exploration).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from com_core.estimation.fits.estimators import DEFAULT_ALPHA, MIN_TILT_SIGMAS
from com_core.estimation.fits.known_gravity import BIAS_DRIFT_RATE, Reference
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.fit_setup import (
    INFORMATION,
    KINEMATICS_MOUNT,
    MAX_DRIFT_F,
    MAX_DRIFT_TAU,
    METHODS,
    WRENCHES,
)
from com_core.estimation.runs.hand_motion import load_hand_motion
from com_core.estimation.runs.inbox import MAX_LABEL_GAP
from com_core.estimation.runs.sensor_calibration import SensorCalibration
from com_core.estimation.runs.tare_cache import TareCache, load_tares
from com_core.inputs import Input, table_of
from com_core.robot.config import default_robot_config
from com_core.robot.model import DEFAULT_GRAVITY, KinematicsError, RobotModel
from com_core.sensing.calibration import Calibration, reading_correction
from com_core.sensing.hysteresis import Hysteresis
from com_core.sensing.sensor_profiles import DEFAULT_PROFILE, PROFILES
from com_core.sensing.wrench_model import SensorModel

__all__ = [
    "BAG_SETTINGS_FILE",
    "REFERENCE_MASS_TOLERANCE",
    "SETTINGS",
    "defaults",
    "exploration_from",
    "load_cached_tares",
    "read_bag_settings",
    "robot_from",
    "use_cached_hand_motion",
    "use_cached_tares",
    "use_sensor_calibration",
    "write_bag_settings",
]

BAG_SETTINGS_FILE = "estimator.yaml"
"""The estimator's settings of a run, beside its bag (the replay's defaults): every setting
but the robot's frames (``robot.yaml``'s), its URDF (the bag's /robot_description) and the
tare cache (the bag's copy)."""
NOT_IN_BAG_SETTINGS = ("sensor_frame", "base_frame", "robot_description", "tare_cache")
_REALISTIC = PROFILES[DEFAULT_PROFILE]
CALIBRATION_ACCURACY = _REALISTIC.calibration_accuracy
FULL_SCALE = (_REALISTIC.limit_f, _REALISTIC.limit_tau)
"""The estimator's defaults: the default sensor profile's datasheet figures."""

REFERENCE_MASS_TOLERANCE = 5e-5
"""A reference weight's maximum permissible error, of its mass: OIML R 111-1's class M1
from 100 g to 50 kg (50 mg at 1 kg)."""
REFERENCE_MASS_SHARE = REFERENCE_MASS_TOLERANCE / math.sqrt(3.0)
"""A reference weight's default 1-sigma, of its mass: its error anywhere within the
tolerance (a rectangular distribution, GUM 4.3.7)."""
_NOISE = dict(low=0.0, high=1000.0)
_TEXT = dict(kind="str")
_DRIFT = dict(low=0.0, high=1000.0)


def _gravity(value: list[float]) -> str:
    norm = math.hypot(*value)
    return "" if 1.0 <= norm <= 100.0 else f"its norm {norm:.4g} m/s^2 is outside [1, 100]"


def _urdf(value: str) -> str:
    """Why a robot_description is refused: a file that cannot be read ('' text or file)."""
    if not value or value.lstrip().startswith("<"):
        return ""
    try:
        Path(value).read_text()
    except (OSError, UnicodeDecodeError) as error:
        return f"is neither URDF text nor a readable file ({error})"
    return ""


SETTINGS = table_of([
    Input("method", "ml", "'ml' (multi-pose maximum likelihood) or 'two_pose' (the paper)",
          kind="str", choices=METHODS),
    Input("alpha", DEFAULT_ALPHA, "false-alarm rate of the object-moved test (and of the "
          "verification's, the bias drift's)", low=0.0,
          high=0.5, low_open=True, high_open=True),
    Input("expected_frame", "ft_sensor", "frame_id wrenches must carry; others are dropped",
          **_TEXT),
    Input("wrench_sign", 1.0, "1: the wrench topic carries the wrench the load exerts on "
          "the sensor; -1: its opposite (a driver's other convention; no relay node needed)",
          choices=(1.0, -1.0), check=lambda v: "" if v in (1.0, -1.0) else "must be 1 or -1"),
    Input("sigma_f", 0.0, "sensor force noise per sample, for windows too few to learn the "
          "noise from (0: unknown; the noise is learnt from the static windows, "
          "com_core.sensing.noise)", unit="N", **_NOISE),
    Input("sigma_tau", 0.0, "sensor torque noise per sample (as sigma_f)", unit="N m",
          **_NOISE),
    Input("accuracy", CALIBRATION_ACCURACY, "the sensor's calibration accuracy, a fraction of "
          "full scale (95 %): a systematic term of the kinematic fit's covariance "
          "(com_core.sensing.calibration); 0: exact", low=0.0, high=1.0, high_open=True),
    Input("full_scale", list(FULL_SCALE), "the sensor's full scale in force and torque "
          "(weighs the calibration's cross-talk)", kind="floats", unit="N, N m", low=1e-3,
          high=1e6, lengths=(2,)),
    Input("hysteresis", [0.0] * 6, "the sensor's hysteresis band per axis (fx fy fz tx ty "
          "tz: a datasheet's % of full scale times the axis's range): the gain below one "
          "it reads load changes with is taken off every reading, and the fits weigh what "
          "is left (com_core.sensing.hysteresis); zeros: none",
          kind="floats", unit="N, N m", low=0.0, high=1e6, lengths=(6,)),
    Input("limit_f", 0.0, "sensor force range (0: no saturation check)", unit="N", low=0.0,
          high=1e6),
    Input("limit_tau", 0.0, "sensor torque range (0: no saturation check)", unit="N m",
          low=0.0, high=1e6),
    Input("min_tilt_sigmas", MIN_TILT_SIGMAS, "refuse tilts below this many sigma of noise",
          low=0.0, high=1000.0),
    Input("max_label_gap", MAX_LABEL_GAP, "(sensor time) without a label after which a label "
          "starts a new exploration (0: never)", unit="s", low=0.0, high=1e6),
    Input("tare_cache", "", "file of cached tare windows for poses without a fresh tare "
          "('': none)", **_TEXT),
    Input("information", KINEMATICS_MOUNT, "ml's information: 'wrenches' (gravity directions "
          "unknown), 'kinematics' (from the URDF and joints, with the hand and the bias "
          "fitted) or 'kinematics+mount' (and the sensor's mounting and the base tilt); "
          "two_pose uses the wrenches", kind="str", choices=INFORMATION),
    Input("robot_description", "", "URDF text or file for 'kinematics' ('': "
          "/robot_description)", kind="str", check=_urdf),
    Input("sensor_frame", default_robot_config().sensor_frame, "URDF frame of the F/T sensor "
          "(the wrenches' frame; robot configuration)", kind="str",
          check=lambda v: "" if v else "must name a frame"),
    Input("base_frame", "", "URDF frame gravity is given in ('': the URDF's root)", **_TEXT),
    Input("gravity", list(DEFAULT_GRAVITY), "in base_frame (a tilted base gives its own)",
          kind="floats", unit="m/s^2", low=-100.0, high=100.0, lengths=(3,), check=_gravity),
    Input("bias_drift_rate", list(BIAS_DRIFT_RATE), "1-sigma drift rate of the sensor bias to "
          "allow for within a run (the kinematic fit's prior; the wrenches alone weigh with it "
          "the drift between each pose's tare and object windows; [0, 0]: a constant bias "
          "within a run)", kind="floats", unit="N/s, N m/s", lengths=(2,), **_DRIFT),
    Input("max_drift_f", MAX_DRIFT_F, "a larger bias drift since the cached tare, beyond "
          "the fit's sigma at alpha, is a WARN", unit="N", **_DRIFT),
    Input("max_drift_tau", MAX_DRIFT_TAU, "a larger bias drift since the cached tare, beyond "
          "the fit's sigma at alpha, is a WARN", unit="N m", **_DRIFT),
    Input("reference_mass", 0.0, "the object is a reference weight of this mass: the run "
          "calibrates the sensor in place (com_core.estimation.fits.in_place) and keeps it "
          "for sensor_id beside tare_cache, instead of weighing the object; 0: an unknown "
          "object", unit="kg", low=0.0, high=1000.0,
          check=lambda v: "" if v == 0 or v >= 1e-3 else "must be 0 or at least 0.001 kg"),
    Input("reference_mass_sigma", 0.0, "the reference's mass's 1-sigma (0: "
          f"{REFERENCE_MASS_SHARE:.2g} of it: an OIML class M1 weight, within "
          f"{REFERENCE_MASS_TOLERANCE:g} of it)", unit="kg", low=0.0,
          high=1000.0,
          check=lambda v: "" if v == 0 or v >= 1e-6 else "must be 0 or at least 1e-06 kg"),
    Input("reference_com", [0.0, 0.0, 0.0], "the reference's COM in the sensor frame, when "
          "reference_com_sigma > 0 (a weight on a fixture of known geometry)", kind="floats",
          unit="m", low=-10.0, high=10.0, lengths=(3,)),
    Input("reference_com_sigma", 0.0, "the reference's COM's 1-sigma per axis; 0: unknown "
          "(the calibration then leaves the part of its error that a COM offset explains)",
          unit="m", low=0.0, high=1.0,
          check=lambda v: "" if v == 0 or v >= 1e-6 else "must be 0 or at least 1e-06 m"),
])  # fmt: skip
"""The estimator's settings by name (``com_core.inputs``)."""


def defaults() -> dict[str, Any]:
    """Every setting at its default."""
    return {name: row.default for name, row in SETTINGS.items()}


def exploration_from(settings: Mapping[str, Any], urdf: str = "") -> Exploration:
    """A new ``Exploration`` for ``settings`` (names of ``SETTINGS``; missing ones take
    their defaults). The sensor model is set when a noise or a range is given. With
    information 'kinematics' the robot model is built from ``robot_description`` (a URDF
    text or file), else from ``urdf`` (what /robot_description carried); a URDF that does
    not serve leaves the robot model unset and says why in ``robot_problem``. The cached
    tare is not read here (``load_cached_tares``)."""
    value = defaults() | dict(settings)
    sensor = None
    if any(value[k] > 0 for k in ("sigma_f", "sigma_tau", "limit_f", "limit_tau")):
        sensor = SensorModel.from_scalars(
            value["sigma_f"],
            value["sigma_tau"],
            limit_f=value["limit_f"],
            limit_tau=value["limit_tau"],
        )
    exploration = Exploration(
        method=value["method"],
        expected_frame=value["expected_frame"],
        wrench_sign=value["wrench_sign"],
        sensor=sensor,
        alpha=value["alpha"],
        min_tilt_sigmas=value["min_tilt_sigmas"],
        max_label_gap=value["max_label_gap"],
        information=value["information"],
        bias_drift_rate=tuple(value["bias_drift_rate"]),
        max_drift_f=value["max_drift_f"],
        max_drift_tau=value["max_drift_tau"],
        calibration=(
            Calibration(value["accuracy"], *value["full_scale"]) if value["accuracy"] > 0 else None
        ),
        reference=reference_of(value),
        hysteresis=hysteresis_of(value),
    )
    if value["information"] != WRENCHES:
        exploration.robot, exploration.robot_problem = robot_from(value, urdf)
    return exploration


def hysteresis_of(settings: Mapping[str, Any]) -> Hysteresis | None:
    """The hysteresis ``settings`` state (``hysteresis`` over ``full_scale``), else None."""
    return Hysteresis.stated(settings["hysteresis"], *settings["full_scale"])


def reference_of(settings: Mapping[str, Any]) -> Reference | None:
    """The reference weight ``settings`` name (``reference_mass`` > 0), else None."""
    mass = settings["reference_mass"]
    if not mass > 0:
        return None
    sigma = settings["reference_mass_sigma"] or max(REFERENCE_MASS_SHARE * mass, 1e-6)
    if not settings["reference_com_sigma"] > 0:
        return Reference(mass, sigma)
    com = tuple(float(x) for x in settings["reference_com"])
    return Reference(mass, sigma, com, settings["reference_com_sigma"])  # type: ignore[arg-type]


def robot_from(settings: Mapping[str, Any], urdf: str = "") -> tuple[RobotModel | None, str]:
    """(the robot model, '') of ``settings``' robot_description (a URDF text or file),
    else of ``urdf`` (what /robot_description carried), sensor_frame, base_frame and
    gravity; (None, why) when there is none or it does not serve."""
    value = defaults() | dict(settings)
    try:
        text = _urdf_text(value["robot_description"]) or urdf
    except (OSError, UnicodeDecodeError) as error:  # a file gone since it was checked
        return None, f"robot_description: {error}"
    if not text:
        return None, "no robot description received"
    try:
        robot = RobotModel(
            text, value["sensor_frame"], value["base_frame"] or None, value["gravity"]
        )
    except KinematicsError as error:
        return None, str(error)
    return robot, ""


def _urdf_text(description: str) -> str:
    """A URDF text as it is, or the text of a file it names ('' for '')."""
    if description.lstrip().startswith("<"):
        return description
    return Path(description).read_text() if description else ""


def load_cached_tares(path: str | Path) -> TareCache | None:
    """The current entry of the cache file ``path`` (None for '', none, or a broken file:
    the solution then says which poses have no tare)."""
    if not str(path):
        return None
    try:
        return load_tares(path)
    except (ValueError, KeyError, TypeError, OSError):  # a broken file: as if none
        return None


def use_cached_tares(exploration: Exploration, path: str | Path) -> None:
    """Give ``exploration`` the current entry of the cache file ``path``: its tare windows
    and, told the sensor's hysteresis, their ways (corrected as its samples are: by the
    gain of that hysteresis and a calibration in place, ``use_sensor_calibration``;
    ``Exploration.samples``), their joint positions and times, and the noise learnt from
    them (none for '', no file or a broken one)."""
    cache = load_cached_tares(path)
    if cache is not None and exploration.hysteresis is None:
        cache = replace(cache, ways={})
    m = reading_correction(exploration.calibration, exploration.hysteresis)
    if cache is not None and m is not None:  # the file keeps the windows as read
        cache = cache.corrected(m)
    exploration.cached_tare = cache
    exploration.noise = None if cache is None else cache.noise


def use_sensor_calibration(exploration: Exploration, entry: SensorCalibration | None) -> None:
    """Give ``exploration`` its sensor's calibration in place (``sensor_calibration``):
    its samples read corrected (and the cached tare windows ``use_cached_tares`` gives it
    after), its fits weighing what is left of the error; None leaves the stated accuracy
    of its settings."""
    if entry is not None:
        exploration.calibration = entry.calibration


def use_cached_hand_motion(exploration: Exploration, path: str | Path, owner: str) -> None:
    """Give ``exploration`` the empty hand's motion fit in the file ``path``
    (``hand_motion``) when it is of ``owner`` (the hand on the sensor,
    ``tare_cache.cache_owner``) and of its robot model; else none."""
    entry, robot = load_hand_motion(path), exploration.robot
    fits = entry is not None and robot is not None
    exploration.hand_motion = (
        entry.fit if fits and not entry.other_owner(owner, robot.urdf_sha256) else None
    )


def write_bag_settings(values: Mapping[str, Any], path: Path) -> None:
    """Write the settings ``values`` (by name; those of NOT_IN_BAG_SETTINGS left out) to
    ``path`` (YAML) for ``read_bag_settings``."""
    import yaml

    kept = {k: v for k, v in values.items() if k in SETTINGS and k not in NOT_IN_BAG_SETTINGS}
    path.write_text("# the estimator's settings of this run\n" + yaml.safe_dump(kept))


def read_bag_settings(path: Path) -> dict[str, Any]:
    """The settings in ``path`` that its table takes ({} with no file; a value the table
    refuses, or an unknown name, is left out)."""
    import yaml

    try:
        values = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError):
        return {}
    if not isinstance(values, dict):
        return {}
    taken = set(SETTINGS) - set(NOT_IN_BAG_SETTINGS)
    return {k: v for k, v in values.items() if k in taken and not SETTINGS[k].problem(v)}
