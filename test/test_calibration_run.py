"""A calibration in place through the three nodes, as a user runs it:
``make demo ARGS="--calibrate --mass 1.0"`` (the Explore goal's ``reference_mass``), the
realistic sensor."""

from __future__ import annotations

import subprocess
import sys

import pytest
import yaml
from conftest import replay_json

from com_core.estimation.runs.sensor_calibration import CALIBRATION_FILE, load_calibration
from com_core.report.run import read_run
from wrench_sim.objects import reference_weight_mass

pytestmark = pytest.mark.system

SENSOR = "sim-realistic-0"  # the demo's name of the sim's default sensor


def test_a_run_of_a_reference_weight_calibrates_the_sensor_and_the_bag_replays_it(
    ros_env, tmp_path
):
    """The sequencer runs the exploration with the estimator's ``reference_mass`` set for
    the run (and restored after); the estimator identifies the calibration, keeps it for
    the sensor beside the tare cache and says what it identified; the bag records the
    setting, and its replay identifies the same calibration to the last bit without
    keeping it again."""
    bags = tmp_path / "bags"
    done = subprocess.run(
        [sys.executable, "-m", "exploration_sequencer.demo", "--calibrate", "--mass", "1.0",
         "--seed", "5", "--bag-dir", str(bags)],
        env=ros_env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    out = done.stdout + done.stderr
    assert done.returncode == 0, out
    assert "[OK] calibrated in place with 1000.0 g over 5 poses" in out, out
    kept = load_calibration(bags / CALIBRATION_FILE, SENSOR)
    assert kept is not None, out
    left = kept.result.left
    assert left["force from force"] < 0.25 and all(share < 0.8 for share in left.values())
    (bag,) = [path for path in bags.iterdir() if (path / "metadata.yaml").is_file()]
    assert yaml.safe_load((bag / "estimator.yaml").read_text())["reference_mass"] == 1.0
    run = read_run(bag)  # the sim's weight is off its stated 1 kg, as a real one is
    assert run.truth is not None and run.truth.mass == reference_weight_mass(1.0, 5) != 1.0
    values = run.diagnostic["values"]
    offline = replay_json(bag)
    assert offline["calibration"] == values["calibration"] == kept.result.summary()
    node_left = [float(v) for v in values["calibration_left"].split(",")]
    assert offline["calibration_left"] == node_left == list(left.values())
    assert offline["calibration_kept"].startswith("calibration not kept here")
