"""com_core.sequencing (no ROS): the arm's and the gripper's motion over fake ports
(``fake_robot``), in milliseconds: what a move sends, when it counts as arrived, the
controller's result, the way back."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import PANDA, choreography
from fake_robot import HOME, MS, PICK, FakeWorld

from com_core.planning.decisions import GRIPPER_TIME
from com_core.planning.excitation import design_excitation
from com_core.sequencing.errors import RunError, TimeoutRunError
from com_core.sequencing.motion import ArmMotion, excitation_path


def arm_motion(world: FakeWorld) -> ArmMotion:
    motion = ArmMotion(world, world, PANDA, world.warnings.append)
    motion.arm, motion.gripper_port, motion.motion = world, world, choreography("panda")
    motion.speed, motion.settle = 1.0, 0.3
    return motion


def test_a_move_is_two_points_at_rest_and_the_window_starts_a_settle_after_arrival():
    world = FakeWorld()
    motion = arm_motion(world)
    sent_at = world.t
    ready = motion.move(PICK, "the object")
    (t, kind, path), (t_done, done, _) = world.events
    assert (t, kind, done) == (sent_at, "send", "finished")
    assert path.stamp_ns == 0 and len(path.points) == 2  # from where it rests: one quintic
    (t0, q0, v0, a0), (t1, q1, v1, a1) = path.points
    assert t0 == 0.0 and list(q0) == pytest.approx(HOME) and list(q1) == PICK
    assert not any(v0) and not any(a0) and not any(v1) and not any(a1)
    duration = choreography("panda").motion_time(HOME, PICK, 1.0)
    assert t1 == duration
    arrived = sent_at + path.duration_ns  # the fake arrives on time, to the ms
    assert ready == pytest.approx(arrived + 300 * MS, abs=2 * MS)
    assert t_done == ready  # the result is read after the settle, off the run's path
    assert motion.move(PICK, "the object") == world.t and len(world.events) == 2  # there


def test_a_move_while_the_arm_moves_is_its_goal_alone():
    world = FakeWorld()
    motion = arm_motion(world)
    motion.command(PICK, "the object")
    world.sleep_until(world.t + 100 * MS, "moving")
    assert not motion.still()
    motion.command(HOME, "home")
    assert len(world.events[-1][2].points) == 1  # a cubic from the arm's state


def test_a_controller_that_does_not_succeed_ends_the_run_or_is_gone_past_on_the_way_back():
    world = FakeWorld(result_error="/arm_controller/follow_joint_trajectory did not succeed")
    motion = arm_motion(world)
    with pytest.raises(RunError, match="did not succeed"):
        motion.move(PICK, "the object")
    world.result_error = "GOAL_TOLERANCE_VIOLATED"
    motion.move(HOME, "home", must_arrive=False)
    assert world.events[-1][1] == "forget" and "going on from where" in world.warnings[-1]


def test_an_arm_that_never_arrives_times_out_or_goes_on_from_where_it_is():
    world = FakeWorld()
    motion = arm_motion(world)
    world.send = lambda path, what: world.events.append((world.t, "send", path))  # stuck
    with pytest.raises(TimeoutRunError, match="moving to the object"):
        motion.move(PICK, "the object")
    before = world.t
    assert motion.move(PICK, "the stand", must_arrive=False) > before
    assert "going on from where the arm is" in world.warnings[-1]


def test_putting_back_goes_home_down_opens_and_home_and_the_fingers_take_their_time():
    world = FakeWorld()
    motion = arm_motion(world)
    motion.move(PICK, "the object")
    closed = motion.gripper(close=True, wait=GRIPPER_TIME)
    assert closed.stalled and not closed.reached_goal
    start = world.t
    motion.put_back(HOME, PICK)
    kinds = [(kind, value) for _, kind, value in world.events if kind in ("send", "gripper")]
    goals = [list(v.points[-1][1]) if k == "send" else ("gripper", v[0]) for k, v in kinds]
    assert goals[-4:] == [HOME, PICK, ("gripper", PANDA.gripper_open), HOME]
    opened = next(t for t, kind, v in world.events if kind == "gripper" and t > start)
    after = next(t for t, kind, _ in world.events if kind == "send" and t > opened)
    assert after - opened >= GRIPPER_TIME * 1e9  # the fingers' time before the arm goes


def test_an_excitation_starts_at_home_at_rest_at_its_stamp():
    motion = choreography("panda")
    home = [motion.home_positions()[name] for name in motion.robot.joint_names]
    excitation = design_excitation(motion.robot, home, PANDA.arm_joints[-3:], period=2.0,
                                   iterations=3, seed=0)  # fmt: skip
    path = excitation_path(excitation, PANDA.arm_joints, 7 * MS)
    t0, q0, v0, a0 = path.points[0]
    assert path.stamp_ns == 7 * MS and t0 == 0.0 and path.duration_ns == 2_000 * MS
    assert q0 == pytest.approx(HOME, abs=1e-12)
    assert np.abs(v0).max() < 1e-12 and np.abs(a0).max() < 1e-12
    world = FakeWorld()
    arm = arm_motion(world)
    assert arm.follow(excitation, world.t + 50 * MS, "motion/object") == world.t + 2050 * MS
    # three cycles: three periods, through home at rest after each, the first one's points
    cycled = excitation_path(replace(excitation, cycles=3), PANDA.arm_joints, 7 * MS)
    assert cycled.duration_ns == 6_000 * MS and cycled.points[: len(path.points)] == path.points
    for k in (1, 2, 3):
        _, q, v, a = next(p for p in cycled.points if p[0] == pytest.approx(2.0 * k))
        assert q == pytest.approx(HOME, abs=1e-9) and np.abs([*v, *a]).max() < 1e-9
