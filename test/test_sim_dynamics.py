"""The simulator in motion: pybullet's joint force/torque reading during fast wrist moves
against pinocchio's inverse dynamics of the bodies beyond the sensor
(``com_core.robot.dynamics``, with the inertial parameters pybullet simulates), and the
object's inertia in the ground truth (no ROS). The figures: docs/design.md, The simulated
sensor in motion."""

from __future__ import annotations

import numpy as np
import pytest
from test_sim_physics import grasp

from com_core.robot.dynamics import (
    inertial_parameters,
    load_of,
    sensor_regressor,
    sensor_regressors,
)
from com_core.robot.model import RobotModel
from wrench_sim.config import SimConfig
from wrench_sim.load import GroundTruth
from wrench_sim.objects import SHAPES
from wrench_sim.physics import TIME_STEP, ArmWorld

SEGMENT = 0.8  # s per rest-to-rest quintic segment: the wrist within its 2.61 rad/s


@pytest.fixture(scope="module")
def held_box():
    world = ArmWorld(SimConfig(object_mass=0.5, seed=3))
    grasp(world)
    yield world
    world.close()


def follow(world: ArmWorld, swings: list[np.ndarray]) -> tuple[np.ndarray, ...]:
    """Swing the arm by each of ``swings`` (rad, about home) in turn, SEGMENT s each, and
    home; ``record_until`` its end."""
    home = np.array(world.config.robot.home_joints)
    waypoints = [home] + [home + swing for swing in swings] + [home]
    times = [SEGMENT * k for k in range(len(waypoints))]
    rest = [np.zeros(len(home))] * len(waypoints)  # each waypoint at rest: quintics
    names = world.config.robot.arm_joints
    return record_until(world, world.command_arm(names, times, waypoints, 0.0, rest, rest))


def record_until(world: ArmWorld, end: float) -> tuple[np.ndarray, ...]:
    """Step to ``end`` + 0.2 s (sim): per step, (sim time s, joint positions, velocities
    and accelerations at its start, the reading N and N m in ``ft_sensor``). A step's
    reading is of the state it starts from and the acceleration over it (the forward
    difference of the velocities): Bullet's semi-implicit Euler step."""
    arm = len(world.config.robot.arm_joints)
    times, positions, velocities, readings = [], [], [], []
    while world.time < end + 0.2:
        _, q, dq, _ = world.joint_state()
        times.append(world.time)
        positions.append(q[:arm])
        velocities.append(dq[:arm])
        world.step()
        readings.append(world.raw_wrench)
    velocities.append(world.joint_state()[2][:arm])
    accelerations = np.diff(velocities, axis=0) / TIME_STEP
    recorded = (times, positions, velocities[:-1], accelerations, readings)
    return tuple(np.array(x) for x in recorded)


def regressors_of(world: ArmWorld, positions, velocities, accelerations) -> np.ndarray:
    """(n, 6, 10) along the joint states, on the sim's own URDF (fingers fixed)."""
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    assert model.joint_names == robot.arm_joints  # the fingers are fixed (rigid grasp)
    return sensor_regressors(model, positions, velocities, accelerations)


def fitted(world: ArmWorld, motion, readings) -> tuple:
    """(the fit of the readings along ``motion`` (positions, velocities, accelerations)
    with the realistic sensor's noise per sample, its load, pybullet's load): each load
    as (mass kg, COM m, inertia about the COM kg m^2)."""
    from com_core.estimation.fits.inertial import fit_inertial

    fit = fit_inertial(regressors_of(world, *motion), readings, [0.1] * 3 + [0.005] * 3)
    return fit, load_of(fit.pi), load_of(world.load_parameters())


def assert_same_load(load: tuple, truth: tuple, com_within: float) -> None:
    """Two loads (mass, COM, inertia about the COM): mass to 0.01 %, COM to ``com_within``
    m, principal moments to 1 %."""
    (mass, com, inertia), (true_mass, true_com, true_inertia) = load, truth
    assert mass == pytest.approx(true_mass, rel=1e-4)
    np.testing.assert_allclose(com, true_com, atol=com_within)
    moments, true_moments = np.linalg.eigvalsh(inertia), np.linalg.eigvalsh(true_inertia)
    np.testing.assert_allclose(moments, true_moments, rtol=0.01)


def wrist_motion(world: ArmWorld, amplitudes: list[float]) -> tuple[np.ndarray, ...]:
    """Swing the three wrist joints by ``amplitudes`` (rad) about home, back and forth in
    five segments; (the readings, the inverse dynamics' wrench, the static model's at the
    same joints), each (n, 6), N and N m, ``ft_sensor``."""
    swing = np.zeros(len(world.config.robot.arm_joints))
    swing[-3:] = amplitudes
    _, positions, velocities, accelerations, readings = follow(
        world, [swing * (-1) ** k for k in range(5)]
    )
    pi = world.load_parameters()
    still = np.zeros_like(velocities)
    dynamic = regressors_of(world, positions, velocities, accelerations) @ pi
    static = regressors_of(world, positions, still, still) @ pi
    return readings, dynamic, static


def rms(x: np.ndarray) -> np.ndarray:
    """(force, torque) rms over samples and axes."""
    return np.array([np.sqrt(np.mean(x[:, :3] ** 2)), np.sqrt(np.mean(x[:, 3:] ** 2))])


@pytest.mark.parametrize(
    ("amplitudes", "within"),
    [
        ([0.4, 0.0, 0.0], 0.01),
        ([0.0, 0.4, 0.0], 0.01),
        ([0.0, 0.0, 0.5], 0.01),
        ([0.4, 0.4, 0.5], 0.01),
    ],
    ids=["joint5", "joint6", "joint7", "all three"],
)
def test_in_fast_wrist_motion_the_reading_is_the_inverse_dynamics(held_box, amplitudes, within):
    """The reading minus the inverse dynamics, rms, is within 1 % of the inertial wrench
    (the reading's part beyond the static model; 0.2-0.5 % measured, once the wrench
    Bullet counts twice is off it: ``wrench_sim.feedback``). The static model misses the
    whole inertial wrench: it is no model for motion."""
    readings, dynamic, static = wrist_motion(held_box, amplitudes)
    inertial, error = rms(dynamic - static), rms(readings - dynamic)
    assert inertial[1] > 0.01, inertial  # N m: a motion worth the name
    # joint 7 turns the load about its own axis: no force to speak of, then 1 mN at most
    assert np.all(error < np.maximum(within * inertial, [1e-3, 0.0])), error / inertial
    assert np.all(rms(readings - static) > 0.8 * inertial)


def test_the_ground_truth_holds_the_objects_inertia_in_the_sensor_frame(held_box):
    """The box's inertia about its COM, in sensor axes: the solid box's principal moments,
    and the load's parameters are the hand's and the object's summed."""
    hand, obj = held_box.inertia_ground_truth()
    mass = held_box.object.mass
    a, b, c = 2 * np.array(SHAPES["box"].half_extents)  # m: the solid box's sides
    expected = mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(obj)), np.sort(expected), rtol=1e-6)
    total_mass, com, _ = load_of(held_box.load_parameters())
    hand_mass, hand_com = held_box.hand_ground_truth()
    object_mass, object_com = held_box.object_ground_truth()
    assert total_mass == pytest.approx(hand_mass + object_mass, rel=1e-12)
    np.testing.assert_allclose(
        com, (hand_mass * hand_com + object_mass * object_com) / total_mass, atol=1e-9
    )
    assert np.all(np.linalg.eigvalsh(hand) > 0)


def test_the_fit_in_motion_gives_the_load_pybullet_simulates(held_box):
    """Seven random wrist moves (5.6 s), the ideal sensor: the 10 parameters of hand and
    box together from the readings (``estimation.fits.inertial``) are pybullet's, mass to
    0.01 %, COM to 0.01 mm, principal moments to 1 % (measured: 4e-4 %, 7e-4 mm,
    0.2 %)."""
    rng = np.random.default_rng(1)
    swings = [np.concatenate([np.zeros(4), rng.uniform(-1, 1, 3) * [0.4, 0.4, 0.5]])
              for _ in range(7)]  # fmt: skip
    _, *motion, readings = follow(held_box, swings)
    _, load, truth = fitted(held_box, motion, readings)
    assert_same_load(load, truth, com_within=1e-5)


def test_the_designed_excitation_is_followed_and_gives_the_load(held_box):
    """The D-optimal wrist excitation (``planning.excitation``, 3 s), sent as waypoints
    with their velocities and accelerations at 20 Hz: the arm follows it to 0.5 mrad, and
    the fit from its readings is pybullet's load (measured: 0.04 mrad; mass 0.003 %, COM
    0.004 mm, principal moments 0.2 %)."""
    from com_core.planning.excitation import design_excitation

    world = held_box
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    home = np.array(robot.home_joints)
    excitation = design_excitation(model, home, robot.arm_joints[-3:], period=3.0,
                                   iterations=60, seed=0)  # fmt: skip
    times = np.arange(0, 61) * 0.05  # from its start, at rest at home
    q, dq, ddq = excitation.at(times)
    start = world.time
    end = world.command_arm(robot.arm_joints, times, q, 0.0, dq, ddq)
    stamps, *motion, readings = record_until(world, end)
    planned = excitation.at(np.minimum(stamps - start, excitation.period))[0]
    assert np.abs(motion[0] - planned).max() < 5e-4
    fit, load, truth = fitted(world, motion, readings)
    assert_same_load(load, truth, com_within=2e-5)
    assert fit.chi2 / fit.dof < 0.01  # the model error is far below the realistic noise


@pytest.mark.parametrize("moving", [[4], [4, 5, 6]], ids=["joint5", "wrist"])
def test_bullets_reading_in_free_motion_is_the_reaction_plus_what_it_counts_twice(moving):
    """The empty arm, gravity off, its motors slack, set moving: after one step pybullet's
    raw reading is the inverse dynamics at the step's start (the acceleration: the step's
    velocity change) plus ``CountedTwice.wrench``, to 1 % of the inertial wrench."""
    from wrench_sim.feedback import CountedTwice
    from wrench_sim.objects import object_spec
    from wrench_sim.scene import Scene

    config = SimConfig()
    home = np.array(config.home)
    scene = Scene(config, object_spec("box", 0.5, (0.0, 0.0, 0.0), np.random.default_rng(0)), home)
    try:
        c, body, arm = scene.client, scene.robot_body, scene.arm
        c.setGravity(0.0, 0.0, 0.0)
        c.setJointMotorControlArray(body, arm, c.VELOCITY_CONTROL, forces=[0.0] * len(arm))
        c.enableJointForceTorqueSensor(body, scene.sensor, True)
        twice = CountedTwice(c, body, scene.urdf_text, scene.sensor, scene.load_links)
        model = RobotModel(scene.urdf_text, config.robot.sensor_frame)
        hand = GroundTruth(scene).inertial_parameters(False)
        rng = np.random.default_rng(2)
        for _ in range(5):
            q = home + rng.uniform(-0.3, 0.3, len(arm))
            dq = np.zeros(len(arm))
            dq[moving] = rng.choice([-1.0, 1.0], len(moving)) * rng.uniform(1.5, 2.5, len(moving))
            for joint, position, velocity in zip(arm, q, dq, strict=True):
                c.resetJointState(body, joint, position, velocity)
            states = c.getJointStates(body, twice.joints)
            extra = twice.wrench([s[0] for s in states], [s[1] for s in states])
            c.stepSimulation()
            reading = -np.array(c.getJointState(body, scene.sensor)[2])
            ddq = (np.array([s[1] for s in c.getJointStates(body, arm)]) - dq) / TIME_STEP
            still = np.zeros(len(arm))
            inertial = (
                sensor_regressor(model, q, dq, ddq) - sensor_regressor(model, q, still, still)
            ) @ hand  # the inverse dynamics' part beyond gravity (gravity is off here)
            error = rms((reading - inertial - extra)[None]) / rms(inertial[None])
            assert np.all(error < 0.01), error  # 0.05-0.5 % measured
            # without the mend: 4-38 % of the force, 35-150 % of the torque
            assert np.all(rms(extra[None]) > 0.03 * rms(inertial[None]))
    finally:
        scene.close()


def test_the_motion_fit_through_the_realistic_sensor_gives_the_object():
    """The designed excitation run twice on the simulator, with the empty hand and then
    holding the 0.5 kg box, read through the realistic sensor (its coloured noise,
    quantisation, drifting bias and 1 % calibration) with joint states at 100 Hz, each
    fitted by ``estimation.fits.motion.fit_motion``: the hand's parameters taken off the second
    fit, the box's mass, COM and inertia lie within 4 of their sigmas, and the delay
    found is near the sensor's low-pass and the sim's step (6.5 ms; 5.7-6.1 ms measured,
    the calibration's cross-talk pulling it). Along a motion the fit did not see, the
    wrench less the fitted load's stays within twice the sensor's noise per axis, where
    the static model of the same load leaves 3 to 14 times it.

    The noise model holds the quantisation's white error: without it (the low-pass
    alone) both fits of the same recordings widen by 1.08-1.11; with it, the box's
    chi^2/dof is what its calibration's error explains, the hand's 1.9 % beyond it (its
    noise's share widened so). The widened fits tell how the box's covariance takes the
    hand's."""
    from com_core.estimation.fits.motion import (
        compensated,
        fit_motion,
        joint_motion,
        load_vector,
        regressors_along,
        widening_factor,
    )
    from com_core.planning.excitation import design_excitation
    from com_core.sensing.sensor_profiles import PROFILES
    from wrench_sim.sensor import profile_sensor
    from wrench_sim.studies import run_excitation, without_rest

    p = PROFILES["realistic"]
    sensor = profile_sensor(p, seed=7, serial=7)
    noise, calibration = p.noise_model(), p.calibration()
    world = ArmWorld(SimConfig(object_mass=0.5, seed=3))
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    excitation = design_excitation(model, robot.home_joints, robot.arm_joints[-3:],
                                   period=3.0, iterations=60, seed=0)  # fmt: skip

    def record(motion) -> tuple[np.ndarray, ...]:
        return without_rest(run_excitation(world, motion, sensor, joint_every=10))  # 100 Hz

    try:
        hand_motion = record(excitation)
        grasp(world)
        box_motion = record(excitation)
        hand = fit_motion(model, *hand_motion, noise, calibration=calibration)
        box = fit_motion(model, *box_motion, noise, hand, calibration)
        mass, com = world.object_ground_truth()
        truth = load_vector(inertial_parameters(mass, com, world.inertia_ground_truth()[1]))
        z = (box.load_vector() - truth) / np.sqrt(np.diag(box.load_cov()))
        assert np.all(np.abs(z) < 4.0), z
        assert hand.widening < 1.03 and box.widening < 1.03  # measured 1.019 and 1.0
        low_pass = p.with_overrides(resolution_f=0.0, resolution_tau=0.0).noise_model()
        hand_ = fit_motion(model, *hand_motion, low_pass, calibration=calibration)
        box_ = fit_motion(model, *box_motion, low_pass, hand_, calibration)
        assert hand_.widening > 1.05 and box_.widening > 1.05  # measured 1.105 and 1.079
        # the box's covariance: its own noise share widened by its fit, its calibration's,
        # and the hand's noise share as the hand's fit widened it; none of the hand's
        # calibration share (common to both motions), widened or not. The quantisation is
        # noise, not a misfit along the motion: the two fits' residuals do not agree on it
        assert box_.common < 0.01 * box_.dof and box.common < 0.01 * box.dof
        hand_widening = widening_factor(hand_.chi2 - box_.common, hand_.dof, hand_.expected,
                                        hand_.misfit)  # fmt: skip
        np.testing.assert_allclose(
            box_.cov,
            box_.widening * box_.bound + box_.calibration_cov + hand_widening * hand_.bound,
        )
        assert 0.005 < hand.delay < 0.008 and 0.005 < box.delay < 0.008
        assert box.chi2 / box.dof < 1.3
        # a motion the fit did not see: the compensated wrench is the sensor's noise
        other = design_excitation(model, robot.home_joints, robot.arm_joints[-3:],
                                  period=3.0, iterations=20, seed=5)  # fmt: skip
        recorded = record(other)
        inner = (recorded[2] > recorded[0][0] + 0.1) & (recorded[2] < recorded[0][-1] - 0.1)
        load = hand.pi + box.pi
        stamps, readings = recorded[2][inner], recorded[3][inner]
        left = compensated(model, load, box.bias, box.delay, *recorded[:2], stamps, readings)
        sigma = np.array([p.sigma_f] * 3 + [p.sigma_tau] * 3)
        ratio = np.sqrt(np.mean(left**2, axis=0)) / sigma
        q = joint_motion(*recorded[:2], stamps - box.delay)[0]
        still = np.zeros_like(q)
        static = readings - regressors_along(model, q, still, still) @ load - box.bias
        static_ratio = np.sqrt(np.mean(static**2, axis=0)) / sigma
        # measured 1.0-1.7 (the calibration's error beside the noise), static 4-14
        assert np.all(ratio < 2.0) and np.all(static_ratio > 3.0), (ratio, static_ratio)
    finally:
        world.close()
