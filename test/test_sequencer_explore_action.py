"""The Explore action's messages (exploration_sequencer.explore_action): a goal's options
over the parameters, checked as the parameters are; the feedback's progress; the result
from the estimator's answer."""

from __future__ import annotations

import math

import numpy as np

from com_interfaces.action import Explore
from exploration_sequencer.explore_action import feedback_of, goal_options, result_of


def test_a_goal_left_at_its_defaults_keeps_every_parameter():
    assert goal_options(Explore.Goal()) == ({}, [])


def test_a_goals_options_become_the_runs_parameters():
    goal = Explore.Goal(
        target_com_sigma=math.inf, tilt=0.4, raise_tilt=Explore.Goal.YES, information="wrenches"
    )
    options, problems = goal_options(goal)
    assert not problems
    assert options == {
        "target_com_sigma": 0.0,  # inf: the plan as set
        "tilt": 0.4,
        "raise_tilt": True,
        "information": "wrenches",
    }
    faster = Explore.Goal(excitation="motion", motion_period=2.0, motion_acceleration=20.0,
                          motion_cycles=2)  # fmt: skip
    motion = {"motion_period": 2.0, "motion_acceleration": 20.0, "motion_cycles": 2}
    assert goal_options(faster) == ({"excitation": "motion"} | motion, [])


def test_each_bad_option_is_named_with_its_value():
    goal = Explore.Goal(tilt=3.0, dwell=math.nan, fewer_poses=7, information="guess",
                        motion_cycles=21)  # fmt: skip
    _, problems = goal_options(goal)
    assert len(problems) == 5, problems
    text = "; ".join(problems)
    assert "tilt=3.0 refused: must be in [0.01, pi/2) rad" in text
    assert "dwell=nan refused: must be a finite number [0.1, 300] s" in text
    assert "fewer_poses=7 refused: must be PARAMETER (-1), NO (0) or YES (1)" in text
    assert "information='guess' refused: must be one of" in text
    assert "motion_cycles=21 refused: must be in [1, 20]" in text


def test_progress_is_time_done_over_time_done_and_left_and_never_done_before_the_end():
    live = {"mass": "0.1", "com_x": "0.01", "com_y": "0.0", "com_z": "0.1", "sigma_mass": "1e-3"}
    live |= {f"sigma_com_{a}": "5e-4" for a in "xyz"}
    early = feedback_of("tare", 5.0, 35.0, {})
    assert early.progress == 0.125 and early.time_remaining == 35.0
    assert math.isnan(early.sigma_mass) and early.estimate.inertia.m == 0.0
    late = feedback_of("return", 50.0, 0.1, live)
    assert late.progress == np.float32(0.99) and late.time_remaining == np.float32(0.1)
    assert late.estimate.inertia.m == 0.1 and late.estimate.inertia.com.z == 0.1
    np.testing.assert_array_equal(late.sigma_com, [5e-4] * 3)
    unplanned = feedback_of("starting", 0.0, math.inf, {})
    assert unplanned.progress == 0.0 and unplanned.time_remaining == 0.0


def test_the_result_carries_the_estimate_and_its_covariance_unless_cancelled():
    cov = np.diag([1e-6, 4e-8, 4e-8, 9e-8])
    values = {"mass": "0.1", "com_x": "0.01", "com_y": "-0.02", "com_z": "0.1"}
    values["cov"] = ",".join(map(repr, cov.ravel().tolist()))
    ok = result_of("OK", "[OK] ...", None, values, "ft_sensor")
    assert ok.estimate.header.frame_id == "ft_sensor" and ok.estimate.inertia.com.y == -0.02
    np.testing.assert_array_equal(np.reshape(ok.covariance, (4, 4)), cov)
    cancelled = result_of(Explore.Result.CANCELLED, "[CANCELLED] ...", None, values, "")
    assert cancelled.estimate.inertia.m == 0.0 and np.isnan(cancelled.covariance).all()


def test_the_result_carries_the_inertia_and_its_covariance_only_when_published():
    """A run in motion: the inertia and its covariance when the motion told it; when a
    principal moment is within its sigma (only ``inertia_fit`` in the answer), zero and
    NaN, as for a static run."""
    values = {"mass": "0.5", "com_x": "0.0", "com_y": "0.0", "com_z": "0.1"}
    values["cov"] = ",".join(["1e-6"] * 16)
    elements, cov = "2e-4,0.0,0.0,3e-4,0.0,4e-4", ",".join(["1e-10"] * 36)
    published = result_of("OK", "[OK] ...", None, values | {"inertia": elements,
                          "inertia_cov": cov}, "ft_sensor")  # fmt: skip
    assert published.estimate.inertia.ixx == 2e-4 and published.estimate.inertia.izz == 4e-4
    np.testing.assert_array_equal(published.inertia_covariance, [1e-10] * 36)
    withheld = result_of("OK", "[OK] ...", None, values | {"inertia_fit": elements,
                         "inertia_cov": cov}, "ft_sensor")  # fmt: skip
    assert withheld.estimate.inertia.ixx == 0.0 and withheld.estimate.inertia.m == 0.5
    assert np.isnan(withheld.inertia_covariance).all()
