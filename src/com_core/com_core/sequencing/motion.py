"""The arm and its gripper as a run moves them, over ports (``sequencing.ports``; no ROS):
smooth moves to joint goals, arrival and settling, the fingers, in the run's time.

The arm's joints and gripper are its robot configuration's, its motion times its
choreography's (``motion``; the URDF's velocity limits). A move is a joint path a
joint_trajectory_controller runs as planned: two points with zero velocities and
accelerations, where the arm rests now (time 0) and the goal, which the controller joins by
one quintic (when the arm is still moving, the goal alone, joined by a cubic from its
state); its duration follows from the joint distance and ``speed``
(``Choreography.motion_time``). A move starts when it is sent: none is sent while a window
is open. An excitation is sent ahead, stamped to start later: its first point is home at
rest, so the arm holds still until then.

The arm rests at a goal when every joint is within the configuration's ``goal_tolerance``
of it and slower than its ``stopped_velocity_tolerance``; a window starts ``settle`` s
after the joint states first show it resting there, and the controller's result is checked
then (it came while the arm settled).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from com_core.planning.decisions import GRIPPER_TIME
from com_core.planning.excitation import Excitation
from com_core.robot.choreography import Choreography
from com_core.robot.config import RobotConfig
from com_core.sequencing.errors import RunError
from com_core.sequencing.ports import (
    ArmPort,
    GripperOutcome,
    GripperPort,
    JointFeed,
    JointPath,
    RunClock,
)

__all__ = ["ArmMotion", "excitation_path", "move_path", "resting"]


def resting(
    joints: Mapping[str, tuple[float, float]],
    names: Sequence[str],
    goal: Sequence[float],
    config: RobotConfig,
) -> bool:
    """The joints ``names`` (position rad, speed rad/s) are within ``config``'s
    goal_tolerance of ``goal`` and slower than its stopped_velocity_tolerance."""
    return all(
        abs(joints[j][0] - g) < config.goal_tolerance
        and abs(joints[j][1]) < config.stopped_velocity_tolerance
        for j, g in zip(names, goal, strict=True)
    )


def move_path(
    names: Sequence[str], start: Sequence[float] | None, goal: Sequence[float], duration: float
) -> JointPath:
    """A rest-to-rest move of the joints ``names`` to ``goal`` (rad) in ``duration`` s: from
    ``start`` at time 0 (one quintic), or with ``start`` None the goal alone (a cubic from
    the arm's state); zero velocities and accelerations at each point."""
    rest = (0.0,) * len(names)
    points = [] if start is None else [(0.0, tuple(map(float, start)), rest, rest)]
    points.append((duration, tuple(map(float, goal)), rest, rest))
    return JointPath(tuple(names), tuple(points))


def excitation_path(excitation: Excitation, names: Sequence[str], start_ns: int = 0) -> JointPath:
    """``excitation`` as a path of the joints ``names`` from ``start_ns`` (0: when the
    controller receives it): its waypoints with their velocities and accelerations
    (``Excitation.waypoints``), the first at home at rest at its start (the arm holds still
    until then), the last at its end."""
    times, q, dq, ddq = excitation.waypoints(names)
    rows = zip(times.tolist(), q.tolist(), dq.tolist(), ddq.tolist(), strict=True)
    return JointPath(tuple(names), tuple(rows), start_ns)


class ArmMotion:
    """Moves the arm and the gripper of ``config`` through the ports ``arm`` and
    ``gripper`` (the sequencer sets them, with ``motion`` (the choreography), ``speed``
    (rad/s, mean joint speed), ``settle`` (s to wait after arriving) and ``max_effort``
    (N), for each run), timed by ``clock``, watching ``feed``; ``warn`` says what the run
    goes on past."""

    def __init__(
        self,
        clock: RunClock,
        feed: JointFeed,
        config: RobotConfig,
        warn: Callable[[str], None],
    ) -> None:
        self._clock, self._feed, self.config, self._warn = clock, feed, config, warn
        self.arm: ArmPort | None = None
        self.gripper_port: GripperPort | None = None
        self.motion: Choreography | None = None
        self.speed = 1.0
        self.settle = 0.3
        self.max_effort = 20.0

    def gripper_closed(self) -> float:
        """How far the gripper is closed, 0 open .. 1 closed: its most closed joint (a
        joint not reported counts as open)."""
        config, joints = self.config, self._feed.joints
        return max(
            config.gripper_closed_fraction(joints.get(j, (config.gripper_open, 0.0))[0])
            for j in config.gripper_joints
        )

    def at(self, goal: Sequence[float]) -> bool:
        """The arm rests at ``goal`` now."""
        return resting(self._feed.joints, self.config.arm_joints, goal, self.config)

    def still(self) -> bool:
        """Every arm joint is slower than the stopped_velocity_tolerance now."""
        limit, joints = self.config.stopped_velocity_tolerance, self._feed.joints
        return all(abs(joints[j][1]) < limit for j in self.config.arm_joints)

    def move(self, goal: Sequence[float], what: str, must_arrive: bool = True) -> int:
        """Move to ``goal`` (rad) now and wait until the arm has rested there ``settle`` s;
        returns that time, ns. See ``arrive`` for ``must_arrive``."""
        if self.at(goal):
            return self._clock.now_ns()
        return self.arrive(goal, what, self.command(goal, what), must_arrive)

    def command(self, goal: Sequence[float], what: str) -> int:
        """Send a smooth move to ``goal`` (rad), starting now (``move_path``); returns the
        time (ns) at which it is planned to end."""
        names = self.config.arm_joints
        here = [self._feed.joints[j][0] for j in names]
        assert self.motion is not None and self.arm is not None, "set for the run"
        duration = self.motion.motion_time(here, goal, self.speed)
        path = move_path(names, here if self.still() else None, goal, duration)
        now = self._clock.now_ns()
        self.arm.send(path, f"moving to {what}")
        return now + path.duration_ns

    def follow(self, excitation: Excitation, start_ns: int, what: str) -> int:
        """Send ``excitation`` (a periodic motion from home back to home; the arm rests at
        home) to start at ``start_ns`` (``excitation_path``); returns the time (ns) it
        ends. ``finished`` checks its result."""
        assert self.arm is not None, "set for the run"
        path = excitation_path(excitation, self.config.arm_joints, start_ns)
        self.arm.send(path, what)
        return start_ns + path.duration_ns

    def finished(self, wall_timeout: float) -> None:
        """The last path's result (``ArmPort.finished``)."""
        assert self.arm is not None, "set for the run"
        self.arm.finished(wall_timeout)

    def arrive(
        self, goal: Sequence[float], what: str, arrival_ns: int, must_arrive: bool = True
    ) -> int:
        """Wait until the arm rests at ``goal`` and ``settle`` s more, counted from the
        first joint state that shows it resting (however late this run notices) and no
        earlier than ``arrival_ns``, the move's planned end; then the controller's result.
        Returns the end of ``settle``, ns.

        The wait ends 5 s + twice the time to ``arrival_ns`` after the call (wall; a sim
        runs at least real time); then TimeoutRunError, or with ``must_arrive`` False a
        warning and the arm stays where it is (so too for a result other than success).
        """
        clock, config = self._clock, self.config
        timeout = 5.0 + 2.0 * max(arrival_ns - clock.now_ns(), 0) * 1e-9
        try:
            clock.wait(lambda: self.at(goal), f"moving to {what}", timeout)
        except RunError as exc:
            return self._gone_on(exc, must_arrive)
        target = dict(zip(config.arm_joints, goal, strict=True))

        def still(name: str, position: float, velocity: float) -> bool:
            return (abs(position - target[name]) < config.goal_tolerance
                    and abs(velocity) < config.stopped_velocity_tolerance)  # fmt: skip

        # each joint by its own joint states: a gripper's publisher does not count
        rested = self._feed.rested_since(config.arm_joints, still)
        if rested is None:  # moved again since the wait saw it resting
            rested = clock.now_ns()
        # never before the move's planned end: a move smaller than the rest tolerance
        # looks resting at its goal before it has begun
        ready = max(rested, arrival_ns) + round(self.settle * 1e9)
        clock.sleep_until(ready, f"settling at {what}")
        try:  # its result came while the arm settled: no wait on the run's path
            self.finished(timeout)
        except RunError as exc:
            self._gone_on(exc, must_arrive)
        return ready

    def _gone_on(self, error: RunError, must_arrive: bool) -> int:
        """``error`` raised, or with ``must_arrive`` False warned of; then the time now."""
        if must_arrive:
            raise error
        assert self.arm is not None
        self.arm.forget()
        self._warn(f"{error}: going on from where the arm is")
        return self._clock.now_ns()

    def come_to_rest(self, wall_timeout: float = 10.0) -> None:
        """Wait until the arm's joints are slower than the stopped_velocity_tolerance (a
        move under way ends where it was going): a new move starts from rest, as every move
        is planned."""
        if self.arm is not None:
            self.arm.forget()
        self._clock.wait(self.still, "the arm coming to rest", wall_timeout)

    def gripper(self, close: bool, wait: float = 0.0) -> GripperOutcome | None:
        """Close (or open) the gripper: its port's outcome (None from a topic), and no
        earlier than ``wait`` s after the command (the fingers' time in the run's plan)."""
        assert self.gripper_port is not None, "set for the run"
        position = self.config.gripper_closed if close else self.config.gripper_open
        until = self._clock.now_ns() + round(wait * 1e9)
        outcome = self.gripper_port.command(
            float(position), float(self.max_effort), "closing" if close else "opening"
        )
        self._clock.sleep_until(until, "moving the fingers")
        return outcome

    def put_back(self, home: Sequence[float], pick: Sequence[float]) -> None:
        """Carry what the hand holds home, down to the stand, open, and back home."""
        self.move(home, "home")
        self.move(pick, "the stand", must_arrive=False)  # a shifted object may hit it
        self.gripper(close=False, wait=GRIPPER_TIME)
        self.move(home, "home")
