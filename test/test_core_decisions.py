"""com_core.planning.decisions: a run's plan within the arm's reach and its target, the
noise it plans for, the tare cache's reuse and the grasp's load (no ROS)."""

from __future__ import annotations

import json
import math
import shutil
import time
from dataclasses import replace

import numpy as np
import pytest
from conftest import choreography

from com_core.estimation.fits.windows import window_from_mean
from com_core.estimation.runs.tare_cache import TareCache, save_tares
from com_core.planning.decisions import (
    BAG_BYTES_PER_S,
    GRIPPER_HOLDING,
    PlanInfeasible,
    PlannedRun,
    RunSettings,
    bag_bytes,
    bag_room_refusal,
    cached_tare,
    complete_tare_pass,
    estimator_calibration,
    free_room,
    grasp_holds,
    held_mass,
    hysteresis_hides,
    may_hold_object,
    newest_hand_model,
    plan_for_target,
    plan_within_reach,
    planning_noise,
    predicted_run,
    reachable_tilt,
    requested_plan,
    tare_cache_path,
    tare_decision,
    tare_reuse,
)
from com_core.planning.prediction import predict
from com_core.sensing.hysteresis import Hysteresis, edge
from com_core.sensing.noise import ar1_noise
from com_core.sensing.wrench_model import STANDARD_GRAVITY

PANDA = choreography("panda")
DEFAULTS = {  # the sequencer's parameter defaults
    "tilt": math.pi / 6,
    "tilt_axes": ["y", "x"],
    "both_directions": True,
    "dwell": 0.9,
    "tare_dwell": 5.0,
    "settle": 0.3,
    "speed": 1.35,
    "max_tilt": math.pi / 6,
    "raise_tilt": False,
    "target_com_sigma": 0.0,
    "fewer_poses": False,
    "max_object_time": 20.0,
    "sigma_f": 0.1,
    "sigma_tau": 0.005,
    "correlation_time": 0.005,
    "rate": 1000.0,
    "mass_guess": 0.1,
    "com_guess": [0.0],
    "bias_dwell": 3.0,
    "hand_id": "not a setting",
}
SETTINGS = RunSettings.from_parameters(DEFAULTS.__getitem__)
NOISE = ar1_noise([0.1] * 3 + [0.005] * 3, 0.005, 1000.0)
COV = np.eye(6) * 1e-6  # N^2, N^2 m^2: a window's mean to 1 mN


def settings(**changes) -> RunSettings:
    return replace(SETTINGS, **changes)


def window(pose: str, fz: float):
    return window_from_mean(pose, [0.0, 0.0, fz, 0.0, 0.0, 0.0], COV, 5000)


def entry(age: float = 10.0, poses=("home",), fz: float = -5.0, noise=None) -> TareCache:
    return TareCache(
        "panda_hand|sig", time.time() - age, {p: window(p, fz) for p in poses}, noise=noise
    )


# --- settings --------------------------------------------------------------------------


def test_settings_take_their_parameters_and_lists_become_tuples():
    assert SETTINGS.tilt_axes == ("y", "x") and SETTINGS.com_guess == (0.0,)
    assert SETTINGS.dwell == 0.9 and SETTINGS.max_object_time == 20.0
    assert not hasattr(SETTINGS, "hand_id")


def test_the_tare_cache_is_beside_the_bags_unless_named(tmp_path):
    assert tare_cache_path("", str(tmp_path)) == tmp_path / "tare_cache.json"
    assert tare_cache_path("/x/cache.json", str(tmp_path)).as_posix() == "/x/cache.json"


def test_the_calibration_is_the_estimators_only_when_it_states_one():
    calibration = estimator_calibration(0.01, [100.0, 5.0])
    assert calibration is not None
    assert estimator_calibration(0.0, [100.0, 5.0]) is None
    assert estimator_calibration(0.01, [100.0]) is None


# --- the noise planned for -------------------------------------------------------------


def test_the_noise_planned_for_is_the_tare_passes_else_the_assumed_one():
    learnt = ar1_noise([0.3] * 3 + [0.02] * 3, 0.0, 1000.0)
    noise, source = planning_noise(entry(noise=learnt), SETTINGS)
    assert noise is learnt and source == "learnt by the cached tare pass"
    for cache in (None, entry()):
        noise, source = planning_noise(cache, settings(sigma_f=0.2, sigma_tau=0.01))
        assert source == "assumed from sigma_f, sigma_tau and correlation_time"
        np.testing.assert_allclose(np.sqrt(noise.variance), [0.2] * 3 + [0.01] * 3)
        # a first-order low-pass of 5 ms sampled at 1 kHz: phi = exp(-1 / 5)
        assert noise.ar == ((pytest.approx(math.exp(-0.2)),),) * 6


def test_an_unreadable_cache_has_no_hand_model(tmp_path):
    broken = tmp_path / "tare_cache.json"
    broken.write_text("{not json")
    assert newest_hand_model(broken, "panda_hand") is None
    assert newest_hand_model(tmp_path / "none.json", "panda_hand") is None


# --- the plan --------------------------------------------------------------------------


def test_the_requested_plan_guesses_the_com_at_the_grasp_centre_and_gravity_from_the_arm():
    plan = requested_plan(SETTINGS, PANDA, NOISE)
    assert plan.tilt == pytest.approx(math.pi / 6) and plan.axes == ("y", "x")
    assert plan.dwell == 0.9 and plan.tare_dwell == 5.0 and plan.bias_dwell == 3.0
    np.testing.assert_allclose(plan.com_guess, PANDA.pivot)
    gravity = PANDA.robot.gravity_in_sensor(PANDA.home_positions())
    np.testing.assert_allclose(plan.gravity_home, gravity / np.linalg.norm(gravity))
    assert np.linalg.norm(plan.gravity_home) == pytest.approx(1.0)
    assert plan.noise is NOISE and plan.sensor.rate_hz == 1000.0
    guessed = requested_plan(settings(com_guess=(0.01, -0.02, 0.05)), PANDA, NOISE)
    assert guessed.com_guess == (0.01, -0.02, 0.05)


def test_a_reachable_plan_keeps_its_tilt_and_moves_as_long_as_its_longest_move():
    planned = plan_within_reach(SETTINGS, PANDA, NOISE)
    assert planned.refusals == () and planned.changes == ()
    assert planned.plan.tilt == pytest.approx(math.pi / 6)
    names = [name for name, _ in planned.poses]
    assert names == ["home", "tilt_y+", "tilt_y-", "tilt_x-", "tilt_x+"]
    moves = [
        PANDA.motion_time(a, b, 1.35)
        for (_, a), (_, b) in zip(planned.poses, planned.poses[1:], strict=False)
    ]
    assert planned.plan.move_time == pytest.approx(max(moves))
    slower = plan_within_reach(settings(speed=0.5), PANDA, NOISE)
    assert slower.plan.move_time > planned.plan.move_time


def test_a_tilt_above_max_tilt_is_lowered_and_said():
    planned = plan_within_reach(settings(tilt=0.5, max_tilt=0.3), PANDA, NOISE)
    assert planned.plan.tilt == pytest.approx(0.3)
    assert planned.changes == ("tilt 0.5 -> 0.3 rad (the plan's tilt exceeds max_tilt)",)


def test_a_tilt_beyond_reach_is_lowered_to_the_largest_the_arm_reaches():
    planned = plan_within_reach(settings(tilt=1.5, max_tilt=1.55), PANDA, NOISE)
    assert planned.refusals, "1.5 rad is beyond the Panda's reach"
    largest = planned.refusals[-1].largest
    assert 0.0 < largest < 1.5 and planned.plan.tilt == pytest.approx(largest)
    assert len(planned.changes) == 1
    assert planned.changes[0].startswith(f"tilt 1.500 -> {largest:.3f} rad (the largest")
    assert reachable_tilt(planned.plan, PANDA, []) == planned.plan.tilt


def test_the_estimators_drift_rate_and_calibration_enter_the_plan():
    calibration = estimator_calibration(0.01, [100.0, 5.0])
    planned = plan_within_reach(SETTINGS, PANDA, NOISE, calibration, (1e-3, 1e-4))
    assert planned.plan.bias_drift_rate == (1e-3, 1e-4)
    assert planned.plan.calibration is calibration
    default = plan_within_reach(SETTINGS, PANDA, NOISE, None, ())
    assert default.plan.bias_drift_rate != (1e-3, 1e-4) and default.plan.calibration is None
    assert default.plan.hysteresis is None


def test_the_estimators_hysteresis_enters_the_plan_and_widens_its_prediction():
    """The estimator's stated band (the xArm F/T's): the kinematic prediction weighs what
    its gain leaves, as the fit does (``FitSetup.with_hysteresis``)."""
    from com_core.estimation.runs.settings import hysteresis_of

    hysteresis = hysteresis_of({"hysteresis": [3.75, 3.75, 2.0, 0.04, 0.04, 0.04],
                                "full_scale": [150.0, 4.0]})  # fmt: skip
    planned = plan_within_reach(settings(mass_guess=2.0), PANDA, NOISE, None, (), hysteresis)
    assert planned.plan.hysteresis is hysteresis
    told = predict(planned.plan, "ml", "kinematics")
    untold = predict(replace(planned.plan, hysteresis=None), "ml", "kinematics")
    assert told.sigma_mass > 3 * untold.sigma_mass, (told.sigma_mass, untold.sigma_mass)  # ~6.8


def test_without_a_target_the_plan_is_the_reachable_one():
    planned = plan_within_reach(SETTINGS, PANDA, NOISE)
    assert plan_for_target(planned, SETTINGS, PANDA, "ml", "wrenches") is planned


def test_a_target_sets_the_dwell_that_meets_it_and_says_so():
    target = settings(target_com_sigma=1e-3)
    planned = plan_within_reach(target, PANDA, NOISE)
    assert max(predict(planned.plan, "ml", "wrenches").sigma_com) > 1.4e-3  # not met
    met = plan_for_target(planned, target, PANDA, "ml", "wrenches")
    assert 1.5 < met.plan.dwell < 5.0
    assert max(predict(met.plan, "ml", "wrenches").sigma_com) == pytest.approx(1e-3, rel=1e-3)
    assert len(met.changes) == 1 and met.changes[0].startswith("dwell 0.9 -> ")
    assert [n for n, _ in met.poses] == [n for n, _ in planned.poses]
    assert met.plan.move_time == planned.plan.move_time  # the same poses


def test_a_target_out_of_reach_is_refused_with_the_reason():
    target = settings(target_com_sigma=1e-6, max_object_time=5.0)
    planned = plan_within_reach(target, PANDA, NOISE)
    with pytest.raises(PlanInfeasible, match=r"^target COM sigma cannot be met: "):
        plan_for_target(planned, target, PANDA, "ml", "wrenches")


def test_planned_runs_keep_the_refusals_and_earlier_changes():
    target = settings(tilt=1.5, max_tilt=1.55, target_com_sigma=1e-3)
    planned = plan_within_reach(target, PANDA, NOISE)
    met = plan_for_target(planned, target, PANDA, "ml", "wrenches")
    assert isinstance(met, PlannedRun) and planned.refusals and planned.changes
    assert met.refusals == planned.refusals
    assert met.changes[: len(planned.changes)] == planned.changes


# --- the tare cache --------------------------------------------------------------------


def test_the_cached_entry_is_the_plans_or_the_hands_newest_model(tmp_path):
    path = tmp_path / "tare_cache.json"
    joints = {"home": {"panda_joint1": 0.0}}
    save_tares(path, "panda_hand|plan a", {"home": window("home", -5.0)}, joints)
    save_tares(path, "panda_hand|plan b", {"home": window("home", -6.0)})
    by_plan, problem = cached_tare(path, "panda_hand", "panda_hand|plan b", hand_model=False)
    assert problem == "" and by_plan.windows["home"].force[2] == -6.0
    model, _ = cached_tare(path, "panda_hand", "panda_hand|plan b", hand_model=True)
    assert model.signature == "panda_hand|plan a"  # the newest with joints
    assert cached_tare(path, "panda_hand", "panda_hand|plan c", False) == (None, "")
    path.write_text(json.dumps({"entries": {"x": {}}}))
    none, problem = cached_tare(path, "panda_hand", "x", False)
    assert none is None and problem


def test_a_cached_entry_is_checked_only_when_the_estimator_reads_the_same_file(tmp_path):
    path = tmp_path / "tare_cache.json"
    poses = ["home", "tilt_x+"]
    full = entry(poses=poses)
    shared = tare_decision(
        full, path, str(tmp_path / "." / "tare_cache.json"), 3600.0, poses, False
    )
    assert shared.shared and shared.check and not shared.unshared
    other = tare_decision(full, path, str(tmp_path / "other.json"), 3600.0, poses, False)
    assert not other.shared and not other.check and other.unshared
    none = tare_decision(full, path, "", 3600.0, poses, False)
    assert not none.shared and none.unshared
    assert not tare_decision(None, path, str(path), 3600.0, poses, False).unshared
    assert not tare_decision(None, path, str(path), 3600.0, poses, False).check


def test_a_cached_entry_serves_while_young_and_with_the_wrenches_alone_complete(tmp_path):
    path = tmp_path / "tare_cache.json"
    poses = ["home", "tilt_x+"]
    assert not tare_decision(
        entry(age=4000.0, poses=poses), path, str(path), 3600.0, poses, False
    ).check
    partial = entry(poses=["home"])
    assert not tare_decision(partial, path, str(path), 3600.0, poses, False).check
    assert tare_decision(partial, path, str(path), 3600.0, poses, True).check  # a hand model
    assert not tare_decision(entry(age=4000.0), path, str(path), 3600.0, poses, True).check


def test_a_hand_model_serves_with_any_fresh_window_and_weighs_against_it():
    fresh = window("home_check", -5.5)  # drifted: the bias is fitted with the object
    reuse = tare_reuse(entry(), "home", fresh, hand_model=True)
    assert reuse.reuse and reuse.home is fresh
    assert reuse.verdict == "its hand model; the bias is fitted with the object"
    missing = tare_reuse(entry(), "home", None, hand_model=True)
    assert not missing.reuse and missing.verdict == "drift chi2 inf, 6 dof, p 0"


def test_with_the_wrenches_alone_the_fresh_window_must_agree_with_the_cached_one():
    cached = entry(fz=-5.0)
    # covariance of the difference 2e-6 N^2 on each axis: 2 mN along z gives chi2 2
    agree = tare_reuse(cached, "home", window("home_check", -5.002), hand_model=False)
    assert agree.reuse and agree.home is cached.windows["home"]
    assert agree.verdict.startswith("drift chi2 2.0, 6 dof, p 0.9")
    # 10 mN: chi2 50, p ~ 5e-9 < 1e-3
    drifted = tare_reuse(cached, "home", window("home_check", -5.010), hand_model=False)
    assert not drifted.reuse and drifted.verdict.startswith("drift chi2 50.0, 6 dof, p 4.")
    assert not tare_reuse(cached, "home", None, hand_model=False).reuse


def test_only_a_complete_tare_pass_is_cached():
    assert complete_tare_pass({"home": 1, "tilt_x+": 2}, ["home", "tilt_x+"])
    assert not complete_tare_pass({"home": 1}, ["home", "tilt_x+"])


# --- the grasp -------------------------------------------------------------------------


def test_the_held_mass_is_the_force_beyond_the_tare_along_gravity_in_its_window():
    tare = np.array([0.0, 3.0, -4.0])  # N; gravity along (0, 0.6, -0.8)
    unit = tare / 5.0
    extra = 0.2 * STANDARD_GRAVITY * unit + np.array([0.8, 0.0, 0.0])  # across: no weight
    stamps = np.arange(0, 10, dtype=np.int64) * 100
    forces = np.tile(np.concatenate([tare + extra, [0.0, 0.0, 0.0]]), (10, 1))
    forces[:3, :3] = 1e3  # before the window
    forces[-1, :3] = -1e3  # at its end: not in it
    assert held_mass(stamps, forces, 300, 900, tare) == pytest.approx(0.2, abs=1e-12)
    assert held_mass(stamps, forces, 1000, 2000, tare) is None
    assert held_mass(stamps, forces, 300, 900, np.zeros(3)) is None  # a tare quantised to 0


def test_the_grasp_holds_from_min_load():
    assert grasp_holds(0.005, 0.005) and grasp_holds(0.2, 0.005)
    assert not grasp_holds(0.0049, 0.005)
    assert not grasp_holds(-0.01, 0.0)
    assert not grasp_holds(float("nan"), 0.005)


def test_the_grasp_check_allows_what_the_sensors_hysteresis_can_hide():
    """The xArm sensor's band (3.75 N in fz) bounds its state at b = 1.362 N: at the tare
    and again after the grasp's contact, so the lift's reading moves by up to 2 b along
    gravity (278 g), and across gravity by none; a tilted hand sums the axes it spans."""
    xarm = Hysteresis.stated((3.75, 3.75, 2.0, 0.04, 0.04, 0.04), 150.0, 4.0)
    b = edge(xarm.band)
    down = hysteresis_hides(xarm, (0.0, 0.0, -7.0))
    assert down == pytest.approx(2 * b[2] / STANDARD_GRAVITY, rel=1e-12)
    assert down == pytest.approx(0.2778, abs=1e-4)
    tilted = hysteresis_hides(xarm, (0.0, 3.0, -4.0))  # u = (0, 0.6, -0.8)
    assert tilted == pytest.approx(2 * (0.6 * b[1] + 0.8 * b[2]) / STANDARD_GRAVITY)
    assert hysteresis_hides(None, (0.0, 0.0, -7.0)) == 0.0
    assert hysteresis_hides(xarm, np.zeros(3)) == 0.0
    # the 0.1 kg box read -11.6 g after a contact that moved fz by a newton: held; an
    # empty hand read farther below than the band reaches: not
    assert grasp_holds(-0.0116, 0.005, down) and not grasp_holds(-0.0116, 0.005)
    assert not grasp_holds(0.005 - down - 1e-6, 0.005, down)


def test_fingers_closed_beyond_a_fortieth_of_their_stroke_may_hold_an_object():
    assert GRIPPER_HOLDING == 0.025
    assert may_hold_object(0.03) and not may_hold_object(0.025) and not may_hold_object(0.0)


def test_a_target_refused_at_a_small_tilt_says_what_raise_tilt_would_do():
    """The target cannot be met at the tilt set: the refusal adds the planner's answer with
    raise_tilt (a plan to allow, or its own refusal)."""
    small = settings(tilt=0.05, target_com_sigma=1e-3, max_object_time=60.0)
    with pytest.raises(PlanInfeasible, match=r"with raise_tilt it plans tilt 0\.5") as refused:
        predicted_run(plan_within_reach(small, PANDA, NOISE), small, PANDA, "ml", "wrenches")
    assert str(refused.value).startswith("target COM sigma cannot be met: ")
    assert "allow raise_tilt" in str(refused.value)


def test_a_bag_dir_without_room_for_the_run_is_refused_with_the_room_it_has(tmp_path):
    planned = 60.0
    assert bag_bytes(planned) == round(1.5 * (planned * BAG_BYTES_PER_S + 2_000_000))
    free = shutil.disk_usage(tmp_path).free
    assert bag_room_refusal(tmp_path / "not" / "yet", planned) == ""  # its parent's room
    too_long = 2 * free / BAG_BYTES_PER_S  # s: a run whose bag cannot fit
    refusal = bag_room_refusal(tmp_path, too_long)
    assert refusal.startswith(f"bag_dir {tmp_path}: ") and "MB free" in refusal
    assert free_room(tmp_path / "missing").endswith(f"MB free on {tmp_path}")
