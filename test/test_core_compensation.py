"""com_core.payload.compensation: the payload's wrench at a sample's stamp from the joint states
around it, and the compensated wrench of a moving arm within the bound of that."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet_data
import pytest
from conftest import PANDA_JOINTS

from com_core.payload.compensation import Compensator
from com_core.payload.model import Payload, payload_wrench
from com_core.robot.model import RobotModel

MS = 1_000_000  # ns
NAMES = list(PANDA_JOINTS)
START = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.04, 0.04])
SPEED = np.array([0.2, -0.1, 0.3, 0.1, -0.4, 0.5, 0.6, 0.0, 0.0])  # rad/s, m/s


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    urdf = (Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf").read_text()
    return RobotModel(urdf, "panda_hand")


def payload_of(**changes) -> Payload:
    values = dict(
        mass=0.3,
        com=np.array([0.01, -0.02, 0.1]),
        cov=np.eye(4) * 1e-8,
        hand_mass=0.73,
        hand_com=np.array([0.0, 0.0, 0.04]),
        bias=np.array([0.5, -0.3, 0.2, 0.01, -0.02, 0.005]),
        mount=np.array([0.02, -0.01, 0.03]),
        base_tilt=np.array([0.01, 0.0, 0.0]),
        frame="ft_sensor",
        sensor_frame="panda_hand",
        base_frame="panda_link0",
        information="kinematics+mount",
    )
    return Payload(**(values | changes))


def at(panda: RobotModel, payload: Payload, q) -> np.ndarray:
    """The payload's wrench at joint positions ``q`` (NAMES order)."""
    return payload_wrench(payload, panda.sensor_rotation(dict(zip(NAMES, q, strict=True))))


def test_the_payload_wrench_is_interpolated_between_states_and_extrapolated_past(panda):
    payload = payload_of()
    c = Compensator(payload, panda, max_age=0.05)
    q0, q1 = START, START + SPEED * 0.01
    assert c.add_joint_state(0, NAMES, q0, SPEED)
    assert c.add_joint_state(10 * MS, list(reversed(NAMES)), q1[::-1], SPEED[::-1])  # any order
    w0, w1 = at(panda, payload, q0), at(panda, payload, q1)
    np.testing.assert_allclose(c.payload_wrench_at(4 * MS), w0 + 0.4 * (w1 - w0), atol=1e-12)
    # past the latest: along the joint velocities, to the second order of the step:
    # |W| (omega t)^2 / 2 with |W| ~ 12 N, omega ~ 1.2 rad/s, t = 20 ms: 3.5 mN
    ahead = at(panda, payload, START + SPEED * 0.03)
    error = np.abs(np.array(c.payload_wrench_at(30 * MS)) - ahead).max()
    assert 1e-5 < error < 3.5e-3, error
    assert c.payload_wrench_at(61 * MS) is None  # 51 ms past the latest: stale
    assert c.payload_wrench_at(-1 * MS) is None  # before the oldest kept
    held = Compensator(payload, panda)
    held.add_joint_state(0, NAMES, q1)  # no velocities: held
    np.testing.assert_allclose(held.payload_wrench_at(20 * MS), w1, atol=1e-12)


def test_a_sensor_calibrated_in_place_is_compensated_through_its_correction(panda):
    """The payload is the load's: a sensor that reads C w is read through C^-1 first, so
    its compensated wrench is the one a perfect sensor's would be."""
    from com_core.sensing.wrench_model import calibration_matrix

    reading = calibration_matrix(0.01, 290.0, 10.0, np.random.default_rng(2))
    correction = tuple(map(tuple, np.linalg.inv(reading).tolist()))
    payload = payload_of()
    perfect = Compensator(payload, panda)
    corrected = Compensator(payload, panda, correction=correction)
    for c in (perfect, corrected):
        assert c.add_joint_state(0, NAMES, START)
    contact = np.array([0.3, -0.2, 0.5, 0.01, 0.02, -0.01])  # a push besides the load
    load = np.array(at(panda, payload, START)) + contact
    truth = perfect.compensate(1 * MS, load)
    np.testing.assert_allclose(corrected.compensate(1 * MS, reading @ load), truth, atol=1e-9)
    assert np.abs(np.subtract(perfect.compensate(1 * MS, reading @ load), truth)).max() > 1e-3


def test_a_state_without_every_joint_is_refused_and_a_clock_restart_starts_anew(panda):
    c = Compensator(payload_of(), panda)
    assert c.add_joint_state(100 * MS, NAMES, START)
    assert not c.add_joint_state(200 * MS, NAMES[:3], START[:3])
    assert c.add_joint_state(5 * MS, NAMES, START)  # before the latest: a new clock
    assert c.payload_wrench_at(60 * MS) is None and c.payload_wrench_at(50 * MS) is not None


def test_a_new_payload_takes_over_the_joint_states_and_the_counts(panda):
    first = Compensator(payload_of(), panda)
    first.add_joint_state(0, NAMES, START)
    first.compensate(MS, [0.0] * 6)
    second = Compensator(payload_of(mass=0.5), panda)
    second.take_over(first)
    assert second.compensated == 1
    np.testing.assert_allclose(
        second.payload_wrench_at(2 * MS), at(panda, payload_of(mass=0.5), START), atol=1e-12
    )


def test_a_moving_arm_is_compensated_within_the_interpolations_bound_at_each_sample(panda):
    """Joint states at 100 Hz with their velocities along a joint path, samples at 1 kHz
    reading exactly the bias, the hand and the payload at their orientation, each
    compensated when it arrives (after the latest joint state): the compensated wrench is
    within |W| (omega dt)^2 / 2 of zero, W some 12 N, the sensor turning at up to ~1.2
    rad/s and dt up to 9 ms: 0.7 mN (a sample's noise: 100 mN). A sample 60 ms past the
    latest state is left out and counted."""
    payload = payload_of()
    compensator = Compensator(payload, panda)
    errors = []
    for k in range(1000):  # 1 s at 1 kHz
        if k % 10 == 0:
            compensator.add_joint_state(k * MS, NAMES, START + SPEED * k * 1e-3, SPEED)
        reading = at(panda, payload, START + SPEED * k * 1e-3)
        errors.append(compensator.compensate(k * MS, reading))
    assert np.max(np.abs(errors)) < 7e-4
    assert np.max(np.abs(errors)) > 1e-6  # linear in time, not exact: the test sees it
    assert compensator.compensate(1069 * MS, reading) is None  # 60 ms past the latest
    assert (compensator.compensated, compensator.stale) == (1000, 1)


def test_malformed_and_repeated_joint_states_leave_the_track_as_it_was(panda):
    """A state without one finite position per name is refused; velocities of another
    length or not finite count as absent (held, not extrapolated); a state stamped as the
    latest (republished) is ignored, not taken for a restarted clock."""
    c = Compensator(payload_of(), panda)
    assert c.add_joint_state(0, NAMES, START, SPEED)
    assert c.add_joint_state(10 * MS, NAMES, START + SPEED * 0.01, SPEED)
    assert not c.add_joint_state(20 * MS, NAMES, START[:5])
    assert not c.add_joint_state(20 * MS, NAMES, [*START[:8], float("nan")])
    assert c.add_joint_state(10 * MS, NAMES, START, SPEED)  # the latest again: ignored
    assert c.payload_wrench_at(5 * MS) is not None  # the history is kept
    held = Compensator(payload_of(), panda)
    held.add_joint_state(0, NAMES, START, SPEED[:3])
    held.add_joint_state(5 * MS, NAMES, START + 1e-3, [float("nan")] * len(NAMES))
    w = held.payload_wrench_at(5 * MS)
    assert held.payload_wrench_at(30 * MS) == w  # no rate: held


def test_a_fast_arms_states_are_kept_every_min_spacing(panda):
    """1 kHz joint states (Franka's): one 4 ms after the latest kept is kept, one sooner
    is not (W there is the latest kept's, held without velocities)."""
    payload = payload_of()
    c = Compensator(payload, panda)
    other = START + 0.1
    assert c.add_joint_state(0, NAMES, START)
    assert c.add_joint_state(3 * MS, NAMES, other)  # taken, not kept: too soon
    np.testing.assert_allclose(c.payload_wrench_at(3 * MS), at(panda, payload, START))
    assert c.add_joint_state(4 * MS, NAMES, other)
    np.testing.assert_allclose(c.payload_wrench_at(4 * MS), at(panda, payload, other))
