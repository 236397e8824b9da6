"""com_core.planning.motion_accuracy: the sigmas an exploration in motion will have,
predicted before anything moves, against the estimator's fit of a simulated run; and
how many cycles of the motion a target on the inertia needs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from com_core.estimation.fits.motion import load_vector
from com_core.estimation.runs.motion_solution import MotionResult
from com_core.planning.excitation import Excitation, acceleration_bounds, design_excitation
from com_core.planning.motion_accuracy import (
    HAND_CYCLES,
    MotionAccuracy,
    box_inertia,
    cycles_for,
    fastest,
    predict_fit,
    predict_motion,
)
from com_core.robot.config import read_robot_config
from com_core.robot.dynamics import inertial_parameters, links_beyond
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.config import SimConfig
from wrench_sim.physics import ArmWorld
from wrench_sim.studies import explore_in_motion

REALISTIC = PROFILES["realistic"]
_EXCITATION = Excitation(("j",), np.zeros(1), ("j",), 1.0, np.zeros((1, 3)), np.zeros((1, 3)), 0.0)


@pytest.fixture(scope="module")
def panda():
    """(robot model, the 3 s excitation explore_in_motion runs, the hand's parameters
    from the URDF, a 0.5 kg box's whose principal moments stand apart)."""
    world = ArmWorld(SimConfig(object_mass=0.5, seed=3))
    robot = world.config.robot
    from com_core.robot.model import RobotModel

    model = RobotModel(world.urdf_text, robot.sensor_frame)
    excitation = design_excitation(model, robot.home_joints, robot.arm_joints[-3:],
                                   period=3.0, iterations=40)  # fmt: skip
    hand = links_beyond(world.urdf_text, robot.sensor_frame)
    box = inertial_parameters(0.5, [0.0, 0.0, 0.1], box_inertia(0.5, (0.04, 0.06, 0.09)))
    world.close()
    return model, excitation, hand, box


@pytest.mark.parametrize("robot", ["panda", "xarm6", "ur5e", "fr3"])
def test_the_links_beyond_the_sensor_are_the_hand_the_sim_holds(robot):
    """Mass and COM of every link the URDF attaches beyond the sensor's (joints at zero)
    are the sim's hand's (pybullet's reading of the same URDF)."""
    world = ArmWorld(SimConfig(robot=read_robot_config(robot)))
    try:
        pi = links_beyond(world.urdf_text, world.config.robot.sensor_frame)
        mass, com = world.hand_ground_truth()
        assert pi[0] == pytest.approx(mass, rel=1e-9)
        np.testing.assert_allclose(pi[1:4] / pi[0], com, atol=1e-7)
    finally:
        world.close()
    with pytest.raises(ValueError, match="not a link"):
        links_beyond(world.urdf_text, "no_such_link")


def test_the_prediction_is_the_sigma_of_a_simulated_run_over_two_cycles(panda):
    """The Panda's 0.5 kg box along two cycles of its excitation, the empty hand along
    four (the sequencer's default), through the realistic sensor (serial 4): the
    estimator's sigmas of mass, COM and the six inertia elements are within 0.85-1.3 of
    the prediction's over as many cycles (the run's fit also weighs the noise it learnt,
    the delay it found and the chi-square; 1.03-1.2 measured over one cycle for serials
    0-3). The box's two equal moments make its principal axes, and so each moment's
    sigma, arbitrary in their plane: the elements are compared."""
    model, excitation, hand, _ = panda
    run = explore_in_motion(REALISTIC.calibration_accuracy, seed=4, cycles=2,
                            hand_cycles=HAND_CYCLES)  # fmt: skip
    try:
        (mass, com), inertia = run.world.object_ground_truth(), run.world.inertia_ground_truth()
        load = inertial_parameters(mass, com, inertia[1])
        result = run.solution.motion
        assert result is not None, run.solution.reason
    finally:
        run.world.close()
    fit = predict_fit(model, replace(excitation, cycles=2), hand, load, REALISTIC.noise_model(),
                      REALISTIC.calibration(), None, HAND_CYCLES)  # fmt: skip
    ratio = np.sqrt(np.diag(result.load_cov) / np.diag(fit.load_cov()))
    assert np.all((ratio > 0.85) & (ratio < 1.3)), ratio


def test_a_longer_motion_of_the_empty_hand_takes_its_share_of_the_noise_off(panda):
    """The object's fit takes the empty hand's off: over motions of equal length half the
    noise's share is the hand's. The hand along four periods, the object along one: the
    object's mass and COM sigmas are 0.7-0.85 of the equal motions' (0.79 of them if the
    two shares were equal: sqrt((1 + 1/4) / 2)); over two periods of the object with the
    same hand the moments' sigmas are what ``sigma_moments_over`` makes of the one-period
    prediction (within 5 %)."""
    model, excitation, hand, box = panda
    noise = REALISTIC.noise_model()
    equal = predict_motion(model, excitation, hand, box, noise, None)
    longer = predict_motion(model, excitation, hand, box, noise, None, None, hand_cycles=4)
    shrunk = np.append(longer.sigma_mass / equal.sigma_mass, longer.sigma_com / equal.sigma_com)
    assert np.all((shrunk > 0.7) & (shrunk < 0.85)), shrunk
    two = predict_fit(model, replace(excitation, cycles=2), hand, box, noise, None, None, 4)
    result = MotionResult(two, two, two.load_cov())
    np.testing.assert_allclose(longer.sigma_moments_over(2), result.moments[1], rtol=0.05)


def test_more_cycles_divide_the_noises_share_and_leave_the_calibrations(panda):
    """Over three cycles the moments' sigmas are the one-cycle prediction's with the
    noise's share divided by three (within 5 %: 3.3 % measured, the delay's sigma and the
    coloured noise at the motion's ends do not scale exactly); with a perfect calibration
    nothing is left (sigma / sqrt(3)); with the realistic sensor's 1 % the calibration's
    share stays."""
    model, excitation, hand, box = panda
    noise = REALISTIC.noise_model()
    for calibration in (None, REALISTIC.calibration()):
        one = predict_motion(model, excitation, hand, box, noise, calibration)
        three = predict_fit(model, replace(excitation, cycles=3), hand, box, noise, calibration)
        result = MotionResult(three, three, three.load_cov())
        np.testing.assert_allclose(one.sigma_moments_over(3), result.moments[1], rtol=0.05)
        if calibration is None:
            np.testing.assert_allclose(one.fixed, 0.0, atol=1e-6 * one.sigma_moments.max() ** 2)
        else:
            assert np.all(one.fixed > 0.05 * one.sigma_moments**2), (one.fixed, one.sigma_moments)


def test_the_prediction_holds_what_a_stated_hysteresis_leaves_and_more_cycles_keep_it(panda):
    """The xArm F/T's stated hysteresis, its gain taken off: what it leaves widens the
    predicted sigmas as the estimator weighs it (``motion_calibration`` of the motion's
    wrenches), a gain error the same at every pass, so more cycles leave it too."""
    model, excitation, hand, box = panda
    profile = PROFILES["xarm_ft"]
    noise, hysteresis = profile.noise_model(), profile.stated_hysteresis()
    told = predict_motion(model, excitation, hand, box, noise, None, hysteresis)
    untold = predict_motion(model, excitation, hand, box, noise, None)
    mass, com = told.sigma_mass / untold.sigma_mass, told.sigma_com / untold.sigma_com
    assert mass > 1.05 and com[2] > 1.5, (mass, com)  # ~1.09, ~1.85
    np.testing.assert_allclose(untold.fixed, 0.0, atol=1e-6 * untold.sigma_moments.max() ** 2)
    assert np.all(told.fixed > 0.0) and np.all(told.sigma_moments >= untold.sigma_moments)


def test_the_cycles_a_target_needs_or_that_none_reach_it():
    """The fewest cycles that bring every moment's sigma within the target; none when the
    share more cycles leave exceeds it, or when more than MAX_CYCLES would be needed."""
    moments = np.array([1.0, 2.0, 2.0])
    a = MotionAccuracy(0.0, np.zeros(3), moments, np.array([0.5, 0.4, 0.4]),
                       fixed=np.array([0.01, 0.0, 0.0]))  # fmt: skip
    assert cycles_for(a, 0.5) == 1
    # 0.25 needs 0.01 + 0.24 / n <= 0.0625: n >= 4.6
    assert cycles_for(a, 0.25) == 5
    assert cycles_for(a, 0.09) is None  # the fixed share alone is 0.1
    assert cycles_for(replace(a, fixed=np.zeros(3)), 0.05) is None  # 100 cycles


def test_a_faster_motion_tells_the_inertia_better_in_the_sim_as_predicted(panda):
    """The Panda's 0.5 kg box along a 2 s excitation at the arm's own acceleration limits
    (15, 20, 20 rad/s^2) through the realistic sensor (serial 1): the run stays within its
    error bars and its sigmas within 0.85-1.3 of the prediction along that motion, as
    along the default one. Predicted for a box of distinct moments: against the default
    3 s at 8 rad/s^2, every moment's sigma shrinks (0.49-0.81 computed), and the
    calibration's share, which more cycles leave, most (0.42-0.59 of its sigma): the
    inertial wrench grows against the calibration's error, so 2 s reach what no number
    of 3 s cycles does."""
    model, default, hand, box = panda
    config = read_robot_config("panda")
    bounds = acceleration_bounds(np.inf, config.arm_joints[-3:], config.arm_joints,
                                 config.max_joint_acceleration)  # fmt: skip
    run = explore_in_motion(REALISTIC.calibration_accuracy, seed=1, period=2.0,
                            acceleration=bounds)  # fmt: skip
    try:
        (mass, com), inertia = run.world.object_ground_truth(), run.world.inertia_ground_truth()
        load = inertial_parameters(mass, com, inertia[1])
        result = run.solution.motion
        assert result is not None, run.solution.reason
        assert run.solution.usable, run.solution.reason
    finally:
        run.world.close()
    fast = design_excitation(model, config.home_joints, config.arm_joints[-3:], 2.0, bounds,
                             iterations=40)  # fmt: skip
    noise, calibration = REALISTIC.noise_model(), REALISTIC.calibration()
    fit = predict_fit(model, fast, hand, load, noise, calibration)
    ratio = np.sqrt(np.diag(result.load_cov) / np.diag(fit.load_cov()))
    assert np.all((ratio > 0.85) & (ratio < 1.3)), ratio
    error = result.object.load_vector() - load_vector(load)  # less the truth
    assert np.all(np.abs(error) < 3.5 * np.sqrt(np.diag(result.load_cov))), error
    slow = predict_motion(model, default, hand, box, noise, calibration)
    quick = predict_motion(model, fast, hand, box, noise, calibration)
    assert np.all(quick.sigma_moments < 0.9 * slow.sigma_moments)
    assert np.all(quick.fixed < 0.5 * slow.fixed)
    assert fastest([(default, slow), (fast, quick)], target=10.0) == (1, 1)  # 2 s, not 3


def test_the_fastest_design_meets_the_target_in_the_least_time():
    """Of designs with their predictions, the one whose cycles take the least time wins:
    two cycles of 1.5 s before one of 4 s; none when no design meets the target."""
    moments = np.array([1.0, 2.0, 2.0])

    def design(period: float, sigma: float):
        excitation = replace(_EXCITATION, period=period)
        return excitation, MotionAccuracy(0.0, np.zeros(3), moments, np.full(3, sigma),
                                          fixed=np.zeros(3))  # fmt: skip

    # 0.3 needs 1 cycle of sigma 0.3, 2 of 0.4 (0.16 / 2 = 0.08 <= 0.09), 4 of 0.6
    designs = [design(4.0, 0.3), design(1.5, 0.4), design(3.0, 0.6)]
    assert fastest(designs, 0.3) == (1, 2)
    assert fastest(designs[::2], 0.3) == (0, 1)
    assert fastest(designs, 0.01) is None
