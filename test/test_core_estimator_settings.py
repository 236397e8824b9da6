"""com_core.estimation.runs.settings: the node's parameters and the replay's options are one
table, one check and one mapping to an Exploration."""

from __future__ import annotations

from com_core.estimation.fits.windows import window_from_mean
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.settings import (
    BAG_SETTINGS_FILE,
    SETTINGS,
    defaults,
    exploration_from,
    load_cached_tares,
    read_bag_settings,
    write_bag_settings,
)
from com_core.estimation.runs.tare_cache import save_tares


def test_the_defaults_are_an_explorations_defaults():
    made, plain = exploration_from({}), Exploration()
    for name in ("method", "alpha", "expected_frame", "min_tilt_sigmas", "max_label_gap"):
        assert getattr(made, name) == getattr(plain, name) == SETTINGS[name].default, name
    assert made.sensor is None  # no noise, no range: the motion test goes by drift


def test_a_noise_or_a_range_sets_the_sensor_model():
    made = exploration_from({"sigma_f": 0.1, "sigma_tau": 0.005, "limit_f": 50.0})
    assert made.sensor is not None
    assert made.sensor.sigma[:3].tolist() == [0.1] * 3
    assert made.sensor.limit[:3].tolist() == [50.0] * 3


def test_the_cached_tare_is_the_current_entry_of_the_file(tmp_path):
    assert load_cached_tares("") is None
    assert load_cached_tares(tmp_path / "none.json") is None
    window = window_from_mean("home", [0, 0, 9.9, 0, 0, 0], [[0.0] * 6] * 6, 5000)
    save_tares(tmp_path / "cache.json", "hand|plan", {"home": window})
    assert load_cached_tares(tmp_path / "cache.json").windows["home"].force[2] == 9.9


def test_a_runs_settings_beside_its_bag_read_back_as_written_and_refused_values_left_out(
    tmp_path,
):
    """``estimator.yaml``: the replay's defaults for the run (the frames, the URDF and the
    tare cache have files of their own)."""
    path = tmp_path / BAG_SETTINGS_FILE
    values = defaults() | {"accuracy": 0.03, "full_scale": [50.0, 10.0], "wrench_sign": -1.0}
    write_bag_settings(values | {"sensor_frame": "tool0", "robot_description": "<robot/>"}, path)
    read = read_bag_settings(path)
    assert read["accuracy"] == 0.03 and read["full_scale"] == [50.0, 10.0]
    assert read["wrench_sign"] == -1.0 and read["method"] == "ml"
    assert not {"sensor_frame", "robot_description", "tare_cache"} & read.keys()
    path.write_text("accuracy: -2.0\nmethod: ml\nno_such_setting: 1\n")
    assert read_bag_settings(path) == {"method": "ml"}
    assert read_bag_settings(tmp_path / "none.yaml") == {}


def test_a_stated_hysteresis_takes_its_gain_off_every_sample():
    """The samples an exploration fits are the readings divided by the gain 1 - d the
    stated band gives each axis (``Hysteresis.gain``); with no band, as read."""
    import numpy as np

    band = [3.75, 3.75, 2.0, 0.04, 0.04, 0.04]  # the xArm F/T's
    made = exploration_from({"hysteresis": band, "full_scale": [150.0, 4.0]})
    plain = exploration_from({"full_scale": [150.0, 4.0]})
    readings = np.random.default_rng(0).normal(0.0, 5.0, (4, 6))
    for exploration in (made, plain):
        assert exploration.add_samples([1, 2, 3, 4], readings, exploration.expected_frame) == 4
    assert made.hysteresis is not None and plain.hysteresis is None
    gain = made.hysteresis.gain()
    assert np.all((gain > 0.96) & (gain < 0.99))  # 3.4 % of fx, fy; 1.8 % of fz
    np.testing.assert_allclose(made.samples()[1], readings / gain, rtol=1e-15)
    np.testing.assert_array_equal(plain.samples()[1], readings)
