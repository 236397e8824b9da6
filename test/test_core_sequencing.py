"""com_core.sequencing (no ROS): the arm's and the gripper's motion over fake ports, in
milliseconds: what a move sends, when it counts as arrived, the controller's result, the
way back."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PANDA, choreography

from com_core.planning.decisions import GRIPPER_TIME
from com_core.planning.excitation import design_excitation
from com_core.sequencing.errors import RunError, TimeoutRunError
from com_core.sequencing.motion import ArmMotion, excitation_path
from com_core.sequencing.ports import GripperOutcome, JointPath

MS = 1_000_000
HOME, PICK = list(PANDA.home_joints), list(PANDA.pick_joints)


class FakeArm:
    """One world behind every port: the run's clock (1 ms steps), the joint states, a
    trajectory controller that moves the joints linearly to a path's last point, and a
    gripper; ``events`` says what was sent when."""

    def __init__(self, result_error: str = "") -> None:
        self.t = 10_000 * MS
        self.joints = {name: (q, 0.0) for name, q in zip(PANDA.arm_joints, HOME, strict=True)}
        self.events: list[tuple[int, str, object]] = []
        self.result_error = result_error
        self._path: tuple[int, np.ndarray, np.ndarray, int] | None = None  # start, from, to, end
        self._rested = self.t
        self.warnings: list[str] = []

    # RunClock
    def now_ns(self) -> int:
        return self.t

    def wait(self, done, what: str, wall_timeout: float | None) -> None:
        limit = self.t + round((wall_timeout or 60.0) * 1e9)
        while not done():
            if self.t > limit:
                raise TimeoutRunError(f"timed out while {what}")
            self._step()

    def sleep_until(self, stamp_ns: int, what: str) -> None:
        self.wait(lambda: self.t >= stamp_ns, what, None)

    def _step(self) -> None:
        self.t += MS
        if self._path is None:
            return
        start, q0, q1, end = self._path
        share = min(max((self.t - start) / (end - start), 0.0), 1.0)
        speed = 0.0 if share >= 1.0 else 1e9 / (end - start)
        q = q0 + share * (q1 - q0)
        self.joints = {n: (float(v), float(speed * (b - a))) for n, v, a, b in
                       zip(PANDA.arm_joints, q, q0, q1, strict=True)}  # fmt: skip
        if share >= 1.0:
            self._path, self._rested = None, self.t

    # JointFeed
    def rested_since(self, names, resting) -> int | None:
        return self._rested if all(resting(n, *self.joints[n]) for n in names) else None

    # ArmPort
    def send(self, path: JointPath, what: str) -> None:
        self.events.append((self.t, "send", path))
        q0 = np.array([self.joints[n][0] for n in path.names])
        start = max(self.t, path.stamp_ns)
        self._path = (start, q0, np.array(path.points[-1][1]), start + path.duration_ns)

    def finished(self, wall_timeout: float) -> None:
        self.events.append((self.t, "finished", None))
        if self.result_error:
            raise RunError(self.result_error)

    def forget(self) -> None:
        self.events.append((self.t, "forget", None))

    # GripperPort
    def command(self, position: float, max_effort: float, what: str) -> GripperOutcome:
        self.events.append((self.t, "gripper", (position, max_effort, what)))
        closing = position == PANDA.gripper_closed
        return GripperOutcome(0.025 if closing else position, max_effort, closing, not closing)


def arm_motion(world: FakeArm) -> ArmMotion:
    motion = ArmMotion(world, world, PANDA, world.warnings.append)
    motion.arm, motion.gripper_port, motion.motion = world, world, choreography("panda")
    motion.speed, motion.settle = 1.0, 0.3
    return motion


def test_a_move_is_two_points_at_rest_and_the_window_starts_a_settle_after_arrival():
    world = FakeArm()
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
    world = FakeArm()
    motion = arm_motion(world)
    motion.command(PICK, "the object")
    world.sleep_until(world.t + 100 * MS, "moving")
    assert not motion.still()
    motion.command(HOME, "home")
    assert len(world.events[-1][2].points) == 1  # a cubic from the arm's state


def test_a_controller_that_does_not_succeed_ends_the_run_or_is_gone_past_on_the_way_back():
    world = FakeArm(result_error="/arm_controller/follow_joint_trajectory did not succeed")
    motion = arm_motion(world)
    with pytest.raises(RunError, match="did not succeed"):
        motion.move(PICK, "the object")
    world.result_error = "GOAL_TOLERANCE_VIOLATED"
    motion.move(HOME, "home", must_arrive=False)
    assert world.events[-1][1] == "forget" and "going on from where" in world.warnings[-1]


def test_an_arm_that_never_arrives_times_out_or_goes_on_from_where_it_is():
    world = FakeArm()
    motion = arm_motion(world)
    world.send = lambda path, what: world.events.append((world.t, "send", path))  # stuck
    with pytest.raises(TimeoutRunError, match="moving to the object"):
        motion.move(PICK, "the object")
    before = world.t
    assert motion.move(PICK, "the stand", must_arrive=False) > before
    assert "going on from where the arm is" in world.warnings[-1]


def test_putting_back_goes_home_down_opens_and_home_and_the_fingers_take_their_time():
    world = FakeArm()
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
    world = FakeArm()
    arm = arm_motion(world)
    assert arm.follow(excitation, world.t + 50 * MS, "motion/object") == world.t + 2050 * MS
