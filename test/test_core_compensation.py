"""com_core.compensation: the joints at a sample's stamp, and the compensated wrench of a
moving arm exact when its readings are the payload's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet_data
import pytest

from com_core.compensation import Compensator, JointTrack
from com_core.contract import ARM_JOINTS, FINGER_JOINTS
from com_core.kinematics import RobotModel
from com_core.payload import Payload, payload_wrench

NAMES = ("a", "b")
MS = 1_000_000  # ns


def track_of(*states, velocities=True):
    """A JointTrack of names a, b fed (stamp ms, (a, b), (va, vb)) states."""
    track = JointTrack(NAMES, max_age=0.05)
    for stamp, q, v in states:
        assert track.add(
            stamp * MS,
            ["b", "a", "extra"],
            [q[1], q[0], 9.0],
            [v[1], v[0], 0.0] if velocities else [],
        )
    return track


def test_joints_are_interpolated_between_states_and_extrapolated_past_the_latest():
    track = track_of((0, (0.0, 1.0), (1.0, 0.0)), (10, (0.01, 1.0), (1.0, 0.0)))
    np.testing.assert_allclose(track.at(4 * MS), [0.004, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(track.at(30 * MS), [0.03, 1.0], rtol=0, atol=1e-15)  # velocity
    assert track.at(61 * MS) is None  # 51 ms past the latest: stale
    assert track.at(-1 * MS) is None  # before the oldest kept
    held = track_of((0, (0.0, 1.0), (1.0, 0.0)), (10, (0.01, 1.0), (1.0, 0.0)), velocities=False)
    np.testing.assert_allclose(held.at(30 * MS), [0.01, 1.0])  # no velocities: held


def test_a_state_without_every_joint_is_refused_and_a_clock_restart_starts_anew():
    track = track_of((100, (0.0, 1.0), (0.0, 0.0)))
    assert not track.add(200 * MS, ["a"], [0.5])
    assert track.latest_stamp == 100 * MS
    assert track.add(5 * MS, ["a", "b"], [0.5, 0.5])  # earlier than the latest: a new clock
    assert track.at(60 * MS) is None and track.latest_stamp == 5 * MS


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    urdf = (Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf").read_text()
    return RobotModel(urdf, "panda_hand")


def test_a_moving_arm_is_compensated_exactly_at_each_sample(panda):
    """Joint states at 100 Hz with their velocities along a linear joint path, samples at
    1 kHz that read exactly the bias, the hand and the payload at their orientation: the
    compensated wrench is zero to rounding, between the states and past the latest one;
    a sample 60 ms past the latest state is left out and counted."""
    payload = Payload(
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
    names = [*ARM_JOINTS, *FINGER_JOINTS]
    start = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.04, 0.04])
    speed = np.array([0.2, -0.1, 0.3, 0.1, -0.4, 0.5, 0.6, 0.0, 0.0])  # rad/s, m/s
    compensator = Compensator.of(payload, panda, "test")
    errors = []
    for k in range(1000):  # 1 s at 1 kHz
        t = k * 1e-3
        if k % 10 == 0:
            compensator.track.add(k * MS, names, start + speed * t, speed)
        truth = dict(zip(names, start + speed * t, strict=True))
        reading = payload_wrench(payload, panda.sensor_rotation(truth))
        errors.append(compensator.compensate(k * MS, reading))
    assert np.max(np.abs(errors)) < 1e-12
    assert compensator.compensate(1069 * MS, reading) is None  # 60 ms past the latest
    assert (compensator.compensated, compensator.stale) == (1000, 1)
