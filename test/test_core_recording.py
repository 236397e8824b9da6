"""An estimate from any recording (``com_core.estimation.recordings.recording_fit``):
unlabelled wrenches with the sensor's orientations or the arm's joint states, a large
bias, slow motion with a few rests."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from com_core.contract import ERROR, OK, WARN
from com_core.estimation.recordings import (
    CSV_COLUMNS,
    fit_recording,
    read_recording_file,
    recording_from_orientations,
)
from com_core.paper.synthetic import Load, wandering_recording
from com_core.sensing.calibration import Calibration
from com_core.sensing.wrench_model import SensorModel, calibration_matrix

LOAD = Load(0.22, (0.01, -0.02, 0.06))
BIAS = np.array([4.0, -5.0, 3.0, 0.2, -0.1, 0.15])  # |f| 7.07 N
RATE = 248.0
ACCURACY, FULL_SCALE = 0.01, (290.0, 10.0)


def sensor(rng: np.random.Generator | None = None, noise: bool = True) -> SensorModel:
    """A sensor of the realistic profile's noise (coloured, quantised) with a 7 N bias and,
    from ``rng``, a 1 % calibration error; exact with ``noise`` False."""
    if not noise:
        return SensorModel(bias=BIAS, rate_hz=RATE)
    calibration = None if rng is None else calibration_matrix(ACCURACY, *FULL_SCALE, rng)
    return SensorModel(
        sigma=np.array([0.1] * 3 + [0.005] * 3),
        bias=BIAS,
        resolution=np.array([1 / 16] * 3 + [1 / 2000] * 3),
        rate_hz=RATE,
        correlation_time=0.005,
        calibration=calibration,
    )


def recorded(seed: int, noise: bool = True, calibrated: bool = False, **options):
    """A wandering recording of ``LOAD`` (40 s unless ``options`` say), its sensor's
    calibration drawn if ``calibrated``: (the synthetic recording, its ``Recording``)."""
    rng = np.random.default_rng(seed)
    model = sensor(rng if calibrated else None, noise)
    rec = wandering_recording(model, LOAD, rng, **({"duration": 40.0} | options))
    return rec, recording_from_orientations(rec.times, rec.wrenches, rec.rotations)


def test_a_noiseless_recording_gives_the_load_and_the_bias_exactly():
    """Zero noise: the fit is the model's exact solution, whatever the 7 N bias."""
    _, recording = recorded(0, noise=False, duration=30.0)
    fit = fit_recording(recording)
    assert fit.status == OK, fit.reason
    assert fit.estimate is not None and fit.bias is not None
    # exact but for the delay's search (a parabola through its grid), which lands within
    # 1e-5 s of zero: 1e-7 of the mass, 10 nm
    assert abs(fit.delay) < 1e-5
    assert fit.estimate.mass == pytest.approx(LOAD.mass, rel=1e-7)
    np.testing.assert_allclose(fit.estimate.com, LOAD.com, atol=1e-8)
    np.testing.assert_allclose(fit.bias, BIAS, atol=1e-7)
    assert fit.whole_load and fit.rests >= 2


@pytest.mark.slow
def test_the_error_bars_are_honest_over_50_recordings():
    """50 recordings, each with its own sensor calibration (1 %), noise and path: every
    one OK and within 4 sigma (mass, COM, bias: the largest of 500 exceeds 3.5 one time in
    four), and rms(error / sigma) of the mass, the COM, the bias's force and torque each in
    0.8-1.2 (pooled over 50, or 150 for the vectors: an rms over 50 has a relative sd of
    10 %, so the bounds are 2 sd for the mass)."""
    z = []
    for seed in range(50):
        rec, recording = recorded(100 + seed, calibrated=True)
        fit = fit_recording(recording, calibration=Calibration(ACCURACY, *FULL_SCALE))
        assert fit.status == OK, (seed, fit.reason)
        e = fit.estimate
        assert e is not None and fit.bias is not None and fit.bias_sigma is not None
        z.append(
            np.concatenate(
                [
                    [(e.mass - LOAD.mass) / e.sigma_mass],
                    (e.com - LOAD.com) / e.sigma_com,
                    (fit.bias - rec.bias) / fit.bias_sigma,
                ]
            )
        )
    z = np.array(z)
    assert np.all(np.abs(z) < 4.0), np.abs(z).max(axis=0)
    rms = [
        math.sqrt(np.mean(z[:, part] ** 2)) for part in (0, slice(1, 4), slice(4, 7), slice(7, 10))
    ]
    assert all(0.8 <= r <= 1.2 for r in rms), rms


def test_a_load_that_changes_halfway_is_named_not_estimated():
    """A second object put in the hand at 25 s (30 g more): ERROR naming when and how
    much, with no estimate."""
    _, recording = recorded(3, change=(25.0, LOAD.mass + 0.03))
    fit = fit_recording(recording)
    assert fit.status == ERROR and fit.estimate is None
    assert "the load changed" in fit.reason
    assert fit.change is not None and fit.change.found
    assert abs(fit.change.time - 25.0) < 5.0
    assert fit.change.mass == pytest.approx(0.03, abs=5 * fit.change.sigma_mass)


def test_the_same_load_throughout_raises_no_change():
    _, recording = recorded(3)
    fit = fit_recording(recording)
    assert fit.status == OK, fit.reason
    assert fit.change is not None and not fit.change.found


def test_orientations_about_one_axis_are_named_with_the_sigma_they_leave():
    """Every move turns about the sensor's x axis: gravity stays in one plane of the sensor
    frame. WARN naming the axis and the COM's worst sigma; the estimate is kept (within 3
    sigma: the bias and the load are still told apart by the arc's curvature)."""
    _, recording = recorded(4, axes=(1.0, 0.0, 0.0))
    fit = fit_recording(recording)
    assert fit.status == WARN
    assert "turn about one axis ((1.00, 0.00, 0.00)" in fit.reason.replace("-0.00", "0.00")
    e = fit.estimate
    assert e is not None
    assert abs(e.mass - LOAD.mass) < 3 * e.sigma_mass
    assert np.all(np.abs(e.com - LOAD.com) < 3 * e.sigma_com)


def test_the_self_check_predicts_the_other_half_within_the_noise():
    """Each half predicting the other: per axis the residual in sigmas near 1 (the model
    holds), and in N and N m near the window noise."""
    _, recording = recorded(5)
    fit = fit_recording(recording)
    assert fit.check is not None
    assert np.all(fit.check.sigmas > 0.6) and np.all(fit.check.sigmas < 1.5), fit.check
    assert "self-check" in fit.summary()
    assert json.loads(json.dumps(fit.as_dict()))["check_sigmas"] == fit.check.sigmas.tolist()


def test_a_tare_recording_gives_the_object_alone():
    """The empty tool (0.15 kg) recorded on its own, then with the object: the object
    alone, within 3 sigma, and said to be the object."""
    rng = np.random.default_rng(6)
    tool = Load(0.15, (0.0, 0.005, 0.03))
    both_mass = tool.mass + LOAD.mass
    both_com = (tool.mass * np.array(tool.com) + LOAD.mass * np.array(LOAD.com)) / both_mass
    empty = wandering_recording(sensor(), tool, rng, duration=30.0)
    held = wandering_recording(sensor(), Load(both_mass, tuple(both_com)), rng, duration=30.0)
    fit = fit_recording(
        recording_from_orientations(held.times, held.wrenches, held.rotations),
        tare=recording_from_orientations(empty.times, empty.wrenches, empty.rotations),
    )
    assert fit.status == OK, fit.reason
    assert not fit.whole_load
    e = fit.estimate
    assert e is not None
    assert abs(e.mass - LOAD.mass) < 3 * e.sigma_mass
    assert np.all(np.abs(e.com - LOAD.com) < 3 * e.sigma_com)


def quaternion(r: np.ndarray) -> list[float]:
    """(x, y, z, w) of a rotation matrix, from its largest component (Shepperd's method:
    exact for a sensor hanging upside down, where w is near 0)."""
    trace = np.trace(r)
    k = int(np.argmax([r[0, 0], r[1, 1], r[2, 2], trace]))
    if k == 3:
        w = 0.5 * math.sqrt(1.0 + trace)
        return [
            (r[2, 1] - r[1, 2]) / (4 * w),
            (r[0, 2] - r[2, 0]) / (4 * w),
            (r[1, 0] - r[0, 1]) / (4 * w),
            w,
        ]
    i, j, m = k, (k + 1) % 3, (k + 2) % 3
    q = [0.0] * 4
    q[i] = 0.5 * math.sqrt(1.0 + r[i, i] - r[j, j] - r[m, m])
    q[j] = (r[j, i] + r[i, j]) / (4 * q[i])
    q[m] = (r[m, i] + r[i, m]) / (4 * q[i])
    q[3] = (r[m, j] - r[j, m]) / (4 * q[i])
    return q


def write_csv(path: Path, rec, quaternions: bool) -> None:
    """The recording as a CSV log: time, wrench, and R_base_sensor as a quaternion
    (x, y, z, w) or row-major."""
    if quaternions:
        orientation = np.array([quaternion(r) for r in rec.rotations])
    else:
        orientation = rec.rotations.reshape(-1, 9)
    kind = "quaternion" if quaternions else "rotation"
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["time", *CSV_COLUMNS["wrench"], *CSV_COLUMNS[kind]])
        for row in np.column_stack([rec.times, rec.wrenches, orientation]):
            writer.writerow([repr(float(v)) for v in row])


@pytest.mark.parametrize("quaternions", [True, False])
def test_a_csv_log_gives_the_estimate_of_its_arrays(tmp_path, quaternions):
    """The CSV of a recording, its orientations as quaternions or matrices, fitted as its
    arrays are: the same numbers (the quaternion's rounding aside)."""
    rec, recording = recorded(7)
    path = tmp_path / "log.csv"
    write_csv(path, rec, quaternions)
    from_file = fit_recording(read_recording_file(path))
    direct = fit_recording(recording)
    assert from_file.status == direct.status == OK, direct.reason
    assert from_file.estimate is not None and direct.estimate is not None
    assert from_file.estimate.mass == pytest.approx(direct.estimate.mass, rel=1e-9)
    np.testing.assert_allclose(from_file.estimate.com, direct.estimate.com, atol=1e-9)


def test_samples_not_finite_are_dropped_and_counted():
    """A NaN wrench and a NaN orientation in a log: both samples dropped, said in the
    notes, and the rest fitted: OK, the mass within 3 sigma."""
    rec, recording = recorded(10)
    wrenches, rotations = rec.wrenches.copy(), rec.rotations.copy()
    wrenches[100, 2], rotations[2000, 0, 0] = np.nan, np.nan
    damaged = recording_from_orientations(rec.times, wrenches, rotations)
    assert len(damaged.times) == len(recording.times) - 2
    assert "2 samples not finite, dropped" in damaged.notes
    fit = fit_recording(damaged)
    assert fit.status == OK, fit.reason
    assert "2 samples not finite, dropped" in fit.notes
    assert fit.estimate is not None
    assert abs(fit.estimate.mass - LOAD.mass) < 3 * fit.estimate.sigma_mass


def test_a_log_without_an_orientation_is_refused_by_name(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("time,fx,fy,fz,tx,ty,tz\n0,1,2,3,4,5,6\n")
    with pytest.raises(ValueError, match=r"qx, qy, qz, qw or r11\.\.r33"):
        read_recording_file(path)


def test_too_little_orientation_is_refused_or_named():
    """The sensor barely turns (0.01 rad): the load cannot be told from the bias; named
    with the sigma it leaves, or refused, never OK."""
    _, recording = recorded(8, tilt=0.01, duration=20.0)
    fit = fit_recording(recording)
    assert fit.status in (WARN, ERROR)
    if fit.status == WARN:
        assert fit.estimate is not None
        assert "barely turned" in fit.reason


WRIST_URDF = """<?xml version="1.0"?>
<robot name="three_axis_wrist">
  <link name="world"/>
  <link name="link1"><inertial><mass value="1.0"/><origin xyz="0 0 0.1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="link2"><inertial><mass value="0.5"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.005" iyy="0.005" izz="0.005" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="link3"><inertial><mass value="0.3"/><origin xyz="0.05 0 0"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="ft_sensor"/>
  <joint name="j1" type="revolute"><parent link="world"/><child link="link1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="0.3 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="flange" type="fixed"><parent link="link3"/><child link="ft_sensor"/>
    <origin xyz="0.08 0 0" rpy="0 1.5708 0"/></joint>
</robot>
"""


def wrist_recording(seed: int, speed: float, inertia: np.ndarray):
    """The three-joint wrist (``WRIST_URDF``) wandering with rests, its joints at up to
    ``speed`` rad/s (quintic moves): joint states at 100 Hz with jittered stamps, and
    wrenches at 250 Hz of ``LOAD`` with ``inertia`` (about its COM) through white noise
    and the 7 N bias. (robot model, recording)."""
    from com_core.estimation.recordings import recording_from_joint_states
    from com_core.robot.dynamics import inertial_parameters, sensor_regressors
    from com_core.robot.model import RobotModel

    robot = RobotModel(WRIST_URDF, "ft_sensor", "world")
    rng = np.random.default_rng(seed)
    knots_t, knots_q = [0.0], [np.zeros(3)]
    while knots_t[-1] < 45.0:
        target = rng.uniform(-1.0, 1.0, 3)
        rest = knots_t[-1] + rng.uniform(0.5, 2.5)
        move = float(np.max(np.abs(target - knots_q[-1]))) / speed * 1.875  # quintic peak
        knots_t += [rest, rest + move]
        knots_q += [knots_q[-1], target]
    kt, kq = np.array(knots_t), np.array(knots_q)

    def path(t):
        k = np.clip(np.searchsorted(kt, t, side="right") - 1, 0, len(kt) - 2)
        s = (t - kt[k]) / (kt[k + 1] - kt[k])
        ds = 1.0 / (kt[k + 1] - kt[k])
        smooth, d_smooth = s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2 * ds
        dd_smooth = 60 * s * (1 - s) * (1 - 2 * s) * ds**2
        step = kq[k + 1] - kq[k]
        return (
            kq[k] + smooth[:, None] * step,
            d_smooth[:, None] * step,
            dd_smooth[:, None] * step,
        )

    pi = inertial_parameters(LOAD.mass, np.array(LOAD.com), inertia)
    times = np.arange(0.0, kt[-1], 1 / 250)
    true = sensor_regressors(robot, *path(times)) @ pi
    wrenches = true + BIAS + rng.normal(size=true.shape) * np.array([0.1] * 3 + [0.005] * 3)
    base = np.arange(0.0, kt[-1], 0.01)
    joint_times = np.sort(base + rng.uniform(-2e-3, 2e-3, len(base)))
    return recording_from_joint_states(robot, joint_times, path(joint_times)[0], times, wrenches)


def test_joint_states_of_an_arm_given_only_as_a_urdf():
    """A three-joint wrist this project ships no configuration for, given as its URDF:
    joint states at 100 Hz with jittered stamps (resampled), wrenches at 250 Hz of a load
    with its inertia (which the fit leaves to its bound) in slow motion (0.15 rad/s) with
    rests, through a sensor of white noise and a 7 N bias. OK, mass, COM and bias within 3
    sigma, and the inertia not published: the motion excites it too little."""
    recording = wrist_recording(12, 0.15, np.diag([2e-4, 3e-4, 1e-4]))
    assert recording.dynamic
    assert any("resampled" in note for note in recording.notes)
    fit = fit_recording(recording)
    assert fit.status == OK, fit.reason
    e = fit.estimate
    assert e is not None and fit.bias is not None and fit.bias_sigma is not None
    assert abs(e.mass - LOAD.mass) < 3 * e.sigma_mass
    assert np.all(np.abs(e.com - LOAD.com) < 3 * e.sigma_com)
    assert np.all(np.abs(fit.bias - BIAS) < 3 * fit.bias_sigma)
    assert fit.moments is None
    assert any("the inertia: not published" in note for note in fit.notes)


def test_the_inertia_where_the_motion_excites_it():
    """The same wrist moving fast (3 rad/s) with a load of a large inertia: the inertia's
    principal moments published, each within 3 sigma of the truth, and the mass and COM
    still within 3 sigma (the inertia's torque weighed by its bound)."""
    inertia = np.diag([4e-3, 6e-3, 3e-3])
    fit = fit_recording(wrist_recording(14, 3.0, inertia))
    assert fit.estimate is not None, fit.reason
    assert fit.moments is not None and fit.moments_sigma is not None, fit.notes
    truth = np.sort(np.linalg.eigvalsh(inertia))
    assert np.all(np.abs(fit.moments - truth) < 3 * fit.moments_sigma), (fit.moments, truth)
    e = fit.estimate
    assert abs(e.mass - LOAD.mass) < 3 * e.sigma_mass
    assert np.all(np.abs(e.com - LOAD.com) < 3 * e.sigma_com)
