"""com_core.estimation.runs.sensor_calibration and ``replay --reference-mass``: a run whose
object was a reference weight calibrates its sensor in place; the calibration is kept
per sensor, to the last bit, and a run of that sensor is read through it (replay, from
the copy beside its bag), while a reference that disagrees with the readings is refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import WORKSPACE, made_up_calibration, replay_json

from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.sensor_calibration import (
    CALIBRATION_FILE,
    calibrated_owner,
    load_calibration,
    save_calibration,
)
from com_core.estimation.runs.settings import use_cached_tares, use_sensor_calibration
from com_core.estimation.runs.tare_cache import BAG_TARE_FILE, load_tares
from com_core.report.run import read_run
from com_estimator import replay

SAMPLE = WORKSPACE / "bags" / "sample"
SENSOR = "lab-ft-7"


@pytest.fixture
def sample(tmp_path: Path) -> Path:
    """The sample run in ``tmp_path/bags``, its robot configuration naming its sensor."""
    bag = tmp_path / "bags" / "sample"
    shutil.copytree(SAMPLE, bag)
    robot = bag / "robot.yaml"
    text = robot.read_text()
    robot.write_text(text.replace("    hand_id:", f"    sensor_id: {SENSOR}\n    hand_id:", 1))
    return bag


def calibrate(bag: Path, mass: float, capsys, *options: str) -> tuple[int, str]:
    code = replay.main([str(bag), "--reference-mass", repr(mass), *options])
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def test_a_calibration_is_kept_per_sensor_to_the_last_bit(tmp_path):
    path = tmp_path / CALIBRATION_FILE
    assert load_calibration(path, SENSOR) is None
    entry = made_up_calibration(SENSOR)
    save_calibration(path, entry)
    save_calibration(path, made_up_calibration("another-sensor", 0.2))
    again = load_calibration(path, SENSOR)
    assert again is not None and again.as_json() == entry.as_json()
    np.testing.assert_array_equal(again.calibration.residual_cov, entry.calibration.residual_cov)
    assert load_calibration(path, "a third sensor") is None
    assert set(json.loads(path.read_text())["sensors"]) == {SENSOR, "another-sensor"}
    assert calibrated_owner("hand on s", entry) == "hand on s calibrated 2027-01-15T08:00:00Z"
    assert calibrated_owner("hand on s", None) == "hand on s"
    path.write_text('{"sensors": {"lab-ft-7": {"estimate": [1, 2]}}}')
    assert load_calibration(path, SENSOR) is None  # broken: the stated accuracy stands


def test_a_run_of_a_calibrated_sensor_reads_through_the_copy_beside_its_bag(sample):
    raw = replay_json(sample)
    save_calibration(sample / CALIBRATION_FILE, made_up_calibration(SENSOR))
    calibrated = replay_json(sample)
    assert calibrated == replay_json(sample)  # the same numbers, to the last bit
    assert calibrated["mass"] != raw["mass"]
    assert calibrated["sigma_mass"] < raw["sigma_mass"]  # a tenth of the error is left
    (sample / CALIBRATION_FILE).unlink()
    save_calibration(sample / CALIBRATION_FILE, made_up_calibration("another-sensor"))
    assert replay_json(sample) == raw  # another sensor's is not this run's


def test_the_samples_and_the_cached_tare_read_corrected(sample):
    entry = made_up_calibration(SENSOR)
    exploration = Exploration()
    exploration.add_samples([1, 2], np.array([[1.0, 2, 3, 0.1, 0.2, 0.3]] * 2), "")
    raw = exploration.samples()[1]
    use_sensor_calibration(exploration, entry)
    use_cached_tares(exploration, sample / BAG_TARE_FILE)
    m = entry.calibration.correction
    np.testing.assert_array_equal(exploration.samples()[1], raw @ m.T)
    cached = load_tares(sample / BAG_TARE_FILE)
    for pose, window in cached.windows.items():
        np.testing.assert_array_equal(exploration.tares[pose].mean, m @ window.mean)


def test_a_reference_too_light_for_the_gains_is_not_kept(sample, capsys):
    code, out = calibrate(sample, read_run(sample).truth.mass, capsys)  # a 100 g object
    assert code == 0 and "calibration not kept" in out and "heavier reference" in out, out
    assert "identified force from force" in out
    assert not (sample.parent / CALIBRATION_FILE).exists()


def test_a_reference_the_readings_disagree_with_is_not_kept(sample, capsys):
    code, out = calibrate(sample, 1.5 * read_run(sample).truth.mass, capsys)
    assert code == 0 and "calibration not kept" in out and "chi^2" in out, out
    assert not (sample.parent / CALIBRATION_FILE).exists()


def test_a_calibration_needs_a_named_sensor_and_a_mass(sample, capsys):
    robot = sample / "robot.yaml"
    robot.write_text(robot.read_text().replace(f"    sensor_id: {SENSOR}\n", ""))
    out = calibrate(sample, 1.0, capsys)[1]
    assert "calibration not kept" in out and "names no sensor_id" in out, out
    assert not (sample.parent / CALIBRATION_FILE).exists()
    with pytest.raises(SystemExit) as stop:
        replay.main([str(sample), "--reference-mass", "-1"])
    assert stop.value.code == 2


def test_a_recording_of_a_calibrated_sensor_is_weighed_with_what_is_left_of_the_error(sample):
    """The sample bag read as a recording without labels (its labels on another topic):
    with this sensor's calibration beside it the fit reads the samples corrected and
    weighs what is left of the error, not the stated accuracy (a smaller sigma)."""
    raw = replay_json(sample, None, "--pose-topic", "/none")
    save_calibration(sample / CALIBRATION_FILE, made_up_calibration(SENSOR))
    calibrated = replay_json(sample, None, "--pose-topic", "/none")
    assert raw["windows_from"] == calibrated["windows_from"] == "recording"
    assert calibrated["mass"] != raw["mass"]
    assert calibrated["sigma_mass"] < 0.7 * raw["sigma_mass"], (calibrated, raw)
