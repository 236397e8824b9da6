"""The simulated sensor's parts that depend on time, and the arm's ringing, without ROS.

``wrench_sim.sensor.WrenchSensor``: the true wrench through the sensor's first-order
low-pass, the correlated noise as ``SensorModel.measure`` draws it, the calibration, a bias
that warms up and wanders (``BiasDrift``); the seeds' earlier streams unchanged; a run
read through a perfect calibration reads through another afterwards. The
``ideal`` profile reads the world's wrench as is. ``wrench_sim.physics.ArmWorld`` with
structural modes: after a move the wrench rings at each mode's frequency and decays at
zeta w; the ringing after the Panda's 30 deg tilt is printed. The node's refusals of the
sensor parts' parameters.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import choreography
from numpy.testing import assert_allclose, assert_array_equal

from com_core.robot.config import read_robot_config
from com_core.sensing.sensor_profiles import PROFILES
from com_core.sensing.wrench_model import SensorModel, calibration_matrix, gravity_wrench
from wrench_sim.physics import TIME_STEP, ArmWorld, SimConfig
from wrench_sim.sensor import (
    BiasDrift,
    WrenchSensor,
    profile_calibration,
    profile_drift,
    profile_sensor,
    random_streams,
)

CORRELATION_TIME = 0.005  # s
PANDA = read_robot_config("panda")
SETTLE = 0.3  # s: the sequencer's wait after the arm rests
SPEED = 1.35  # rad/s: the sequencer's mean joint speed
FORCE_TOL, TORQUE_TOL = 1e-3, 1e-4  # N, N m: the rigid world against the analytic wrench
WARMUP = np.array([0.3, 0.3, 0.3, 0.015, 0.015, 0.015])  # N, N m
RANDOM_WALK = np.array([2e-4, 2e-4, 2e-4, 1e-5, 1e-5, 1e-5])  # per sqrt(s)


def spread_tolerance(n: int) -> float:
    """4.5 sigma of a sample std's relative error over n independent draws."""
    return 4.5 / math.sqrt(2 * n)


def test_the_earlier_streams_of_a_seed_are_unchanged():
    """Streams added later are appended: a seed's object draw, noise and shifts stay."""
    children = np.random.SeedSequence(7).spawn(3)
    streams = random_streams(7)
    for name, child in zip(("object", "sensor", "slip"), children, strict=True):
        expected = np.random.Generator(np.random.PCG64(child)).standard_normal(100)
        assert_array_equal(streams[name].standard_normal(100), expected)
    assert {"calibration", "drift"} <= set(streams)


def test_the_low_pass_delays_and_smooths_the_signal():
    """A step of the true wrench reaches the reading as 1 - phi^(k+1), k samples after it."""
    model = SensorModel.from_scalars(correlation_time=CORRELATION_TIME)
    sensor = WrenchSensor(model, np.random.default_rng(1))
    for _ in range(10):
        assert_array_equal(sensor.read(np.zeros(6)), 0.0)
    step = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
    readings = np.array([sensor.read(step) for _ in range(40)])
    response = 1.0 - model.phi ** np.arange(1, 41)
    assert_allclose(readings, response[:, None] * step, rtol=1e-12, atol=1e-15)


def test_the_correlated_noise_is_what_measure_draws():
    model = SensorModel.from_scalars(0.1, 0.005, correlation_time=CORRELATION_TIME)
    sensor = WrenchSensor(model, np.random.default_rng(2))
    readings = np.array([sensor.read(np.zeros(6)) for _ in range(2500)])
    assert_array_equal(readings, model.measure(np.zeros((2500, 6)), np.random.default_rng(2)))


def test_the_bias_reaches_the_reading_as_is_and_the_wrench_calibrated():
    """reading = C w + bias + warm-up and walk at t, whatever the calibration."""
    calibration = calibration_matrix(0.01, 290.0, 10.0, np.random.default_rng(3))
    model = SensorModel.from_scalars(bias_f=0.2, bias_tau=-0.01, calibration=calibration)
    sensor = WrenchSensor(
        model,
        np.random.default_rng(4),
        BiasDrift(WARMUP, 600.0, RANDOM_WALK, np.random.default_rng(5)),
    )
    twin = BiasDrift(WARMUP, 600.0, RANDOM_WALK, np.random.default_rng(5))
    wrench = np.array([1.0, -2.0, 8.0, 0.1, -0.2, 0.03])
    for t in (0.0, 1.0, 60.0, 600.0):
        expected = calibration @ wrench + model.bias + twin.at(t)
        assert_allclose(sensor.read(wrench, t), expected, rtol=0, atol=1e-12)


def test_the_bias_warms_up_toward_an_offset_drawn_per_axis():
    """Per axis A (1 - exp(-t / T)), A drawn N(0, warmup^2): the curve exactly, and A's
    spread over seeds."""
    finals = []
    for seed in range(3000):
        drift = BiasDrift(WARMUP, 600.0, np.zeros(6), np.random.default_rng(seed))
        for t in (0.0, 60.0, 600.0, 3000.0):
            assert_allclose(drift.at(t), drift.final * (1.0 - math.exp(-t / 600.0)), rtol=1e-15)
        finals.append(drift.final)
    assert_allclose(np.std(finals, axis=0) / WARMUP, 1.0, atol=spread_tolerance(3000))


@pytest.mark.parametrize("name", [n for n in PROFILES if PROFILES[n].bias_drift_rate])
def test_the_bias_drifts_at_the_rate_its_profile_tells_the_estimator(name):
    """``SensorProfile.bias_drift_rate`` (the datasheet's ``bias_drift_rate``, the fits'
    prior) is the spread of the sim's drift per second from power-on: over the first minute
    the warm-up's mean rate is 10 (1 - exp(-1/10)) = 0.952 of its rate at power-on, and the
    random walk adds a nineteenth of it in quadrature (0.953)."""
    profile = PROFILES[name]
    rates = []
    for seed in range(2000):
        drift = profile_drift(profile, np.random.default_rng(seed))
        rates.append((drift.at(60.0) - drift.at(0.0)) / 60.0)
    stated = np.repeat(profile.bias_drift_rate, 3)
    assert profile.datasheet()["bias_drift_rate"] == list(profile.bias_drift_rate)
    assert_allclose(np.std(rates, axis=0) / stated, 0.953, atol=spread_tolerance(2000))


@pytest.mark.parametrize("step", [0.001, 0.05])
def test_the_random_walk_spreads_as_the_root_of_time(step):
    """After t s the walk's spread is random_walk sqrt(t) per axis, however often read."""
    t_end, runs = 0.1, 2000
    ends = []
    for seed in range(runs):
        drift = BiasDrift(np.zeros(6), 600.0, RANDOM_WALK, np.random.default_rng(seed))
        for t in np.arange(1, round(t_end / step) + 1) * step:
            end = drift.at(t)
        ends.append(end)
    ratio = np.asarray(ends) / (RANDOM_WALK * math.sqrt(t_end))
    assert_allclose(ratio.std(axis=0), 1.0, atol=spread_tolerance(runs))
    assert ratio.std() == pytest.approx(1.0, abs=spread_tolerance(ratio.size))


@pytest.fixture(scope="module")
def tilt() -> tuple[list[float], float]:
    """The Panda's 30 deg tilt about the sensor's y axis as the sequencer moves there:
    arm joints (rad) and the move's duration (s)."""
    motion = choreography("panda")
    goal, reason = motion.turned((0.0, 1.0, 0.0), math.pi / 6)
    assert goal is not None, reason
    return goal, motion.motion_time(PANDA.home_joints, goal, SPEED)


def ringing(
    modes: tuple[tuple[float, float], ...], goal: list[float], duration: float, grasp: bool
) -> tuple[np.ndarray, float]:
    """The wrench a world with ``modes`` reads beyond a rigid one's (n, 6), N and N m, from
    the start of a move to ``goal`` in ``duration`` s until 3 s after it, and the time (s,
    from that start) when the arm rested. ``grasp``: holding the object."""
    worlds = [ArmWorld(SimConfig()), ArmWorld(SimConfig(vibration=modes))]
    try:
        for world in worlds:
            if grasp:
                world.move_arm(PANDA.pick_joints, 3.0)
                world.command_gripper(PANDA.gripper_closed)
                world.run(0.5)
                assert world.object_held, world.events
                world.move_arm(PANDA.home_joints, 3.0)
            world.run(3.0)  # every earlier move's ringing gone
            world.command_move(goal, duration)
        rested = None
        difference = []
        for step in range(round((duration + 3.0) / TIME_STEP)):
            for world in worlds:
                world.step()
            if rested is None and worlds[0].arm_settled:
                rested = (step + 1) * TIME_STEP
            difference.append(worlds[1].wrench - worlds[0].wrench)
    finally:
        for world in worlds:
            world.close()
    assert rested is not None
    return np.array(difference), rested


def peaks(x: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of |x|."""
    a = np.abs(x)
    return np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1


@pytest.mark.parametrize("hz, zeta", [(12.0, 0.03), (27.0, 0.02)])
def test_a_move_leaves_the_arm_ringing_at_its_mode(tilt, hz, zeta):
    """After the move the extra wrench oscillates at the mode's frequency (zero crossings,
    within 5 %) and its envelope decays at zeta w (log-amplitude slope, within 20 %)."""
    goal, duration = tilt
    difference, rested = ringing(((hz, zeta),), goal, duration, grasp=False)
    after = difference[round(rested / TIME_STEP) :]
    axis = int(np.argmax(np.abs(after[:, :3]).max(axis=0)))
    x = after[:, axis]
    t = np.arange(len(x)) * TIME_STEP
    strong = np.abs(x).max() * 0.05  # fits over the ringing well above the physics' noise
    last = np.flatnonzero(np.abs(x) > strong)[-1]
    crossings = np.flatnonzero(np.sign(x[1:last]) != np.sign(x[: last - 1]))
    frequency = (len(crossings) - 1) / (2.0 * (t[crossings[-1]] - t[crossings[0]]))
    assert frequency == pytest.approx(hz * math.sqrt(1.0 - zeta**2), rel=0.05)
    top = peaks(x[:last])
    slope = np.polyfit(t[top], np.log(np.abs(x[top])), 1)[0]
    assert -slope == pytest.approx(zeta * 2.0 * math.pi * hz, rel=0.2)


def test_a_tilt_leaves_a_ringing_that_decays_into_the_next_window(tilt, capsys):
    """The realistic modes, the Panda holding the object: the ringing's force amplitude
    when the arm rests and when a window starts (the sequencer's settle later), printed."""
    goal, duration = tilt
    difference, rested = ringing(PROFILES["realistic"].modes, goal, duration, grasp=True)
    force = np.linalg.norm(difference[:, :3], axis=1)
    torque = np.linalg.norm(difference[:, 3:], axis=1)

    def amplitude(values: np.ndarray, t: float) -> float:
        """The largest value over the 0.1 s from ``t`` s after the arm rested."""
        start = round((rested + t) / TIME_STEP)
        return float(values[start : start + round(0.1 / TIME_STEP)].max())

    at = {t: (amplitude(force, t), amplitude(torque, t)) for t in (0.0, SETTLE, 1.0, 2.0)}
    with capsys.disabled():
        print(
            f"\nringing after the Panda's 30 deg tilt ({duration:.2f} s move), holding the "
            "object: "
            + ", ".join(f"{f:.3f} N {1e3 * m:.2f} mN m at +{t:g} s" for t, (f, m) in at.items())
            + f"; decaying at {math.log(at[0.0][0] / at[1.0][0]):.2f} 1/s over the first second"
        )
    assert at[0.0][0] > at[SETTLE][0] > at[1.0][0] > at[2.0][0]
    assert at[SETTLE][0] > 0.01  # a window's start still rings
    slowest = min(zeta * 2.0 * math.pi * hz for hz, zeta in PROFILES["realistic"].modes)
    assert at[2.0][0] < at[0.0][0] * math.exp(-slowest * 1.8)


def test_a_run_read_through_a_perfect_calibration_reads_through_another_afterwards():
    """bench/error_bars.py: the xArm sensor's readings (hysteresis, low-pass, noise,
    warming bias, quantisation) with its calibration C are those of the same sensor with
    C = I times C^T, but for the two quantisations (independent rounding errors: rms
    step / sqrt(6), mean within 4 of its standard errors) and C's percent of the bias and
    noise; without C^T they are its error on the load's wrench off."""
    profile, serial = PROFILES["xarm_ft"], 7
    t = np.arange(3000) * 1e-3
    angle = 0.5 * np.sin(2 * np.pi * t / 3.0)
    g = 9.81 * np.stack([np.sin(angle), np.zeros_like(angle), -np.cos(angle)], axis=1)
    wrenches = gravity_wrench(2.0, [0.01, 0.02, 0.08], g)

    def read(p) -> np.ndarray:
        sensor = profile_sensor(p, seed=1, serial=serial)
        return np.array([sensor.read(w, s) for w, s in zip(wrenches, t, strict=True)])

    calibrated, perfect = read(profile), read(profile.with_overrides(calibration_accuracy=0.0))
    off = calibrated - perfect @ profile_calibration(profile, serial).T
    rounding = np.array([profile.resolution_f] * 3 + [profile.resolution_tau] * 3) / math.sqrt(6)
    assert_allclose(np.sqrt(np.mean(off**2, axis=0)) / rounding, 1.0, atol=0.1)
    assert np.all(np.abs(off.mean(axis=0)) < 4 * rounding / math.sqrt(len(t)))
    uncorrected = np.sqrt(np.mean((calibrated - perfect) ** 2, axis=0))
    assert np.max(uncorrected[:3] / rounding[:3]) > 5


def test_the_ideal_sensor_reads_the_world_as_is():
    """The ideal profile's sensor, drift and all, changes no bit of the world's wrench, which
    is the analytic gravity wrench of the hand at a tilt."""
    p = PROFILES["ideal"]
    model = SensorModel.from_scalars(
        p.sigma_f,
        p.sigma_tau,
        resolution_f=p.resolution_f,
        resolution_tau=p.resolution_tau,
        limit_f=p.limit_f,
        limit_tau=p.limit_tau,
        correlation_time=p.correlation_time,
    )
    drift = BiasDrift(
        [p.warmup_f] * 3 + [p.warmup_tau] * 3,
        p.warmup_time,
        [p.random_walk_f] * 3 + [p.random_walk_tau] * 3,
        random_streams(0)["drift"],
    )
    sensor = WrenchSensor(model, random_streams(0)["sensor"], drift)
    world = ArmWorld(SimConfig(vibration=p.modes))
    try:
        goal = list(PANDA.home_joints)
        goal[5] += 0.5
        world.move_arm(goal, 2.0)
        world.run(0.2)
        for _ in range(20):
            world.step()
            assert_array_equal(sensor.read(world.wrench, world.time), world.wrench)
            expected = gravity_wrench(*world.hand_ground_truth(), world.gravity_in_sensor())
            assert_allclose(world.wrench[:3], expected[:3], atol=FORCE_TOL)
            assert_allclose(world.wrench[3:], expected[3:], atol=TORQUE_TOL)
    finally:
        world.close()


def test_the_sensor_parts_parameters_are_checked():
    """Each part's parameter: unset (NaN, [-1.0]) leaves the profile's; a value out of its
    range is refused naming the parameter, the value and the range; parts that make no
    sensor together are refused naming the part and the fix."""
    pytest.importorskip("rclpy")
    from com_core.inputs import InputError
    from wrench_sim.parameters import check_parameter as reason
    from wrench_sim.parameters import sensor_profile

    for name, value, allowed in (
        ("sigma_f", -0.1, "[0, 100] N"),
        ("correlation_time", math.inf, "[0, 1]"),
        ("warmup_time", -1.0, "[0, 1e+06] s"),
        ("random_walk_tau", -1e-5, "[0, 1] N m/sqrt(s)"),
        ("vibration_hz", [12.0, -27.0], "(0, 500) Hz"),
        ("calibration_accuracy", 1.5, "[0, 1)"),
        ("vibration_damping", [0.03, 1.2], "[0, 1)"),
    ):
        refusal = reason(name, value)
        assert refusal.startswith(f"{name}={value!r} refused: ") and allowed in refusal, refusal
    assert "realistic" in reason("sensor_profile", "noisy")
    for name, value in (("sigma_f", math.nan), ("vibration_hz", [-1.0]), ("limit_f", 0.0)):
        assert reason(name, value) == ""
    realistic = PROFILES["realistic"]
    unset = {"sensor_profile": "realistic", "sigma_f": math.nan, "vibration_hz": [-1.0]}
    assert sensor_profile(unset) == realistic
    assert sensor_profile(unset | {"sigma_f": 0.3}) == realistic.with_overrides(sigma_f=0.3)
    assert sensor_profile(unset | {"vibration_hz": [0.0]}).modes == ()
    with pytest.raises(InputError, match="one damping ratio per mode"):
        sensor_profile(unset | {"vibration_hz": [12.0]})
    with pytest.raises(InputError, match=r"sigma_f=0.0 refused: below half the resolution_f"):
        sensor_profile(unset | {"sigma_f": 0.0})
    assert sensor_profile(unset | {"sigma_f": 0.0, "resolution_f": 0.0}).sigma_f == 0.0
