"""com_core.estimation.runs.tare_cache: one entry per hand and plan, the current one, the
drift test."""

from __future__ import annotations

import math
import time

import numpy as np
from conftest import WORKSPACE, choreography

from com_core.estimation.fits.windows import window_from_mean
from com_core.estimation.runs.tare_cache import (
    BAG_TARE_FILE,
    TareCache,
    cache_owner,
    drift,
    drift_accepted,
    latest_hand_model,
    load_tares,
    reusable,
    save_tares,
    tare_signature,
    use_tares,
)
from com_core.planning.planner import Plan

PANDA = choreography("panda")


def windows(fz: float) -> dict:
    cov = np.eye(6) * 1e-6
    return {pose: window_from_mean(pose, [0, 0, fz, 0, 0, 0], cov, 5000) for pose in ("home",)}


def test_a_run_with_another_plan_keeps_the_first_plans_tare(tmp_path):
    """Two plans share one cache file: each keeps its entry, the last used is current."""
    path = tmp_path / "tare_cache.json"
    default = tare_signature("panda_hand", PANDA.pose_joints(Plan()))
    paper = tare_signature("panda_hand", PANDA.pose_joints(Plan(0.05, ("x",), False)))
    assert default != paper
    save_tares(path, default, windows(9.9))
    save_tares(path, paper, windows(9.8))
    assert load_tares(path, default).windows["home"].force[2] == 9.9
    assert load_tares(path, paper).windows["home"].force[2] == 9.8
    assert load_tares(path).signature == paper  # current: what the estimator reads
    use_tares(path, load_tares(path, default))
    assert load_tares(path).signature == default
    assert load_tares(path, "another hand") is None
    assert load_tares(tmp_path / "none.json") is None


def test_a_bag_copy_holds_one_entry_and_old_single_entry_files_load(tmp_path):
    sample = load_tares(WORKSPACE / "bags" / "sample" / BAG_TARE_FILE)  # one entry, no index
    assert sample is not None and "home" in sample.windows
    copy = tmp_path / BAG_TARE_FILE
    use_tares(copy, sample)
    again = load_tares(copy)
    assert again.signature == sample.signature and again.created == sample.created
    np.testing.assert_array_equal(again.windows["home"].mean, sample.windows["home"].mean)
    np.testing.assert_array_equal(again.windows["home"].cov, sample.windows["home"].cov)


def test_the_hand_model_is_the_newest_entry_of_the_hand_with_joints_whatever_its_plan(tmp_path):
    """A hand model serves any plan: the newest entry of the hand whose windows all have
    their joint positions; they and the windows' times round-trip to the bit."""
    path = tmp_path / "tare_cache.json"
    joints = {"home": {"panda_joint1": 0.1, "panda_joint2": -0.2}}
    times = {"home": 12.345678901234567}
    default = tare_signature("panda_hand", PANDA.pose_joints(Plan()))
    paper = tare_signature("panda_hand", PANDA.pose_joints(Plan(0.05, ("x",), False)))
    save_tares(path, default, windows(9.9), joints, times)
    save_tares(path, paper, windows(9.8))  # newer, but without joints: no hand model
    save_tares(
        path, tare_signature("gripper_2", [("home", list(PANDA.home))]), windows(7.0), joints
    )
    model = latest_hand_model(path, "panda_hand")
    assert model is not None and model.signature == default and model.has_joints
    assert model.joints == joints and model.times == times
    assert latest_hand_model(path, "no such hand") is None
    assert latest_hand_model(tmp_path / "none.json", "panda_hand") is None


def test_drift_is_chi_square_in_the_noise_and_large_beyond_it():
    cached = windows(9.9)["home"]
    same = window_from_mean("home", cached.mean + 1e-3, cached.cov, 5000)  # 1 sigma per axis
    moved = window_from_mean(
        "home", cached.mean + np.array([0, 0, 0.05, 0, 0, 0]), cached.cov, 5000
    )
    chi2, p = drift(cached, same)
    assert abs(chi2 - 3.0) < 1e-9 and p > 0.5  # 6 axes x (1e-3)^2 / 2e-6
    assert drift(cached, moved)[1] < 1e-6


def test_an_entry_is_reusable_while_young_with_every_pose_and_a_drift_in_the_noise():
    cached = windows(9.9)["home"]
    entry = TareCache("panda_hand|home", time.time() - 10.0, {"home": cached})
    assert reusable(entry, 60.0, ["home"])
    assert not reusable(entry, 5.0, ["home"])  # older than max_age
    assert not reusable(entry, 60.0, ["home", "tilt_y+"])  # a pose without a window
    assert not reusable(None, 60.0, ["home"])
    same = window_from_mean("home", cached.mean + 1e-3, cached.cov, 5000)
    moved = window_from_mean(
        "home", cached.mean + np.array([0, 0, 0.05, 0, 0, 0]), cached.cov, 5000
    )
    assert drift_accepted(cached, same)[0]
    ok, chi2, p = drift_accepted(cached, moved)
    assert not ok and chi2 > 100 and p < 1e-3
    assert drift_accepted(cached, None) == (False, math.inf, 0.0)  # no fresh window


def test_a_hand_model_serves_the_sensor_it_was_read_by_only(tmp_path):
    """The same hand on two sensors: each sensor's entry models the hand on that sensor,
    and a sensor with no entry of its own gets none (not the other's bias and noise)."""
    path = tmp_path / "tare_cache.json"
    joints = {"home": {"panda_joint1": 0.1}}
    poses = PANDA.pose_joints(Plan())
    first, second = cache_owner("panda_hand", "ft-1"), cache_owner("panda_hand", "ft-2")
    save_tares(path, tare_signature(first, poses), windows(9.9), joints)
    save_tares(path, tare_signature(second, poses), windows(5.0), joints)
    for owner, fz in ((first, 9.9), (second, 5.0)):
        model = latest_hand_model(path, owner)
        assert model is not None and model.owner == owner
        assert model.windows["home"].force[2] == fz
    assert latest_hand_model(path, cache_owner("panda_hand", "ft-3")) is None
    assert latest_hand_model(path, cache_owner("panda_hand", "")) is None
    assert cache_owner("panda_hand", "") == "panda_hand on an unnamed sensor"


def test_cached_windows_and_their_ways_read_as_the_samples_do(tmp_path):
    """The cache keeps what the sensor read, and each window's way (``Way``) to the last
    bit; an exploration takes both through what corrects its samples (here the gain of the
    xArm F/T's stated hysteresis, 1.8-3.5 % in the forces): a cached hand weighs what the
    run's own samples say it weighs, not 3.5 % less across the sensor. Told no hysteresis,
    it takes the windows as read and no ways."""
    from com_core.estimation.runs.exploration import Exploration
    from com_core.estimation.runs.settings import use_cached_tares
    from com_core.sensing.hysteresis import Hysteresis, Way
    from com_core.sensing.sensor_profiles import PROFILES

    xarm = PROFILES["xarm_ft"]
    hysteresis = Hysteresis.stated(xarm.hysteresis, xarm.limit_f, xarm.limit_tau)
    read = np.array([-5.6, -1.4, 7.7, 0.02, -0.22, 0.01])
    ways = {
        "home": Way(None, None, np.zeros(6)),
        "tilt": Way(np.full(6, 3.0), np.array([[-6.0] * 6, [9.5] * 6]), read * 1e-3),
    }
    path = tmp_path / "tare_cache.json"
    cov = np.eye(6) * 1e-6
    cached = {pose: window_from_mean(pose, read, cov, 5000) for pose in ways}
    save_tares(path, "panda_hand", cached, ways=ways)
    again = load_tares(path)
    assert again.ways.keys() == ways.keys() and again.ways["home"].travel is None
    for name in ("travel", "reach", "beyond"):
        np.testing.assert_array_equal(
            getattr(again.ways["tilt"], name), getattr(ways["tilt"], name)
        )
    exploration = Exploration(expected_frame="", hysteresis=hysteresis)
    use_cached_tares(exploration, path)
    exploration.add_samples([1], [read], "")
    as_read = exploration.samples()[1][0]
    assert np.abs(as_read[:3] / read[:3] - 1.0).min() > 0.015  # the gain: 3.5, 3.5, 1.8 %
    np.testing.assert_allclose(exploration.tares["tilt"].mean, as_read, rtol=1e-12)
    way = exploration.cached_tare.ways["tilt"]
    np.testing.assert_allclose(way.beyond, as_read * 1e-3, rtol=1e-12)
    np.testing.assert_allclose(way.reach, np.outer([-6.0, 9.5], as_read / read), rtol=1e-12)
    np.testing.assert_allclose(way.travel, 3.0 * as_read / read, rtol=1e-12)
    untold = Exploration(expected_frame="")  # no hysteresis stated: the windows as read
    use_cached_tares(untold, path)
    assert not untold.cached_tare.ways and np.array_equal(untold.tares["tilt"].mean, read)


def test_a_drift_since_the_tare_is_a_warning_only_beyond_what_the_fit_can_tell():
    """``fit_setup.drifted``: a bias drift is beyond ``max_drift_f`` (1 N) when it exceeds
    it by more than its sigma along it allows at alpha 1e-3 (3.09 sigma, one-sided):
    1.2 N read to 0.05 N is; read to 0.4 N, as a sensor of stated hysteresis leaves it (an
    offset after each contact), it is not, until 2.24 N. Only the sigma along the drift
    counts, and within the limit nothing is."""
    from com_core.estimation.runs.fit_setup import drifted

    up = np.array([0.0, 0.6, 0.8])
    assert drifted(1.2 * up, np.eye(3) * 0.05**2, 1.0, 1e-3)
    assert not drifted(1.2 * up, np.eye(3) * 0.4**2, 1.0, 1e-3)
    assert drifted(2.3 * up, np.eye(3) * 0.4**2, 1.0, 1e-3)
    assert not drifted(2.2 * up, np.eye(3) * 0.4**2, 1.0, 1e-3)
    across = np.diag([0.1, 0.4, 0.4]) ** 2  # read to 0.1 N along x
    assert drifted(np.array([1.4, 0.0, 0.0]), across, 1.0, 1e-3)
    assert not drifted(np.array([0.0, 1.4, 0.0]), across, 1.0, 1e-3)
    assert not drifted(0.99 * up, np.zeros((3, 3)), 1.0, 1e-3)
