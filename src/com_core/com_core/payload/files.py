"""The files that carry a payload (``com_core.payload.model``) to other programs.

``write_payload_files`` writes three files into one directory:

- ``payload.yaml``: all of the payload, for people and programs; its floats read back to
  the same doubles. ``read_payload`` reads it: the estimator's ``payload_file``
  parameter loads it to compensate without a new exploration. Its ``control_toolbox``
  section repeats the filter's parameters below.
- ``gravity_compensation.yaml``: a ROS 2 parameters file for control_toolbox's
  GravityCompensation filter (plugin ``control_filters/GravityCompensationWrench``),
  which a force controller's filter chain runs: the hand and the object as one mass at
  one CoG in the URDF's sensor frame, and the (tilted) base's gravity.
- ``payload.urdf``: a URDF fragment, the object as a link on a fixed joint from the
  sensor's URDF frame (a point mass, or with its inertia from an exploration in motion),
  for a motion planner or a dynamics model that adds the payload to the robot (the URDF
  already holds the hand).

The bias: only ``compensate`` (and so the estimator) subtracts the sensor's bias. The
filter and the URDF have no bias term: a wrench filtered with these parameters keeps
the bias (``bias`` in payload.yaml, as it was at ``time``; it drifts) unless the
sensor's driver removes it first.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Iterator, Mapping
from datetime import datetime
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import yaml
from numpy.typing import NDArray

from com_core.estimation.fits.known_gravity import mount_rpy
from com_core.payload.model import Payload, PayloadError
from com_core.sensing.noise import NoiseModel

__all__ = [
    "FILTER_PLUGIN",
    "GRAVITY_COMPENSATION_FILE",
    "PAYLOAD_FILE",
    "URDF_FILE",
    "gravity_compensation_parameters",
    "payload_yaml",
    "read_payload",
    "urdf_snippet",
    "write_payload_files",
]

PAYLOAD_FILE = "payload.yaml"
GRAVITY_COMPENSATION_FILE = "gravity_compensation.yaml"
URDF_FILE = "payload.urdf"
FILTER_PLUGIN = "control_filters/GravityCompensationWrench"
"""control_toolbox's GravityCompensation filter for geometry_msgs/WrenchStamped."""

_FILE_FIELDS = {"cov": "covariance", "hand_mass": "hand.mass", "hand_com": "hand.com"}
"""Payload fields that payload.yaml names otherwise."""
_DERIVED_TOLERANCE = {"rtol": 1e-9, "atol": 1e-12}


# --- control_toolbox's GravityCompensation filter -------------------------------------


def _filter_parameters(payload: Payload) -> dict:
    """The filter's parameters for hand plus object, in both of its releases' names:
    ``CoG.pos`` (m, sensor_frame, the URDF's) and ``CoG.force`` (N along world_frame,
    the base's: mass times gravity, tilt included), as its documentation and the releases
    before 4.x read them, and ``tool.CoG``, ``tool.mass`` (kg) and ``tool.gravity_field``
    (m/s^2), as 4.x (Jazzy) reads them. The filter subtracts T_sw force and
    CoG x (T_sw force) from a wrench it has turned into sensor_frame."""
    cog = (payload._mount_rotation @ payload.total_com).tolist()
    return {
        "world_frame": payload.base_frame,
        "sensor_frame": payload.sensor_frame,
        "CoG": {"pos": cog, "force": (payload.total_mass * payload._base_gravity).tolist()},
        "tool": {
            "CoG": cog,
            "mass": payload.total_mass,
            "gravity_field": payload._base_gravity.tolist(),
        },
    }


_FILTER_NOTE = """\
control_toolbox's GravityCompensation filter ({plugin}):
the hand and the object as one mass at one CoG. CoG.pos: m in sensor_frame; CoG.force:
N along world_frame (mass times the base's gravity, tilt included), the names of its
documentation and of releases before 4.x; 4.x (Jazzy) reads tool.CoG (= CoG.pos),
tool.mass (kg) and tool.gravity_field (m/s^2; tool.mass gravity_field = CoG.force).
With T_sw the rotation from world_frame to sensor_frame it computes
f - T_sw CoG.force and tau - CoG.pos x (T_sw CoG.force).
It has no bias term: the sensor's bias stays in the filtered wrench.
It turns each wrench from its frame_id into sensor_frame by tf2: with a non-zero mount,
that transform must carry the mounting (payload.yaml's mount_rpy).
"""


def gravity_compensation_parameters(payload: Payload) -> str:
    """A ROS 2 parameters file (YAML text) of control_toolbox's GravityCompensation
    filter for the hand plus the object (``payload.yaml``'s ``control_toolbox`` section)."""
    note = _FILTER_NOTE.format(plugin=FILTER_PLUGIN) + (
        "Load it into the node that runs the filter chain\n"
        "(--ros-args --params-file gravity_compensation.yaml); in a chain these parameters\n"
        "go under <chain>.<filterN>.params, beside the filter's name and type.\n"
        f"The payload: information {payload.information}, hand {payload.hand_id!r}, "
        f"time {payload.time!r}.\n"
    )
    document = {"/**": {"ros__parameters": _filter_parameters(payload)}}
    return _comment(note) + _dump(document)


# --- payload.yaml ---------------------------------------------------------------------


_UNITS = (
    "kg, m, N, N m, rad, m/s^2; time ISO 8601 UTC; vectors in frame (the sensor axes) "
    "unless stated"
)
_FILE_NOTES = {
    "mass": (
        "The payload of an F/T sensor: the object held (mass, com), the hand and the sensor's\n"
        "bias and mounting; com_core.payload.files.read_payload reads it (the estimator's\n"
        "payload_file parameter). Units: kg, m, N, N m, rad, m/s^2; vectors in frame (the\n"
        "wrenches' frame_id, the sensor's axes) unless stated.\n"
    ),
    "covariance": "covariance of (mass, com_x, com_y, com_z): kg^2, kg m, m^2\n",
    "bias": "the sensor's bias (its zero) at time: N, N m; it drifts\n",
    "inertia": "the object's inertia about its com (an exploration in motion that identified "
    "it): kg m^2\n",
    "delay": "s the wrenches are stamped after the joint states of the same instant\n",
    "hand": "the hand: everything beyond the sensor but the object; kg, m, kg m^2\n",
    "sensor_frame": "the URDF's frames: of the sensor, and of the base\n",
    "mount": (
        "the sensor's mounting: its axes in sensor_frame are R(mount); mount is a rotation\n"
        "vector (rad), mount_rpy the same as roll, pitch, yaw (rad, fixed axes x, y, z: a URDF\n"
        "origin's rpy, or a static transform from sensor_frame to frame)\n"
    ),
    "base_tilt": (
        "the base's tilt, a rotation vector in base_frame (rad): the base's gravity is\n"
        "R(base_tilt) gravity; gravity: m/s^2 in base_frame\n"
    ),
    "time": "time of the estimate; hand_id: the hand it was held by ('' unknown)\n",
    "noise": (
        "the sensor's noise the estimate learnt (com_core.sensing.noise.NoiseModel): the\n"
        "covariance of one sample, per axis its AR coefficients and prediction-error\n"
        "variance, the samples and the rate it was learnt from\n"
    ),
    "control_toolbox": _FILTER_NOTE.format(plugin=FILTER_PLUGIN)
    + "The same parameters as gravity_compensation.yaml.\n",
}


def _comment(text: str) -> str:
    """``text`` as YAML comment lines."""
    return "".join(f"# {line}".rstrip() + "\n" for line in text.splitlines())


class _Dumper(yaml.SafeDumper):
    """SafeDumper writing mappings as blocks and lists of scalars on one line, and a value
    used twice in full both times: ROS 2's parameter parser refuses YAML aliases."""

    def ignore_aliases(self, data: object) -> bool:
        return True


def _represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
    flat = not any(isinstance(v, list | dict) for v in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flat)


_Dumper.add_representer(list, _represent_list)


def _dump(values: Mapping) -> str:
    """YAML text of ``values``: keys in order, floats as repr (the shortest text that
    reads back to the same double, as yaml.safe_dump writes them)."""
    return yaml.dump(
        dict(values), Dumper=_Dumper, sort_keys=False, default_flow_style=False, width=4096
    )


def _file_fields(payload: Payload) -> dict:
    """payload.yaml's fields, in the file's order."""
    p = payload
    return {
        "mass": p.mass,
        "com": p.com.tolist(),
        "frame": p.frame,
        "information": p.information,
        "covariance": p.cov.tolist(),
        "sigma_mass": p.sigma_mass,
        "sigma_com": p.sigma_com.tolist(),
        "bias": {"force": p.bias[:3].tolist(), "torque": p.bias[3:].tolist()},
        **({"inertia": p.inertia.tolist()} if p.inertia is not None else {}),
        **({"delay": p.delay} if p.delay else {}),
        "hand": {"mass": p.hand_mass, "com": p.hand_com.tolist()}
        | ({"inertia": p.hand_inertia.tolist()} if p.hand_inertia is not None else {}),
        "sensor_frame": p.sensor_frame,
        "base_frame": p.base_frame,
        "mount": p.mount.tolist(),
        "mount_rpy": mount_rpy(p.mount).tolist(),
        "base_tilt": p.base_tilt.tolist(),
        "gravity": p.gravity.tolist(),
        "time": p.time,
        "hand_id": p.hand_id,
        **({"noise": p.noise.as_dict()} if p.noise is not None else {}),
        "units": _UNITS,
        "control_toolbox": {"gravity_compensation": _filter_parameters(p)},
    }


def payload_yaml(payload: Payload) -> str:
    """The text of ``payload.yaml`` (see the module); ``read_payload`` reads it back to the
    same doubles."""
    return "".join(
        _comment(_FILE_NOTES.get(key, "")) + _dump({key: value})
        for key, value in _file_fields(payload).items()
    )


_DERIVED_FIELDS = ("sigma_mass", "sigma_com", "mount_rpy", "control_toolbox")
"""Fields of payload.yaml that the others determine: optional, checked when present."""


def read_payload(
    path: str | os.PathLike[str], *, frame: str | None = None, hand_id: str | None = None
) -> Payload:
    """The payload in ``path`` (``payload_yaml``'s format).

    frame : the wrenches' frame_id it must have (None: any). hand_id : the hand it must
    have been held by (None or '': any; a file's '' matches any).

    Raises PayloadError naming the file and the field: a file that cannot be read or does
    not parse, a missing or malformed field, derived fields (sigmas, mount_rpy,
    control_toolbox) that disagree with the others, another frame or hand.
    """
    source = str(path)
    data = _load_mapping(Path(path), source)
    try:
        payload = _payload_of(data)
        _check_derived(data, payload)
    except PayloadError as error:
        name = _FILE_FIELDS.get(error.field or "", error.field)
        raise PayloadError(error.problem, name, source) from None
    if frame is not None and payload.frame != frame:
        raise PayloadError(f"is {payload.frame!r}, expected {frame!r}", "frame", source)
    if hand_id and payload.hand_id and payload.hand_id != hand_id:
        raise PayloadError(
            f"is {payload.hand_id!r}, expected {hand_id!r}: the payload was held by another hand",
            "hand_id",
            source,
        )
    return payload


def _load_mapping(path: Path, source: str) -> Mapping:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise PayloadError(f"cannot be read: {error}", source=source) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise PayloadError(f"does not parse as YAML: {error}", source=source) from None
    if not isinstance(data, Mapping):
        raise PayloadError(
            f"is not a payload file: a mapping of fields, got {type(data).__name__}",
            source=source,
        )
    return data


def _payload_of(data: Mapping) -> Payload:
    """The Payload of payload.yaml's fields (strict types: numbers are numbers)."""
    return Payload(
        mass=_number(data, "mass"),
        com=_numbers(data, "com", 3),
        cov=_matrix(data, "covariance", 4),
        hand_mass=_number(data, "hand.mass"),
        hand_com=_numbers(data, "hand.com", 3),
        bias=_numbers(data, "bias.force", 3) + _numbers(data, "bias.torque", 3),
        mount=_numbers(data, "mount", 3),
        base_tilt=_numbers(data, "base_tilt", 3),
        gravity=_numbers(data, "gravity", 3),
        frame=_text(data, "frame"),
        sensor_frame=_text(data, "sensor_frame"),
        base_frame=_text(data, "base_frame"),
        information=_text(data, "information"),
        time=_text(data, "time"),
        hand_id=_text(data, "hand_id"),
        noise=_noise(data),
        inertia=_matrix(data, "inertia", 3) if "inertia" in data else None,
        delay=_number(data, "delay") if "delay" in data else 0.0,
        hand_inertia=(
            _matrix(data, "hand.inertia", 3)
            if isinstance(data.get("hand"), Mapping) and "inertia" in data["hand"]
            else None
        ),
    )


def _noise(data: Mapping) -> NoiseModel | None:
    """payload.yaml's optional ``noise`` (None without it)."""
    if "noise" not in data:
        return None
    try:
        return NoiseModel.from_dict(data["noise"])
    except (KeyError, TypeError, ValueError) as error:
        raise PayloadError(f"is not a noise model: {error!r}", "noise") from None


def _get(data: Mapping, name: str) -> object:
    """The value at a dotted ``name`` (``bias.force``)."""
    value: object = data
    parts = name.split(".")
    for k, part in enumerate(parts):
        if not isinstance(value, Mapping):
            raise PayloadError(f"must be a mapping, got {value!r}", ".".join(parts[:k]))
        if part not in value:
            raise PayloadError("is missing", ".".join(parts[: k + 1]))
        value = value[part]
    return value


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _number(data: Mapping, name: str) -> float:
    value = _get(data, name)
    if not _is_number(value):
        raise PayloadError(f"must be a number, got {value!r}", name)
    if not math.isfinite(value):
        raise PayloadError(f"must be finite, got {value!r}", name)
    return float(value)


def _numbers(data: Mapping, name: str, size: int) -> list[float]:
    value = _get(data, name)
    if not (isinstance(value, list) and len(value) == size and all(map(_is_number, value))):
        raise PayloadError(f"must be {size} numbers, got {value!r}", name)
    if not all(map(math.isfinite, value)):
        raise PayloadError(f"must be finite, got {value!r}", name)
    return [float(v) for v in value]


def _matrix(data: Mapping, name: str, size: int) -> list[list[float]]:
    value = _get(data, name)
    rows_ok = isinstance(value, list) and len(value) == size
    if not rows_ok or not all(isinstance(r, list) and len(r) == size for r in value):
        raise PayloadError(f"must be {size} lists of {size} numbers, got {value!r}", name)
    try:
        return [_numbers({"row": row}, "row", size) for row in value]
    except PayloadError as error:  # named by the matrix, not its row
        raise PayloadError(error.problem, name) from None


def _text(data: Mapping, name: str) -> str:
    value = _get(data, name)
    if isinstance(value, datetime):  # an unquoted time reads as a timestamp
        return value.isoformat()
    if not isinstance(value, str):
        raise PayloadError(f"must be a string, got {value!r}", name)
    return value


def _leaves(tree: Mapping, prefix: str = "") -> Iterator[tuple[str, object]]:
    """(dotted name, value) of each value of a nested mapping that is not a mapping."""
    for key, value in tree.items():
        if isinstance(value, Mapping):
            yield from _leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def _check_derived(data: Mapping, payload: Payload) -> None:
    """The derived fields present in ``data`` agree with those ``payload`` gives: a field
    edited by hand on one side only is refused, not used half-way."""
    fields = _file_fields(payload)
    derived = {key: fields[key] for key in _DERIVED_FIELDS if key in data}
    for name, expected in _leaves(derived):
        if isinstance(expected, str):
            agrees = _text(data, name) == expected
        elif isinstance(expected, list):
            given = _numbers(data, name, len(expected))
            agrees = np.allclose(given, expected, **_DERIVED_TOLERANCE)
        else:
            agrees = np.isclose(_number(data, name), expected, **_DERIVED_TOLERANCE)
        if not agrees:
            raise PayloadError(
                f"is {_get(data, name)!r}, but the other fields give {expected!r}: edit "
                "those and write the file again, or remove it",
                name,
            )


# --- URDF -----------------------------------------------------------------------------


def _xml_comment(text: str) -> str:
    return "<!-- " + text.replace("--", "- -") + " -->"


def _xyz(vector: NDArray[np.float64]) -> str:
    return " ".join(repr(float(v)) for v in vector)


def urdf_snippet(payload: Payload, link: str = "payload") -> str:
    """A URDF fragment to put inside the robot's ``<robot>``: the object as a link
    ``link`` with its mass (kg) at its COM (m, in the sensor's URDF frame: R(mount) com)
    and its inertia about the COM (kg m^2, R(mount) I R(mount)^T; zero, a point mass,
    when it was not estimated), on a fixed joint ``<link>_joint`` from ``sensor_frame``
    (which must be a link of the URDF)."""
    rotation = payload._mount_rotation
    com = rotation @ payload.com
    if payload.inertia is None:
        inertia = [_xml_comment("inertia not estimated or not identified: a point mass"),
                   '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>']  # fmt: skip
    else:
        i = rotation @ payload.inertia @ rotation.T
        elements = zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
                       i[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]], strict=True)  # fmt: skip
        inertia = ["<inertia " + " ".join(f'{k}="{float(v)!r}"' for k, v in elements) + "/>"]
    note = (
        f"The object held by {payload.hand_id or 'the hand'} (information "
        f"{payload.information}, time {payload.time or 'unknown'}): mass kg, COM m in "
        f"{payload.sensor_frame}."
    )
    return "\n".join(
        [
            _xml_comment(note),
            f"<link name={quoteattr(link)}>",
            "  <inertial>",
            f'    <origin xyz="{_xyz(com)}" rpy="0 0 0"/>',
            f'    <mass value="{payload.mass!r}"/>',
            *("    " + line for line in inertia),
            "  </inertial>",
            "</link>",
            f'<joint name={quoteattr(link + "_joint")} type="fixed">',
            f"  <parent link={quoteattr(payload.sensor_frame)}/>",
            f"  <child link={quoteattr(link)}/>",
            '  <origin xyz="0 0 0" rpy="0 0 0"/>',
            "</joint>",
            "",
        ]
    )


# --- files ----------------------------------------------------------------------------


def _write_atomically(path: Path, text: str) -> None:
    """``text`` into ``path`` through a temporary file in the same directory and
    os.replace: a reader sees the old file or the new one, never a part."""
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_payload_files(directory: str | os.PathLike[str], payload: Payload) -> list[Path]:
    """Writes ``payload.yaml``, ``gravity_compensation.yaml`` and ``payload.urdf`` (see the
    module) into ``directory``, created if missing; each file atomically, payload.yaml
    last. Returns their paths in that order of names.

    Raises OSError naming the path when the directory cannot be made or written.
    """
    folder = Path(directory)
    texts = {
        GRAVITY_COMPENSATION_FILE: gravity_compensation_parameters(payload),
        URDF_FILE: urdf_snippet(payload),
        PAYLOAD_FILE: payload_yaml(payload),
    }
    path = folder
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in texts.items():
            path = folder / name
            _write_atomically(path, text)
    except OSError as error:
        message = f"cannot write the payload files: {path}: {error.strerror or error}"
        raise (OSError(error.errno, message) if error.errno else OSError(message)) from error
    return [folder / PAYLOAD_FILE, folder / GRAVITY_COMPENSATION_FILE, folder / URDF_FILE]
