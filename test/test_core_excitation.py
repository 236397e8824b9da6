"""com_core.planning.excitation: the periodic wrist motion for the 10 inertial parameters,
at rest at its ends, within the arm's limits, D-optimal against where it started (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PANDA

from com_core.planning.excitation import (
    acceleration_bounds,
    design_excitation,
    excitation_information,
)
from com_core.robot.config import urdf_file
from com_core.robot.model import RobotModel

WRIST = PANDA.arm_joints[-3:]


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel(urdf_file(PANDA).read_text(), PANDA.sensor_frame)


@pytest.fixture(scope="module")
def home(panda) -> np.ndarray:
    out = np.zeros(len(panda.joint_names))
    out[:7] = PANDA.home_joints
    return out


@pytest.fixture(scope="module")
def designed(panda, home):
    return design_excitation(panda, home, WRIST, iterations=40, seed=1)


def test_the_motion_starts_and_ends_at_home_at_rest(designed, home):
    q, dq, ddq = designed.at(np.array([0.0, designed.period]))
    np.testing.assert_allclose(q, [home, home], atol=1e-12)
    np.testing.assert_allclose(dq, 0.0, atol=1e-12)
    np.testing.assert_allclose(ddq, 0.0, atol=1e-12)


def test_the_motion_keeps_within_the_limits_and_moves_only_the_wrist(panda, designed, home):
    t = np.linspace(0.0, designed.period, 4001)
    q, dq, ddq = designed.at(t)
    limits = panda.joint_limits()
    for k, name in enumerate(panda.joint_names):
        low, high, speed = limits[name]
        assert low <= q[:, k].min() and q[:, k].max() <= high, name
        assert np.abs(dq[:, k]).max() <= speed, name
        if name not in WRIST:
            assert np.all(q[:, k] == home[k])
    assert np.abs(ddq).max() <= 8.0 + 1e-9
    assert np.abs(dq[:, 4:7]).max() > 1.0  # it moves, near its limits


def test_the_design_excites_every_parameter_and_beats_its_start(panda, home, designed):
    start = design_excitation(panda, home, WRIST, iterations=0, seed=1)
    assert np.isfinite(start.log_det) and designed.log_det > start.log_det + 1.0
    assert np.linalg.matrix_rank(excitation_information(panda, designed)) == 16
    again = design_excitation(panda, home, WRIST, iterations=40, seed=1)
    assert again.log_det == designed.log_det  # the same seed, the same motion


def test_an_excitation_is_designed_once_and_read_back_to_the_bit(panda, home, tmp_path):
    from com_core.planning.excitation import cached_excitation

    path = tmp_path / "excitations.json"
    first = cached_excitation(path, panda, home, WRIST, iterations=5, seed=2)
    again = cached_excitation(path, panda, home, WRIST, iterations=5, seed=2)
    assert again.a.tobytes() == first.a.tobytes() and again.b.tobytes() == first.b.tobytes()
    assert again.log_det == first.log_det and again.joints == first.joints
    other = cached_excitation(path, panda, home, WRIST, iterations=5, seed=3)
    assert other.a.tobytes() != first.a.tobytes()
    assert len(__import__("json").loads(path.read_text())["entries"]) == 2


def test_a_faster_motion_keeps_each_joint_within_its_own_bound(panda, home):
    """A bound per joint (the Panda's own limits for its wrist, 15, 20 and 20 rad/s^2,
    over a 2 s period) holds joint by joint, and one of them binds; a bound above an
    arm's published limit is brought down to it, and an arm that states none keeps it."""
    bounds = acceleration_bounds(np.inf, WRIST, PANDA.arm_joints, PANDA.max_joint_acceleration)
    assert bounds == (15.0, 20.0, 20.0)
    assert acceleration_bounds(16.0, WRIST, PANDA.arm_joints, PANDA.max_joint_acceleration) == (
        15.0, 16.0, 16.0)  # fmt: skip
    assert acceleration_bounds(16.0, WRIST, PANDA.arm_joints, ()) == (16.0,) * 3
    fast = design_excitation(panda, home, WRIST, period=2.0, max_acceleration=bounds,
                             iterations=20, seed=1)  # fmt: skip
    ddq = np.abs(fast.at(np.linspace(0.0, fast.period, 4001))[2][:, 4:7]).max(axis=0)
    assert np.all(ddq <= np.array(bounds) + 1e-9), ddq
    assert ddq.max() > 8.0  # beyond the default bound, as asked
