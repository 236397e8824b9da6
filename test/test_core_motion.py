"""com_core.estimation.fits.motion: the load's 10 parameters from one wrist motion, with the
delay between wrench and joint stamps estimated and the sensor's coloured noise weighed
(no ROS, no simulator: wrenches from the regressor itself)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PANDA
from test_core_noise import ar1

from com_core.estimation.fits.motion import MAX_DELAY, fit_motion, joint_motion, regressors_along
from com_core.planning.excitation import design_excitation
from com_core.robot.config import urdf_file
from com_core.robot.dynamics import inertial_parameters
from com_core.robot.model import RobotModel
from com_core.sensing.hysteresis import edge
from com_core.sensing.noise import ar1_noise
from com_core.sensing.sensor_profiles import PROFILES

SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # N, N m: the realistic sensor's
CORRELATION = 0.005  # s: its low-pass
RATE = 1000.0  # Hz
# a 0.5 kg box held 8 cm below the sensor and 1 cm off its axis, with the hand's 0.7 kg
LOAD = inertial_parameters(0.5, [0.01, 0.0, 0.08], np.diag([0.4e-3, 0.37e-3, 0.2e-3]))
LOAD = LOAD + inertial_parameters(0.7, [0.0, 0.0, 0.03], np.diag([2.0e-3, 1.5e-3, 1.0e-3]))
BIAS = np.array([0.3, -0.2, 0.1, 0.01, -0.015, 0.005])


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel(urdf_file(PANDA).read_text(), PANDA.sensor_frame)


@pytest.fixture(scope="module")
def recording(panda):
    """A designed 3 s excitation: joint positions at 1 kHz (with 0.4 s at rest around
    it), and the load's wrench at the sensor's stamps, 6.5 ms late: (joint times,
    positions, wrench times, noise-free wrenches)."""
    home = np.zeros(len(panda.joint_names))
    home[:7] = PANDA.home_joints
    excitation = design_excitation(panda, home, PANDA.arm_joints[-3:], period=3.0,
                                   iterations=40, seed=0)  # fmt: skip
    times = np.arange(-0.4, 3.4, 1 / RATE)
    positions = excitation.at(np.clip(times, 0.0, 3.0))[0]
    wrench_times = times[(times > -0.2) & (times < 3.2)]
    late = wrench_times - 0.0065
    w = regressors_along(panda, *excitation_at(excitation, late)) @ LOAD + BIAS
    return times, positions, wrench_times, w


def excitation_at(excitation, t):
    """The excitation's (q, dq, ddq) at ``t`` (s), at rest at home outside [0, period]."""
    q, dq, ddq = excitation.at(np.clip(t, 0.0, excitation.period))
    moving = ((t >= 0.0) & (t <= excitation.period))[:, None]
    return q, dq * moving, ddq * moving


@pytest.mark.parametrize(("rate", "within"), [(1000.0, 5e-5), (100.0, 2e-3)])
def test_the_joint_motion_is_a_polynomials_exactly_and_a_sines_closely(rate, within):
    """Zero phase: a quartic's q, dq, ddq exactly anywhere between samples; a 1 Hz sine's
    to ``within`` of each amplitude, without a delay (measured: 2e-5 at 1 kHz; 1.2e-3 in
    the acceleration from 100 Hz joint states, 11 samples a window)."""
    t = np.arange(0.0, 2.0, 1 / rate)
    at = np.linspace(0.3, 1.7, 57)
    c = np.array([0.1, -0.4, 0.3, 0.2, -0.05])
    x = sum(c[p] * t**p for p in range(5))[:, None]
    q, dq, ddq = joint_motion(t, x, at)
    np.testing.assert_allclose(q[:, 0], sum(c[p] * at**p for p in range(5)), atol=1e-10)
    np.testing.assert_allclose(dq[:, 0], sum(p * c[p] * at ** (p - 1) for p in range(1, 5)),
                               atol=1e-8)  # fmt: skip
    expected = sum(p * (p - 1) * c[p] * at ** (p - 2) for p in range(2, 5))
    np.testing.assert_allclose(ddq[:, 0], expected, atol=1e-6)
    w = 2 * np.pi
    q, dq, ddq = joint_motion(t, np.sin(w * t)[:, None], at)
    np.testing.assert_allclose(q[:, 0], np.sin(w * at), atol=within)
    np.testing.assert_allclose(dq[:, 0], w * np.cos(w * at), atol=within * w)
    np.testing.assert_allclose(ddq[:, 0], -w * w * np.sin(w * at), atol=within * w * w)


def test_joint_states_that_do_not_cover_the_wrenches_are_refused():
    t = np.arange(0.0, 1.0, 1e-3)
    with pytest.raises(ValueError, match="must cover"):
        joint_motion(t, t[:, None], [0.99])
    with pytest.raises(ValueError, match="evenly spaced"):
        joint_motion(np.delete(t, np.s_[400:420]), np.delete(t, np.s_[400:420])[:, None], [0.5])


def test_without_noise_the_fit_is_the_load_and_finds_the_delay(panda, recording):
    times, positions, wrench_times, w = recording
    fit = fit_motion(panda, times, positions, wrench_times, w, ar1_noise(SIGMA, 0.0, RATE))
    assert fit.delay == pytest.approx(0.0065, abs=2e-5)
    np.testing.assert_allclose(fit.pi, LOAD, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(fit.bias, BIAS, atol=1e-5)
    assert fit.chi2 / fit.dof < 1e-3 and not fit.constrained


def test_a_hysteresis_offset_fading_along_the_motion_is_fitted_beside_the_bias(panda, recording):
    """Where a motion starts, a strain-gauge sensor's hysteresis state is anywhere in its
    band (after the grasp's contact, say), and as the load travels it fades toward the
    loops' (``Hysteresis.path_memory``): an offset the bias cannot take. The xArm F/T
    sensor's at 0.8 of its band's edge, no noise: told the hysteresis, the fit takes it
    off beside the bias (the mass 0.6 g off, within its sigma; what is left is its memory
    read from the readings, not the loads); not told, the mass is 3.6 g off, 4.5 sigma,
    and the bias 1.8 N."""
    times, positions, wrench_times, w = recording
    hysteresis = PROFILES["xarm_ft"].stated_hysteresis()
    start = 0.8 * edge(hysteresis.band) * np.array([1, -1, 1, -1, 1, -1])
    read = w + start * hysteresis.path_memory(w)
    noise = ar1_noise(SIGMA, CORRELATION, RATE)
    told = fit_motion(panda, times, positions, wrench_times, read, noise, hysteresis=hysteresis)
    untold = fit_motion(panda, times, positions, wrench_times, read, noise)
    z = (told.pi - LOAD) / np.sqrt(np.diag(told.cov))
    assert np.abs(z[:4]).max() < 1.5, z  # measured 1.13 (the COM's z)
    assert np.abs(told.bias - BIAS)[:3].max() < 0.1  # N: measured 0.05, 1.8 not told
    assert abs(untold.pi[0] - LOAD[0]) > 5 * abs(told.pi[0] - LOAD[0])
    assert (untold.pi[0] - LOAD[0]) / np.sqrt(untold.cov[0, 0]) < -4.0


def test_with_coloured_noise_the_error_bars_hold(panda, recording):
    """Six draws of the realistic sensor's coloured noise (seeded): each parameter's
    error over its sigma has an rms near 1 and none is beyond 4; chi^2/dof is near 1 and
    the delay within 0.3 ms. A fit that weighed the samples as white would claim sigmas
    about 3.3 times too small (the low-pass's long-run factor is 11)."""
    times, positions, wrench_times, w = recording
    noise = ar1_noise(SIGMA, CORRELATION, RATE)
    white = ar1_noise(SIGMA, 0.0, RATE)
    rng = np.random.default_rng(11)
    z, z_white = [], []
    for draw in range(6):
        noisy = w + ar1(len(w), CORRELATION, rng, SIGMA)
        fit = fit_motion(panda, times, positions, wrench_times, noisy, noise)
        assert abs(fit.delay - 0.0065) < 3e-4 and 0.9 < fit.chi2 / fit.dof < 1.1
        z.append((fit.pi - LOAD) / np.sqrt(np.diag(fit.cov)))
        if draw < 2:
            naive = fit_motion(panda, times, positions, wrench_times, noisy, white)
            z_white.append((naive.pi - LOAD) / np.sqrt(np.diag(naive.cov)))
    z, z_white = np.array(z), np.array(z_white)
    assert np.abs(z).max() < 4.0, z
    assert 0.5 < np.sqrt(np.mean(z**2)) < 1.6
    assert np.sqrt(np.mean(z_white**2)) > 2.0  # white weights: error bars not honest


def test_the_delay_is_searched_within_its_bound(panda, recording):
    times, positions, wrench_times, w = recording
    noise = ar1_noise(SIGMA, 0.0, RATE)
    fit = fit_motion(panda, times, positions, wrench_times + 0.02, w, noise)
    assert fit.delay == pytest.approx(0.0265, abs=3e-5) and MAX_DELAY > 0.0265


def test_noisy_encoders_widen_the_error_bars_to_what_they_do(panda, recording):
    """Encoders with 2e-5 rad of white noise per sample (several times a real arm's) and
    a sensor nearly without noise, three draws: with ``position_sigma`` the errors over
    the sigmas have an rms within 2.5 (their errors-in-variables bias included); over the
    sensor noise's share alone they would be beyond 10."""
    times, positions, wrench_times, w = recording
    rng = np.random.default_rng(3)
    noise = ar1_noise(SIGMA * 1e-3, 0.0, RATE)
    z, z_bound = [], []
    for _ in range(3):
        shaken = positions + 2e-5 * rng.standard_normal(positions.shape)
        fit = fit_motion(panda, times, shaken, wrench_times, w, noise, position_sigma=2e-5)
        z.append((fit.pi - LOAD) / np.sqrt(np.diag(fit.cov)))
        z_bound.append((fit.pi - LOAD) / np.sqrt(np.diag(fit.bound)))
    assert np.sqrt(np.mean(np.square(z))) < 2.5, z
    assert np.sqrt(np.mean(np.square(z_bound))) > 10.0, z_bound


def test_a_misfit_common_to_the_hands_motion_and_the_objects_cancels_and_widens_nothing(
    panda, recording
):
    """A wrench no load explains, the same along both motions (as an arm model's error in
    a wrench estimated from the joint torques: here a configuration's term and a term
    whose least squares make the empty hand's inertia negative), four draws of the
    noise: the hand's fit is widened by it (chi^2/dof over 1.5) and made consistent,
    far (beyond 5 of the object's sigmas) from its least squares; the object's fit takes
    the hand's least squares off, so the misfit cancels: its errors over its sigmas have
    an rms near 1 and no mean beyond 1.5 (3 sigmas of a mean of four), its fit is not
    widened (below 1.1) and its covariance is the noise's of the two fits within 10 %, the
    hand's widening not carried over (the two residuals agree along the motion:
    ``common_misfit``)."""
    times, positions, wrench_times, w = recording
    hand_load = inertial_parameters(0.7, [0.0, 0.0, 0.03], np.diag([2.0e-3, 1.5e-3, 1.0e-3]))
    box = LOAD - hand_load
    late = wrench_times - 0.0065
    q, dq, ddq = joint_motion(times, positions, late)
    negative = np.zeros(10)
    negative[4] = -4e-3  # kg m^2 off the hand's ixx about the sensor origin (2.6e-3)
    Y = regressors_along(panda, q, dq, ddq)
    common = Y @ negative
    common[:, 0] += 1.0 * np.sin(10 * q[:, 4])
    common[:, 5] += 0.05 * np.cos(10 * q[:, 5])
    hand_w = w - Y @ box + common
    noise = ar1_noise(SIGMA, CORRELATION, RATE)
    rng = np.random.default_rng(5)
    z = []
    for _ in range(4):
        hand_read, read = (x + ar1(len(w), CORRELATION, rng, SIGMA) for x in (hand_w, w + common))
        hand = fit_motion(panda, times, positions, wrench_times, hand_read, noise)
        assert hand.constrained and hand.chi2 / hand.dof > 1.5 * hand.expected
        fit = fit_motion(panda, times, positions, wrench_times, read, noise, hand)
        sigma = np.sqrt(np.diag(fit.cov))
        assert np.max(np.abs(hand.pi - hand.least_squares) / sigma) > 5.0
        assert fit.widening < 1.1  # measured 1.02-1.06, 2.2 without the common misfit
        noise_alone = np.diag(fit.cov) / np.diag(fit.bound + hand.bound)
        assert np.all((noise_alone >= 1.0) & (noise_alone < 1.1)), noise_alone
        z.append((fit.pi - box) / sigma)
    assert np.abs(z).max() < 4.0, z
    assert 0.5 < np.sqrt(np.mean(np.square(z))) < 1.6, z
    # no parameter biased: the consistent hand taken off moves the object's ixx by -2.3 sigma
    assert np.abs(np.mean(z, axis=0)).max() < 1.5, z
