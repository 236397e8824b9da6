"""wrench_sim.trajectory and trajectory_goal (no ROS, no pybullet): joint trajectories as
the Jazzy joint_trajectory_controller follows them, the checks a command must pass first,
and how a goal ends."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wrench_sim.trajectory import JUMP_TOLERANCE, JointLimits, trajectory_from_command
from wrench_sim.trajectory_goal import (
    GOAL_TOLERANCE_VIOLATED,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
    Tolerance,
    TrajectoryGoal,
    tolerances,
)

NAMES = ("j1", "j2", "j3")
LIMITS = JointLimits(
    NAMES,
    lower=np.array([-2.0, -1.0, -3.0]),
    upper=np.array([2.0, 1.0, 3.0]),
    velocity=np.array([2.0, 2.0, 1.0]),
)
HOLD = np.array([0.1, -0.2, 0.3])
ZERO = np.zeros(3)
STILL = (HOLD, ZERO)  # measured: at rest at HOLD
AT_REST = [ZERO, ZERO]  # two points' velocities (or accelerations), zero


def minimum_jerk(tau: float) -> float:
    """The rest-to-rest quintic's share of the way at tau = s / T: 10t^3 - 15t^4 + 6t^5."""
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def rest_to_rest(goal, duration, now=0.0, stamp=0.0, measured=STILL):
    """Two points at rest, from where the arm is to ``goal``: one quintic."""
    return trajectory_from_command(
        NAMES, [0.0, duration], [measured[0], goal], LIMITS, stamp, now, measured,
        AT_REST, AT_REST,
    )  # fmt: skip


def test_two_points_at_rest_are_the_minimum_jerk_quintic_in_absolute_time():
    now, duration = 12.5, 2.0
    goal = np.array([1.1, 0.3, -0.7])
    trajectory = rest_to_rest(goal, duration, now)
    assert (trajectory.arrival_time, trajectory.end_time) == (now, now + duration)
    p, v, a = trajectory.sample(now)
    assert_allclose(p, HOLD, atol=1e-15)
    assert_allclose(v, ZERO, atol=1e-15)
    assert_allclose(a, ZERO, atol=1e-15)
    for tau in (0.25, 0.5, 0.8):
        p, v, _ = trajectory.sample(now + tau * duration)
        assert_allclose(p, HOLD + minimum_jerk(tau) * (goal - HOLD), rtol=1e-12, atol=1e-12)
        speed = 30 * tau**2 * (1 - tau) ** 2 * (goal - HOLD) / duration
        assert_allclose(v, speed, rtol=1e-12, atol=1e-12)
    assert minimum_jerk(0.25) == 0.103515625  # the numbers above are not all trivial
    # peak speed mid-way: 15/8 of the mean (sampled, so at most that and within 0.1 %)
    mean = np.abs(goal - HOLD) / duration
    assert np.all(trajectory.peak_speed() <= 1.875 * mean + 1e-12)
    assert_allclose(trajectory.peak_speed(), 1.875 * mean, rtol=1e-3)
    for t in (now + duration, now + duration + 5.0):  # at and after the end: held, at rest
        p, v, a = trajectory.sample(t)
        assert p.tolist() == goal.tolist() and not v.any() and not a.any()


def test_a_positions_only_point_is_reached_linearly_with_a_velocity_step():
    """The controller's linear interpolation: the mean speed from the first sample on
    (what a one-point, positions-only command gives a real arm)."""
    goal = np.array([0.5, -0.2, 0.3])
    trajectory = trajectory_from_command(["j1"], [2.0], [[0.5]], LIMITS, 0.0, 1.0, STILL)
    for t in (1.0, 1.5, 2.9):
        p, v, a = trajectory.sample(t)
        assert_allclose(v, [0.2, 0.0, 0.0], atol=1e-15)  # 0.4 rad in 2 s, at once
        assert_allclose(p, HOLD + (t - 1.0) * np.array([0.2, 0.0, 0.0]), atol=1e-15)
        assert not a.any()
    assert trajectory.sample(3.0)[0].tolist() == goal.tolist()


def test_points_with_velocities_are_joined_by_cubics():
    """Positions and velocities: a cubic per segment, each point's velocity matched."""
    times, q = [1.0, 2.0], [[0.3, -0.2, 0.3], [0.5, -0.2, 0.3]]
    dq = [[0.4, 0.0, 0.0], ZERO]
    trajectory = trajectory_from_command(NAMES, times, q, LIMITS, 0.0, 0.0, STILL, dq)
    for t, point, speed in zip(times, q, dq, strict=True):
        p, v, _ = trajectory.sample(t - 1e-9)
        assert_allclose(p, point, atol=1e-8)
        assert_allclose(v, speed, atol=1e-7)
    # the cubic from rest at 0.1 to 0.3 at 0.4 rad/s in 1 s: c2 = 0.2, c3 = 0.0 -> mid 0.15
    assert trajectory.sample(0.5)[0][0] == pytest.approx(0.15, abs=1e-12)
    assert trajectory.sample(0.5)[2][0] == pytest.approx(0.4, abs=1e-12)  # 2 c2 + 6 c3 s


def test_a_trajectory_stamped_ahead_moves_the_arm_at_once():
    """Stamped 3 s ahead with its first point 1 s after the stamp: the controller runs from
    the state at arrival to that point over the 4 s, starting now (a real arm creeps)."""
    goal = np.array([0.5, -0.2, 0.3])
    trajectory = trajectory_from_command(
        NAMES, [1.0, 2.0], [goal, goal], LIMITS, 13.0, 10.0, STILL, AT_REST, AT_REST
    )
    assert trajectory.arrival_time == 10.0 and trajectory.end_time == 15.0
    p, v, _ = trajectory.sample(10.5)
    assert p[0] > HOLD[0] + 1e-4 and v[0] > 0.0  # under way before the stamp
    assert_allclose(trajectory.sample(14.0)[0], goal, atol=1e-12)  # at the first point's time


def test_a_trajectory_whose_first_point_is_where_the_arm_rests_holds_it_until_then():
    """How a move may be sent ahead: its first point, at rest where the arm rests, at the
    time the move is to start."""
    goal = np.array([0.5, -0.2, 0.3])
    trajectory = trajectory_from_command(
        NAMES, [3.0, 4.0], [HOLD, goal], LIMITS, 0.0, 10.0, STILL, AT_REST, AT_REST
    )
    for t in np.linspace(10.0, 13.0, 31):
        p, v, _ = trajectory.sample(t)
        assert_allclose(p, HOLD, atol=1e-15)
        assert_allclose(v, ZERO, atol=1e-15)
    assert trajectory.sample(13.5)[0][0] == pytest.approx(0.1 + 0.4 * 0.5, abs=1e-12)


def test_a_new_command_replaces_the_running_one_from_the_measured_state():
    first = rest_to_rest(np.array([1.0, 0.5, -0.5]), 2.0)
    now = 0.7
    p, v, _ = first.sample(now)
    assert np.abs(v).min() > 0.05  # really moving
    second = trajectory_from_command(
        NAMES, [2.0], [ZERO], LIMITS, 0.0, now, (p, v), [ZERO], [ZERO]
    )  # cubic from the measured state (no acceleration), then held
    for expected, got in zip((p, v), second.sample(now)[:2], strict=True):
        assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    p, v, _ = second.sample(now + 2.0)
    assert_allclose(p, ZERO, atol=1e-12)
    assert_allclose(v, ZERO, atol=1e-12)


def test_a_subset_of_joints_in_any_order_holds_the_others_where_they_are():
    trajectory = trajectory_from_command(
        ["j3", "j1"], [0.0, 1.0], [[0.3, 0.1], [0.0, 1.0]], LIMITS, 0.0, 0.0, STILL
    )
    assert trajectory.sample(1.0)[0].tolist() == [1.0, -0.2, 0.0]  # j2 holds
    assert trajectory.end_time == 1.0


@pytest.mark.parametrize(
    ("names", "times", "positions", "message"),
    [
        ([], [1.0], [[]], "no joint names"),
        (["j1", "elbow"], [1.0], [[0.0, 0.0]], r"unknown joint names \['elbow'\]"),
        (["j1", "j1"], [1.0], [[0.0, 0.0]], "repeated joint names"),
        (["j1"], [], [], "no points"),
        (["j1"], [1.0, 2.0], [[0.0]], "2 times but 1 rows of positions"),
        (["j1", "j2"], [1.0], [[0.0]], "point 0 has 1 positions for 2 joint names"),
        (["j1"], [float("nan")], [[0.0]], "NaN or inf"),
        (["j1"], [1.0], [[float("inf")]], "NaN or inf"),
        (["j1"], [-0.5], [[0.0]], "must be >= 0 and strictly increasing"),
        (["j1"], [1.0, 1.0], [[0.0], [0.1]], "must be >= 0 and strictly increasing"),
        (["j2"], [1.0], [[1.5]], r"j2 = 1.5000 rad at point 0 is outside its limits \[-1"),
        (["j1"], [0.0, 1.0], [[0.2], [0.5]], "would jump 0.1000 rad on j1 at arrival"),
        (["j3"], [1.0], [[1.5]], "j3 would need more than its velocity limit 1.000 rad/s"),
    ],
)
def test_malformed_or_unreachable_commands_are_refused(names, times, positions, message):
    with pytest.raises(ValueError, match=message):
        trajectory_from_command(names, times, positions, LIMITS, 0.0, 0.0, STILL)


def test_old_stamps_are_refused_or_joined_where_the_trajectory_is_now():
    with pytest.raises(ValueError, match=r"before it arrived at t = 5\.000 s"):
        trajectory_from_command(["j1"], [1.0], [[0.2]], LIMITS, 3.0, 5.0, STILL)
    with pytest.raises(ValueError, match="would jump"):  # half-way through, far away
        trajectory_from_command(["j1"], [0.0, 4.0], [[0.1], [1.1]], LIMITS, 3.0, 5.0, STILL)
    small = JUMP_TOLERANCE / 2  # within the tolerance: joined where it is
    trajectory_from_command(["j1"], [0.0, 4.0], [[0.1], [0.1 + 2 * small]], LIMITS, 3.0, 5.0,
                            STILL)  # fmt: skip


def test_the_velocity_limit_is_the_quintics_peak_not_its_mean():
    rest_to_rest(HOLD + np.array([0.0, 0.0, 1.0]), 1.9)
    with pytest.raises(ValueError, match="velocity limit"):
        rest_to_rest(HOLD + np.array([0.0, 0.0, 1.0]), 1.8)


def test_waypoints_with_velocities_and_accelerations_follow_a_smooth_motion():
    """A smooth motion sampled at 20 Hz from its start with its velocity and acceleration:
    the quintics through the samples are the motion to 1e-5 rad between them (a designed
    excitation's path)."""
    w = np.pi / 2.0  # rad/s: 0.3 (1 - cos w t)^2 / 4, at rest at 0 and at 4 s
    times = np.arange(0, 81) * 0.05
    share = np.array([1.0, 0.5, 0.0])

    def motion(t):
        c, s = np.cos(w * np.asarray(t))[..., None], np.sin(w * np.asarray(t))[..., None]
        q = 0.075 * (1 - c) ** 2 * share
        dq = 0.15 * w * (1 - c) * s * share
        ddq = 0.15 * w**2 * (s**2 + (1 - c) * c) * share
        return q, dq, ddq

    q, dq, ddq = motion(times)
    still = (np.zeros(3), np.zeros(3))
    trajectory = trajectory_from_command(NAMES, times, q, LIMITS, 0.0, 0.0, still, dq, ddq)
    between = np.arange(0.0, 4.0, 0.013)
    sampled = np.array([trajectory.sample(t)[0] for t in between])
    assert_allclose(sampled, motion(between)[0], atol=1e-5)


@pytest.mark.parametrize(
    ("velocities", "message"),
    [
        ([ZERO, [np.nan, 0.0, 0.0]], "NaN or inf in velocities"),
        ([ZERO], "velocities: 1 rows for 2 points"),
        ([ZERO, [0.1, 0.0, 0.0]], "velocities at the last point must be 0"),
    ],
)
def test_malformed_waypoint_velocities_are_refused(velocities, message):
    with pytest.raises(ValueError, match=message):
        trajectory_from_command(
            NAMES, [1.0, 2.0], [[0.1] * 3, [0.2] * 3], LIMITS, 0.0, 0.0, STILL, velocities
        )


def test_a_goal_ends_as_the_controller_judges_its_tolerances():
    """Path tolerance while it runs; goal tolerance (position and speed) from its end, with
    goal_time_tolerance of leeway; 0 takes the default, negative is unchecked."""
    names = ("a", "b")
    default = Tolerance(0.01, 0.02)
    goal_tolerances = tolerances(names, {"b": (-1.0, 0.0)}, default)
    assert goal_tolerances == [default, Tolerance(-1.0, 0.02)]
    path = tolerances(names, {"a": (0.05, 0.0)}, Tolerance())
    goal = TrajectoryGoal(names, 2.0, path, goal_tolerances, 0.5)
    final, desired, zero = np.array([1.0, 1.0]), np.array([0.5, 0.5]), np.zeros(2)
    assert goal.check(1.0, desired, desired + np.array([0.04, 9.0]), zero, final) is None
    code, text = goal.check(1.0, desired, desired + np.array([-0.06, 0.0]), zero, final)
    assert code == PATH_TOLERANCE_VIOLATED
    assert text == "path tolerance: a is -0.06 rad from where it should be (tolerance 0.05)"
    assert goal.check(2.0, desired, final + np.array([0.0, 5.0]), zero, final) == (SUCCESSFUL, "")
    moving = np.array([0.03, 0.0])
    assert goal.check(2.4, desired, final, moving, final) is None  # within the leeway
    code, text = goal.check(2.6, desired, final, moving, final)
    assert code == GOAL_TOLERANCE_VIOLATED
    assert text == ("goal tolerance, 0.600 s after the end: a still moves at +0.03 rad/s "
                    "(tolerance 0.02)")  # fmt: skip
    waiting = TrajectoryGoal(names, 2.0, path, goal_tolerances, 0.0)
    assert waiting.check(100.0, desired, final + np.array([0.02, 0.0]), zero, final) is None
