"""com_core.payload: a payload compensates the wrench it predicts exactly, its gravity
follows the mounting and the tilt, control_toolbox's filter with its parameters removes
the same wrench but the bias, payload.yaml reads back to the same doubles and names the
field it refuses, a kinematic fit gives the payload, pinocchio reads the URDF fragment,
and the files are written together or an OSError names the path."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio
import pytest
import yaml

from com_core.estimation.fits.estimators import Consistency
from com_core.estimation.fits.known_gravity import Observation, kinematic_ml
from com_core.estimation.fits.windows import window_from_mean
from com_core.estimation.runs.fit_setup import KINEMATICS_MOUNT, WRENCHES
from com_core.estimation.runs.solution import Solution
from com_core.payload.files import (
    GRAVITY_COMPENSATION_FILE,
    PAYLOAD_FILE,
    URDF_FILE,
    gravity_compensation_parameters,
    payload_yaml,
    read_payload,
    urdf_snippet,
    write_payload_files,
)
from com_core.payload.model import (
    Payload,
    PayloadError,
    compensate,
    payload_from_solution,
    payload_gravity,
    payload_wrench,
)
from com_core.robot.model import RobotModel
from com_core.sensing.noise import ar1_noise
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    SensorModel,
    gravity_wrench,
    rotation_about,
)

G = STANDARD_GRAVITY
MASS, COM = 0.1, np.array([0.01, -0.02, 0.1])
HAND_MASS, HAND_COM = 1.0, np.array([0.001, -0.002, 0.04])
BIAS = np.array([0.5, -0.3, 0.2, 0.01, -0.02, 0.005])  # N, N m
MOUNT = np.array([0.02, -0.03, 0.05])  # rad, rotation vector
TILT = np.array([0.004, -0.003, 0.0])  # rad, across gravity
COV = np.diag([1e-6, 4e-8, 9e-8, 1e-7]) + 1e-9


def rotation(rotvec) -> np.ndarray:
    """R of a rotation vector, by pinocchio's exponential map."""
    return pinocchio.exp3(np.asarray(rotvec, dtype=float))


def make_payload(**changes) -> Payload:
    fields = {
        "mass": MASS,
        "com": COM,
        "cov": COV,
        "hand_mass": HAND_MASS,
        "hand_com": HAND_COM,
        "bias": BIAS,
        "mount": MOUNT,
        "base_tilt": TILT,
        "frame": "ft_sensor",
        "sensor_frame": "hand",
        "base_frame": "base",
        "information": KINEMATICS_MOUNT,
        "time": "2026-01-02T03:04:05Z",
        "hand_id": "test_hand",
    }
    return Payload(**(fields | changes))


def random_rotations(n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack([rotation(rng.normal(size=3)) for _ in range(n)])


# a small arm: j1 about x, j2 about y, the hand on a fixed joint; {payload} for a fragment
ROBOT_URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="link1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/>
    <axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <link name="link1"/>
  <joint name="j2" type="revolute">
    <parent link="link1"/>
    <child link="link2"/>
    <origin xyz="0 0 0.2" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <link name="link2"/>
  <joint name="hand_joint" type="fixed">
    <parent link="link2"/>
    <child link="hand"/>
    <origin xyz="0.01 0.02 0.1" rpy="0.3 -0.2 -0.785398163397"/>
  </joint>
  <link name="hand"/>
{payload}
</robot>
"""


# --- compensation ---------------------------------------------------------------------


def test_compensate_removes_the_payload_wrench_exactly():
    payload = make_payload()
    rotations = random_rotations(50)
    contact = np.random.default_rng(2).normal(size=(50, 6))
    readings = payload_wrench(payload, rotations) + contact
    np.testing.assert_allclose(compensate(payload, readings, rotations), contact, atol=1e-12)
    one = compensate(payload, readings[7], rotations[7])
    assert one.shape == (6,)
    np.testing.assert_allclose(one, contact[7], atol=1e-12)


def test_payload_wrench_is_the_bias_and_the_gravity_of_hand_and_object():
    payload = make_payload()
    rotations = random_rotations(20, seed=3)
    g_s = payload_gravity(payload, rotations)
    expected = BIAS + gravity_wrench(HAND_MASS, HAND_COM, g_s) + gravity_wrench(MASS, COM, g_s)
    np.testing.assert_allclose(payload_wrench(payload, rotations), expected, atol=1e-12)
    np.testing.assert_allclose(payload_wrench(payload, rotations[4]), expected[4], atol=1e-12)


def test_payload_gravity_by_hand():
    quarter = math.pi / 2
    # the sensor turned 90 deg about x in its URDF frame: its y axis points up the base's z
    mounted = make_payload(mount=[quarter, 0.0, 0.0], base_tilt=np.zeros(3))
    np.testing.assert_allclose(payload_gravity(mounted, np.eye(3)), [0, -G, 0], atol=1e-12)
    # a base tilted by a about y, the URDF sensor frame turned 90 deg about z in the base:
    # R(tilt) g = (-g sin a, 0, -g cos a); R^T maps (x, y, z) to (y, -x, z); the mount
    # (x, y, z) to (x, z, -y)
    a = 0.1
    tilted = make_payload(mount=[quarter, 0.0, 0.0], base_tilt=[0.0, a, 0.0])
    turned = rotation_about("z", quarter)
    expected = G * np.array([0.0, -math.cos(a), -math.sin(a)])
    np.testing.assert_allclose(payload_gravity(tilted, turned), expected, atol=1e-12)
    level = make_payload(mount=np.zeros(3), base_tilt=[0.0, a, 0.0])
    expected = G * np.array([0.0, math.sin(a), -math.cos(a)])
    np.testing.assert_allclose(payload_gravity(level, turned), expected, atol=1e-12)
    stack = np.stack([np.eye(3), turned, turned.T])
    each = [payload_gravity(tilted, r) for r in stack]
    np.testing.assert_allclose(payload_gravity(tilted, stack), each, atol=1e-15)
    with pytest.raises(ValueError, match="shape"):
        payload_gravity(tilted, np.eye(4))


def control_toolbox_filter(
    parameters: dict,
    reading: np.ndarray,
    R_base_sensor: np.ndarray,
    frame_to_sensor: np.ndarray,
    release: str,
) -> np.ndarray:
    """control_toolbox's GravityCompensation on one reading in the wrenches' frame: tf2
    turns it into sensor_frame (``frame_to_sensor``, the mounting), then fc_s = f_s -
    T_sw g_w and tau_c = tau_s - p_s x (T_sw g_w), with T_sw = R_base_sensor^T, and back
    into the wrenches' frame. ``release`` '4.x' reads p_s = tool.CoG and g_w = tool.mass
    tool.gravity_field; 'documented' reads CoG.pos and CoG.force."""
    if release == "4.x":
        tool = parameters["tool"]
        cog, g_w = np.array(tool["CoG"]), tool["mass"] * np.array(tool["gravity_field"])
    else:
        cog, g_w = np.array(parameters["CoG"]["pos"]), np.array(parameters["CoG"]["force"])
    T_sw = R_base_sensor.T
    f_s, tau_s = frame_to_sensor @ reading[:3], frame_to_sensor @ reading[3:]
    fc_s = f_s - T_sw @ g_w
    tau_c = tau_s - np.cross(cog, T_sw @ g_w)
    return np.concatenate([frame_to_sensor.T @ fc_s, frame_to_sensor.T @ tau_c])


@pytest.mark.parametrize(
    ("mount", "tilt"),
    [(np.zeros(3), np.zeros(3)), (MOUNT, np.zeros(3)), (MOUNT, TILT), ([0.0, 1.2, -0.7], TILT)],
)
def test_control_toolbox_filter_removes_the_payload_wrench_but_the_bias(mount, tilt):
    payload = make_payload(mount=mount, base_tilt=tilt)
    parameters = yaml.safe_load(gravity_compensation_parameters(payload))["/**"]
    parameters = parameters["ros__parameters"]
    in_file = yaml.safe_load(payload_yaml(payload))["control_toolbox"]["gravity_compensation"]
    assert in_file == parameters
    for text in (gravity_compensation_parameters(payload), payload_yaml(payload)):
        assert not re.search(r"[&*]id\d", text)  # ROS 2's parameter parser refuses aliases
    assert (parameters["world_frame"], parameters["sensor_frame"]) == ("base", "hand")
    rotations = random_rotations(20, seed=4)
    contact = np.random.default_rng(5).normal(size=(20, 6))
    readings = payload_wrench(payload, rotations) + contact
    for R, reading, c in zip(rotations, readings, contact, strict=True):
        for release in ("4.x", "documented"):
            filtered = control_toolbox_filter(parameters, reading, R, rotation(mount), release)
            np.testing.assert_allclose(filtered, c + BIAS, atol=1e-12)


# --- payload.yaml ---------------------------------------------------------------------


def assert_same_payload(a: Payload, b: Payload) -> None:
    """Every field equal, arrays to the last bit."""
    for name in ("com", "cov", "hand_com", "bias", "mount", "base_tilt", "gravity"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and x.tobytes() == y.tobytes(), name
    for name in ("inertia", "hand_inertia"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or x.tobytes() == y.tobytes(), name
    for name in ("mass", "hand_mass", "delay"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.float64(x).tobytes() == np.float64(y).tobytes(), name
    for name in ("frame", "sensor_frame", "base_frame", "information", "time", "hand_id"):
        assert getattr(a, name) == getattr(b, name), name


def awkward_payload(seed: int) -> Payload:
    """Doubles that need all 17 digits, a subnormal, a huge one and a negative zero."""
    rng = np.random.default_rng(seed)

    def digits(*shape):
        return rng.standard_normal(shape) * 10.0 ** rng.uniform(-9, 2, shape)

    a = digits(4, 4)
    return make_payload(
        mass=1 / 3 + 1e-17 * rng.uniform(),
        com=digits(3),
        cov=a @ a.T,
        hand_mass=0.1 + 0.2,
        hand_com=digits(3),
        bias=[5e-324, -0.0, 1e300, 0.1 + 0.2, *digits(2)],
        mount=rng.normal(size=3),
        base_tilt=digits(3),
        gravity=[0.0, 0.0, -9.80665] + digits(3) * 1e-3,
    )


@pytest.mark.parametrize("seed", range(5))
def test_payload_yaml_round_trip_is_bit_exact(tmp_path, seed):
    payload = awkward_payload(seed)
    path = tmp_path / PAYLOAD_FILE
    path.write_text(payload_yaml(payload))
    assert_same_payload(read_payload(path, frame="ft_sensor", hand_id="test_hand"), payload)


def test_yaml_floats_round_trip_to_the_same_double():
    rng = np.random.default_rng(6)
    values = rng.integers(0, 2**64, size=20000, dtype=np.uint64).view(np.float64)
    values = [*values[np.isfinite(values)].tolist(), 5e-324, -0.0, 1e-5, 1e16, 0.1 + 0.2]
    back = np.array(yaml.safe_load(yaml.safe_dump(values)), dtype=np.float64)
    assert back.tobytes() == np.array(values).tobytes()


def test_payload_yaml_holds_the_fields_the_format_names():
    payload = make_payload()
    text = payload_yaml(payload)
    data = yaml.safe_load(text)
    assert list(data) == [
        "mass",
        "com",
        "frame",
        "information",
        "covariance",
        "sigma_mass",
        "sigma_com",
        "bias",
        "hand",
        "sensor_frame",
        "base_frame",
        "mount",
        "mount_rpy",
        "base_tilt",
        "gravity",
        "time",
        "hand_id",
        "units",
        "control_toolbox",
    ]
    assert "# covariance of (mass, com_x, com_y, com_z)" in text
    assert "no bias term" in text
    assert data["bias"] == {"force": BIAS[:3].tolist(), "torque": BIAS[3:].tolist()}
    assert data["hand"] == {"mass": HAND_MASS, "com": HAND_COM.tolist()}
    assert data["sigma_com"] == pytest.approx(np.sqrt(np.diag(COV)[1:]))
    rpy = data["mount_rpy"]  # fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll)
    from_rpy = rotation([0, 0, rpy[2]]) @ rotation([0, rpy[1], 0]) @ rotation([rpy[0], 0, 0])
    np.testing.assert_allclose(from_rpy, rotation(MOUNT), atol=1e-12)
    tool = data["control_toolbox"]["gravity_compensation"]["tool"]
    assert tool["mass"] == pytest.approx(HAND_MASS + MASS)
    combined = (HAND_MASS * HAND_COM + MASS * COM) / (HAND_MASS + MASS)
    np.testing.assert_allclose(tool["CoG"], rotation(MOUNT) @ combined, atol=1e-15)
    np.testing.assert_allclose(tool["gravity_field"], rotation(TILT) @ [0, 0, -G], atol=1e-12)


def edited(text: str, change) -> str:
    """payload.yaml's text with ``change`` applied to its fields."""
    data = yaml.safe_load(text)
    change(data)
    return yaml.safe_dump(data, sort_keys=False)


GOOD = payload_yaml(make_payload())


@pytest.mark.parametrize(
    ("text", "options", "message"),
    [
        ("mass: [0.1\ncom: {", {}, "does not parse as YAML"),
        ("- 0.1\n- 0.2\n", {}, "not a payload file"),
        (edited(GOOD, lambda d: d.pop("mass")), {}, "field 'mass' is missing"),
        (edited(GOOD, lambda d: d.update(com=[0.1, 0.2])), {}, "field 'com' must be 3 numbers"),
        (edited(GOOD, lambda d: d.update(com="0 0 0")), {}, "field 'com' must be 3 numbers"),
        (GOOD.replace("\nmass: 0.1\n", "\nmass: .nan\n"), {}, "field 'mass' must be finite"),
        (GOOD.replace("\nmass: 0.1\n", "\nmass: -0.1\n"), {}, "field 'mass' must be > 0"),
        (edited(GOOD, lambda d: d.pop("hand")), {}, "field 'hand' is missing"),
        (edited(GOOD, lambda d: d["bias"].update(torque=True)), {}, "'bias.torque' must be 3"),
        (edited(GOOD, lambda d: d["covariance"].pop()), {}, "'covariance' must be 4 lists"),
        (edited(GOOD, lambda d: d.update(time="yesterday")), {}, "field 'time' must be an ISO"),
        (
            edited(
                GOOD,
                lambda d: d["control_toolbox"]["gravity_compensation"]["tool"].update(mass=2.0),
            ),
            {},
            "field 'control_toolbox.gravity_compensation.tool.mass' is 2.0",
        ),
        (GOOD, {"frame": "tool0"}, "field 'frame' is 'ft_sensor', expected 'tool0'"),
        (GOOD, {"hand_id": "other_hand"}, "field 'hand_id' is 'test_hand', expected 'other_hand'"),
    ],
)
def test_read_payload_names_the_field_it_refuses(tmp_path, text, options, message):
    path = tmp_path / PAYLOAD_FILE
    path.write_text(text)
    with pytest.raises(PayloadError, match=re.escape(message)) as caught:
        read_payload(path, **options)
    assert str(caught.value).startswith(f"{path}: ")


def test_read_payload_matches_any_hand_when_either_is_unknown(tmp_path):
    path = tmp_path / PAYLOAD_FILE
    path.write_text(GOOD)
    assert read_payload(path, hand_id="").hand_id == "test_hand"
    assert read_payload(path, hand_id=None, frame=None).frame == "ft_sensor"
    path.write_text(payload_yaml(make_payload(hand_id="")))
    assert read_payload(path, hand_id="other_hand").hand_id == ""
    with pytest.raises(PayloadError, match="cannot be read"):
        read_payload(tmp_path / "missing.yaml")


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"mass": 0.0}, "mass"),
        ({"mass": float("nan")}, "mass"),
        ({"com": [0.0, 0.0]}, "com"),
        ({"bias": [0.0] * 5 + [float("inf")]}, "bias"),
        ({"cov": -np.eye(4)}, "cov"),
        ({"hand_mass": -1.0}, "hand_mass"),
        ({"gravity": np.zeros(3)}, "gravity"),
        ({"frame": ""}, "frame"),
        ({"time": "noon"}, "time"),
    ],
)
def test_payload_refuses_values_that_cannot_serve(changes, field):
    with pytest.raises(PayloadError, match=f"field '{field}'") as caught:
        make_payload(**changes)
    assert caught.value.field == field


def test_payload_arrays_are_read_only_copies():
    com = COM.copy()
    payload = make_payload(com=com)
    com[0] = 1.0
    assert payload.com[0] == COM[0]
    with pytest.raises(ValueError, match="read-only"):
        payload.com[0] = 1.0
    moved = replace(payload, com=[0.0, 0.0, 0.2])
    rotations = random_rotations(3)
    assert not np.allclose(payload_wrench(moved, rotations), payload_wrench(payload, rotations))


# --- from a solution ------------------------------------------------------------------

JOINTS = [(0.0, 0.0), (0.5, 0.0), (-0.5, 0.0), (0.0, 0.5), (0.0, -0.5), (0.4, 0.6), (-0.7, 0.3)]
SAMPLE_COV = SensorModel.from_scalars(0.1, 0.005).sample_covariance()


def robot_model() -> RobotModel:
    return RobotModel(ROBOT_URDF.format(payload=""), "hand", "base")


def observations(robot: RobotModel, loads=(False, True)) -> list[Observation]:
    """Noise-free windows of the hand alone and holding the object at each pose, seen by a
    sensor mounted at MOUNT under a base tilted by TILT, with the bias BIAS."""
    out = []
    for k, (a, b) in enumerate(JOINTS):
        R = robot.sensor_rotation({"j1": a, "j2": b})
        g = rotation(MOUNT).T @ R.T @ rotation(TILT) @ robot.gravity
        for load in loads:
            mean = BIAS + gravity_wrench(HAND_MASS, HAND_COM, g)
            mean = mean + (gravity_wrench(MASS, COM, g) if load else 0.0)
            window = window_from_mean(f"p{k}", mean, SAMPLE_COV / 1000, 1000)
            out.append(Observation(window, R, load, 0, 2.0 * k))
    return out


def solution_of(fit, information=KINEMATICS_MOUNT) -> Solution:
    e = fit.estimate
    consistency = Consistency(True, e.chi2, e.dof, e.p_value, 0.01)
    return Solution("OK", "test", "ml", e, consistency, information=information, fit=fit)


def test_payload_from_a_kinematic_fit_compensates_its_windows():
    robot = robot_model()
    obs = observations(robot)
    fit = kinematic_ml(obs, robot.gravity, fit_mount=True)
    payload = payload_from_solution(
        solution_of(fit),
        robot,
        frame="ft_sensor",
        hand_id="test_hand",
        time="2026-01-02T03:04:05Z",
    )
    assert payload.mass == pytest.approx(MASS, rel=1e-9)
    np.testing.assert_allclose(payload.com, COM, atol=1e-9)
    np.testing.assert_allclose(payload.bias, BIAS, atol=1e-9)
    assert payload.hand_mass == pytest.approx(HAND_MASS, rel=1e-9)
    np.testing.assert_allclose(payload.hand_com, HAND_COM, atol=1e-9)
    np.testing.assert_allclose(payload.mount, MOUNT, atol=1e-9)
    np.testing.assert_allclose(payload.base_tilt, TILT, atol=1e-9)
    np.testing.assert_array_equal(payload.cov, fit.estimate.cov)
    assert (payload.frame, payload.sensor_frame, payload.base_frame) == (
        "ft_sensor",
        "hand",
        "base",
    )
    assert (payload.information, payload.hand_id) == (KINEMATICS_MOUNT, "test_hand")
    loads = [o for o in obs if o.load]
    means = np.array([o.window.mean for o in loads])
    rotations = np.array([o.rotation for o in loads])
    np.testing.assert_allclose(compensate(payload, means, rotations), 0.0, atol=1e-9)


def test_payload_from_solution_stamps_now_in_utc():
    robot = robot_model()
    fit = kinematic_ml(observations(robot), robot.gravity, fit_mount=True)
    payload = payload_from_solution(solution_of(fit), robot, frame="ft_sensor", hand_id="")
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", payload.time)


def test_payload_from_solution_refuses_what_cannot_compensate():
    robot = robot_model()
    fit = kinematic_ml(observations(robot), robot.gravity, fit_mount=True)
    options = {"frame": "ft_sensor", "hand_id": "test_hand"}
    failed = Solution("ERROR", "no windows", "ml")
    with pytest.raises(PayloadError, match=r"no usable estimate \(ERROR: no windows\)"):
        payload_from_solution(failed, robot, **options)
    moved = replace(solution_of(fit), consistency=Consistency(False, 99.0, 10, 1e-9, 0.01))
    with pytest.raises(PayloadError, match="no usable estimate"):
        payload_from_solution(moved, robot, **options)
    wrenches = replace(solution_of(fit, WRENCHES), fit=None)
    with pytest.raises(PayloadError, match="'wrenches' has no kinematic fit"):
        payload_from_solution(wrenches, robot, **options)
    untared = kinematic_ml(observations(robot, loads=(True,)), robot.gravity)
    with pytest.raises(PayloadError, match="no empty-hand window"):
        payload_from_solution(solution_of(untared), robot, **options)


# --- URDF -----------------------------------------------------------------------------


def test_pinocchio_reads_the_urdf_fragment():
    payload = make_payload()
    model = pinocchio.buildModelFromXML(ROBOT_URDF.format(payload=urdf_snippet(payload)))
    hand = model.frames[model.getFrameId("hand")]
    link = model.frames[model.getFrameId("payload")]
    j2 = model.getJointId("j2")
    assert link.parentJoint == j2
    np.testing.assert_allclose(link.placement.homogeneous, hand.placement.homogeneous)
    com_in_hand = rotation(MOUNT) @ COM
    assert model.inertias[j2].mass == pytest.approx(MASS, rel=1e-15)
    np.testing.assert_allclose(model.inertias[j2].lever, hand.placement.act(com_in_hand))
    np.testing.assert_array_equal(model.inertias[j2].inertia, np.zeros((3, 3)))
    assert "inertia not estimated" in urdf_snippet(payload)


INERTIA = np.array([[3.7e-4, 1e-6, -2e-6], [1e-6, 3.1e-4, 4e-6], [-2e-6, 4e-6, 2.1e-4]])


def test_a_payload_in_motion_keeps_its_inertias_and_delay_to_the_bit(tmp_path):
    """payload.yaml of a payload from an exploration in motion reads back with the same
    inertias and delay; its URDF fragment gives pinocchio the object's inertia about its
    COM in the sensor's URDF frame, R(mount) I R(mount)^T (pinocchio holds it in the
    frame of the joint the hand hangs from)."""
    payload = make_payload(inertia=INERTIA, hand_inertia=INERTIA * 3, delay=0.0061)
    path = tmp_path / PAYLOAD_FILE
    path.write_text(payload_yaml(payload))
    assert_same_payload(read_payload(path), payload)
    model = pinocchio.buildModelFromXML(ROBOT_URDF.format(payload=urdf_snippet(payload)))
    inertia = model.inertias[model.getJointId("j2")].inertia  # in the joint's frame
    hand = model.frames[model.getFrameId("hand")].placement.rotation
    expected = hand @ rotation(MOUNT) @ INERTIA @ rotation(MOUNT).T @ hand.T
    np.testing.assert_allclose(inertia, expected, rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize(
    "inertia", [np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) * 1e-4, np.eye(2)]
)
def test_an_inertia_that_is_not_a_symmetric_3x3_is_refused(inertia):
    with pytest.raises(PayloadError, match="inertia"):
        make_payload(inertia=inertia)


# --- files ----------------------------------------------------------------------------


def test_write_payload_files_writes_the_three_files(tmp_path):
    payload = awkward_payload(7)
    directory = tmp_path / "out" / "deeper"
    paths = write_payload_files(directory, payload)
    assert paths == [directory / n for n in (PAYLOAD_FILE, GRAVITY_COMPENSATION_FILE, URDF_FILE)]
    assert sorted(p.name for p in directory.iterdir()) == sorted(p.name for p in paths)
    assert_same_payload(read_payload(paths[0]), payload)
    assert paths[1].read_text() == gravity_compensation_parameters(payload)
    assert paths[2].read_text() == urdf_snippet(payload)
    write_payload_files(directory, make_payload())  # replaces them
    assert_same_payload(read_payload(paths[0]), make_payload())


def test_write_payload_files_to_an_unwritable_path_names_it(tmp_path):
    (tmp_path / "file").write_text("not a directory")
    directory = tmp_path / "file" / "sub"
    with pytest.raises(OSError, match=re.escape(str(directory))):
        write_payload_files(directory, make_payload())


def test_write_payload_files_leaves_no_partial_file(tmp_path):
    (tmp_path / PAYLOAD_FILE).mkdir()  # os.replace onto a directory fails
    with pytest.raises(OSError, match=re.escape(str(tmp_path / PAYLOAD_FILE))):
        write_payload_files(tmp_path, make_payload())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [PAYLOAD_FILE, GRAVITY_COMPENSATION_FILE, URDF_FILE]
    )
    assert Path(tmp_path / PAYLOAD_FILE).is_dir()


def test_payload_yaml_keeps_the_noise_learnt(tmp_path):
    """The sensor's noise model goes into payload.yaml and reads back to the same doubles."""
    noise = ar1_noise([0.1, 0.1, 0.1, 0.005, 0.005, 0.005], 0.005, 1000.0)
    payload = replace(awkward_payload(0), noise=noise)
    path = tmp_path / PAYLOAD_FILE
    path.write_text(payload_yaml(payload))
    back = read_payload(path).noise
    assert back is not None and back.ar == noise.ar
    np.testing.assert_array_equal(back.cov, noise.cov)
    np.testing.assert_array_equal(back.innovation, noise.innovation)
    path.write_text(payload_yaml(payload).replace("innovation:", "innovations:"))
    with pytest.raises(PayloadError, match="noise"):
        read_payload(path)
