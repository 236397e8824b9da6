"""wrench_sim.trajectory (no ROS, no pybullet): the quintic joint trajectories the sim's
arm follows, and the checks a command must pass first."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wrench_sim.trajectory import JointLimits, QuinticTrajectory, trajectory_from_command

NAMES = ("j1", "j2", "j3")
LIMITS = JointLimits(
    NAMES,
    lower=np.array([-2.0, -1.0, -3.0]),
    upper=np.array([2.0, 1.0, 3.0]),
    velocity=np.array([2.0, 2.0, 1.0]),
)
HOLD = np.array([0.1, -0.2, 0.3])
ZERO = np.zeros(3)
REST = (HOLD, ZERO, ZERO)


def minimum_jerk(tau: float) -> float:
    """The rest-to-rest quintic's share of the way at tau = s / T: 10t^3 - 15t^4 + 6t^5."""
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def test_a_rest_to_rest_segment_is_the_minimum_jerk_quintic_in_absolute_time():
    t0, duration = 12.5, 2.0
    goal = np.array([1.1, 0.3, -0.7])
    trajectory = trajectory_from_command(NAMES, [duration], [goal], LIMITS, t0, REST)
    assert (trajectory.start_time, trajectory.end_time) == (t0, t0 + duration)
    p, v, a = trajectory.sample(t0)  # starts at the set point, at rest, at t0
    assert_allclose(p, HOLD, atol=1e-15)
    assert_allclose(v, ZERO, atol=1e-15)
    assert_allclose(a, ZERO, atol=1e-15)
    for tau in (0.25, 0.5, 0.8):
        p, v, _ = trajectory.sample(t0 + tau * duration)
        assert_allclose(p, HOLD + minimum_jerk(tau) * (goal - HOLD), rtol=1e-12, atol=1e-12)
        speed = 30 * tau**2 * (1 - tau) ** 2 * (goal - HOLD) / duration
        assert_allclose(v, speed, rtol=1e-12, atol=1e-12)
    assert minimum_jerk(0.25) == 0.103515625  # the numbers above are not all trivial
    # peak speed mid-way: 15/8 of the mean (sampled, so at most that and within 0.1 %)
    mean = np.abs(goal - HOLD) / duration
    assert np.all(trajectory.peak_speed() <= 1.875 * mean + 1e-12)
    assert_allclose(trajectory.peak_speed(), 1.875 * mean, rtol=1e-3)
    # at and after the end: the goal, at rest
    for t in (t0 + duration, t0 + duration + 5.0):
        p, v, a = trajectory.sample(t)
        assert p.tolist() == goal.tolist() and not v.any() and not a.any()


def test_every_waypoint_is_reached_at_its_time_and_at_rest():
    times = [0.5, 1.5, 2.5]
    points = [[0.5, 0.0, 0.3], [-0.5, 0.5, 0.3], [0.0, 0.0, 0.0]]
    trajectory = trajectory_from_command(NAMES, times, points, LIMITS, 3.0, REST)
    for t, point in zip(times, points, strict=True):
        p, v, _ = trajectory.sample(3.0 + t - 1e-9)  # the end of the segment into it
        assert_allclose(p, point, atol=1e-7)
        assert_allclose(v, ZERO, atol=1e-6)
    # j3 stays at 0.3 through the first two waypoints: no overshoot between equal points
    for t in np.linspace(3.0 + 0.5, 3.0 + 1.5, 11):
        assert trajectory.sample(t)[0][2] == pytest.approx(0.3, abs=1e-12)


def test_a_command_that_replaces_a_running_one_continues_from_its_state():
    """The first segment starts from the current set point, velocity and acceleration:
    replacing a trajectory mid-motion neither jumps nor kinks."""
    first = trajectory_from_command(NAMES, [2.0], [[1.0, 0.5, -0.5]], LIMITS, 0.0, REST)
    now = 0.7
    state = first.sample(now)
    assert np.abs(state[1]).min() > 0.05  # really moving
    second = trajectory_from_command(NAMES, [2.0], [[0.0, 0.0, 0.0]], LIMITS, now, state)
    for expected, got in zip(state, second.sample(now), strict=True):
        assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    p, v, _ = second.sample(now + 2.0)
    assert_allclose(p, ZERO, atol=1e-12)
    assert_allclose(v, ZERO, atol=1e-12)


def test_a_subset_of_joints_in_any_order_and_a_point_at_time_zero():
    trajectory = trajectory_from_command(
        ["j3", "j1"], [0.0, 1.0], [[0.3, 0.1], [0.0, 1.0]], LIMITS, 0.0, REST
    )
    p, _, _ = trajectory.sample(1.0)
    assert p.tolist() == [1.0, -0.2, 0.0]  # j2 holds its set point
    assert trajectory.end_time == 1.0  # the time-0 point (the set point) is dropped
    with pytest.raises(ValueError, match="time 0 must equal the current position"):
        trajectory_from_command(["j1"], [0.0, 1.0], [[0.2], [0.5]], LIMITS, 0.0, REST)
    only_now = trajectory_from_command(["j1"], [0.0], [[0.1]], LIMITS, 4.0, REST)
    assert only_now.end_time == pytest.approx(4.001)
    assert only_now.sample(4.001)[0].tolist() == HOLD.tolist()


@pytest.mark.parametrize(
    ("names", "times", "positions", "message"),
    [
        ([], [1.0], [[]], "no joint names"),
        (["j1", "elbow"], [1.0], [[0.0, 0.0]], r"unknown joint names \['elbow'\]"),
        (["j1", "j1"], [1.0], [[0.0, 0.0]], "repeated joint names"),
        (["j1"], [], [], "no points"),
        (["j1"], [1.0, 2.0], [[0.0]], "2 times but 1 position rows"),
        (["j1", "j2"], [1.0], [[0.0]], "point 0 has 1 positions for 2 joint names"),
        (["j1"], [float("nan")], [[0.0]], "NaN or inf"),
        (["j1"], [1.0], [[float("inf")]], "NaN or inf"),
        (["j1"], [-0.5], [[0.0]], "must be >= 0 and strictly increasing"),
        (["j1"], [1.0, 1.0], [[0.0], [0.1]], "must be >= 0 and strictly increasing"),
        (["j2"], [1.0], [[1.5]], r"j2 = 1.5000 rad at point 0 is outside its limits \[-1"),
        (["j3"], [1.0], [[2.0]], "j3 would need more than its velocity limit 1.000 rad/s"),
    ],
)
def test_malformed_or_unreachable_commands_are_refused(names, times, positions, message):
    with pytest.raises(ValueError, match=message):
        trajectory_from_command(names, times, positions, LIMITS, 0.0, REST)


def test_the_velocity_limit_is_the_quintics_peak_not_its_mean():
    """j3 (1 rad/s) moving 1 rad: 1.875 s is the least time (peak 15/8 of the mean)."""
    trajectory_from_command(["j3"], [1.9], [[HOLD[2] + 1.0]], LIMITS, 0.0, REST)
    with pytest.raises(ValueError, match="velocity limit"):
        trajectory_from_command(["j3"], [1.8], [[HOLD[2] + 1.0]], LIMITS, 0.0, REST)


def test_a_trajectory_built_directly_samples_its_segments():
    trajectory = QuinticTrajectory(
        1.0, REST, np.array([1.0, 3.0]), np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    )
    assert (trajectory.start_time, trajectory.end_time) == (1.0, 4.0)
    assert trajectory.sample(2.0)[0].tolist() == pytest.approx([1.0, 0.0, 0.0])
    p = trajectory.sample(3.0)[0]  # half-way through the second segment
    assert p.tolist() == pytest.approx([1.0, 0.5, 0.0], abs=1e-12)


def test_waypoints_with_velocities_and_accelerations_follow_a_smooth_motion():
    """A smooth motion sampled at 20 Hz with its velocity and acceleration: the quintics
    through the samples are the motion to 1e-5 rad between them (a designed excitation's
    path)."""
    rest = (np.zeros(3), np.zeros(3), np.zeros(3))
    w = np.pi / 2.0  # rad/s: 0.3 (1 - cos w t)^2 / 4, at rest at 0 and at 4 s
    times = np.arange(1, 81) * 0.05
    share = np.array([1.0, 0.5, 0.0])

    def motion(t):
        c, s = np.cos(w * np.asarray(t))[..., None], np.sin(w * np.asarray(t))[..., None]
        q = 0.075 * (1 - c) ** 2 * share
        dq = 0.15 * w * (1 - c) * s * share
        ddq = 0.15 * w**2 * (s**2 + (1 - c) * c) * share
        return q, dq, ddq

    q, dq, ddq = motion(times)
    trajectory = trajectory_from_command(LIMITS.names, times, q, LIMITS, 0.0, rest, dq, ddq)
    between = np.arange(0.0, 4.0, 0.013)
    sampled = np.array([trajectory.sample(t)[0] for t in between])
    assert_allclose(sampled, motion(between)[0], atol=1e-5)


@pytest.mark.parametrize(
    ("velocities", "message"),
    [
        ([[0.0] * 3, [np.nan, 0.0, 0.0]], "NaN or inf in velocities"),
        ([[0.0] * 3], r"velocities: \(1, 3\) values for \(2, 3\) positions"),
        ([[0.0] * 3, [0.1, 0.0, 0.0]], "velocities at the last point must be 0"),
    ],
)
def test_malformed_waypoint_velocities_are_refused(velocities, message):
    rest = (np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match=message):
        trajectory_from_command(
            LIMITS.names, [1.0, 2.0], [[0.1] * 3, [0.2] * 3], LIMITS, 0.0, rest, velocities
        )
