"""The sim's arm controller over ROS: the JointTrajectory topic and the
control_msgs/action/FollowJointTrajectory action, as a Jazzy joint_trajectory_controller
serves them (``wrench_sim.trajectory``, ``wrench_sim.trajectory_goal``).

- A goal is checked in the goal callback (the trajectory as it would run from now: joints,
  points, limits, speeds, stamps) and rejected with an ERROR log naming what is wrong, as
  the controller's ``validate_trajectory_msg`` does.
- An accepted goal replaces the running trajectory (a running goal ends aborted, error code
  INVALID_GOAL, "replaced by a new goal"); so does a trajectory on the topic.
- While it runs, feedback (desired, actual, error) every 50 ms; it ends as
  ``TrajectoryGoal.check`` says, or cancelled on request, the arm held where it is.
"""

from __future__ import annotations

import numpy as np
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from com_core.contract import ARM_COMMAND_TOPIC
from wrench_sim.physics import ArmWorld
from wrench_sim.trajectory_goal import (
    INVALID_GOAL,
    SUCCESSFUL,
    Tolerance,
    TrajectoryGoal,
    tolerances,
)

_FEEDBACK_EVERY = 5  # checks between feedback messages (50 ms at a check per 10 ms)


def _seconds(duration) -> float:
    return duration.sec + 1e-9 * duration.nanosec


def command_of(msg: JointTrajectory) -> dict:
    """The keyword arguments of ``ArmWorld.command_arm`` for ``msg`` (an empty velocities or
    accelerations list: the point carries none)."""
    points = msg.points
    return {
        "joint_names": list(msg.joint_names),
        "times": [_seconds(p.time_from_start) for p in points],
        "positions": [list(p.positions) for p in points],
        "stamp": _seconds(msg.header.stamp),
        "velocities": [list(p.velocities) or None for p in points],
        "accelerations": [list(p.accelerations) or None for p in points],
    }


class ArmController:
    """Serves the arm of ``world`` on ARM_COMMAND_TOPIC and the configuration's
    ``arm_action`` for ``node``; ``track`` (every 10 ms of sim time) ends goals."""

    def __init__(self, node: Node, world: ArmWorld) -> None:
        self._node, self._world = node, world
        robot = world.config.robot
        self._default = Tolerance(robot.goal_tolerance, robot.stopped_velocity_tolerance)
        self._goal: tuple[ServerGoalHandle, TrajectoryGoal, int] | None = None
        self._ended: dict[bytes, tuple[str, int, str]] = {}
        node.create_subscription(JointTrajectory, ARM_COMMAND_TOPIC, self._topic_callback, 10)
        ActionServer(
            node,
            FollowJointTrajectory,
            robot.arm_action,
            execute_callback=self._result,
            goal_callback=self._goal_callback,
            handle_accepted_callback=self._accepted,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
        )

    def _topic_callback(self, msg: JointTrajectory) -> None:
        """Follow a trajectory from the topic now; a malformed one is logged and ignored."""
        try:
            end = self._world.command_arm(**command_of(msg))
        except ValueError as error:
            self._node.get_logger().error(f"rejected joint trajectory: {error}")
            return
        self._end("aborted", INVALID_GOAL, "replaced by a trajectory on the topic")
        self._node.get_logger().info(
            f"following a {len(msg.points)}-point trajectory until t = {end:.3f} s (sim)"
        )

    def _goal_callback(self, goal: FollowJointTrajectory.Goal) -> GoalResponse:
        """Accept a goal whose trajectory the arm can follow from now; else reject it with an
        ERROR log that says why."""
        unknown = [t.name for t in (*goal.path_tolerance, *goal.goal_tolerance)
                   if t.name not in goal.trajectory.joint_names]  # fmt: skip
        try:
            if unknown:
                raise ValueError(f"tolerances for joints the trajectory lacks: {unknown}")
            if goal.multi_dof_trajectory.points:
                raise ValueError("a multi-DOF trajectory (this arm has single-DOF joints only)")
            self._world.plan_arm(**command_of(goal.trajectory))
        except ValueError as error:
            self._node.get_logger().error(f"rejected trajectory goal: {error}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _accepted(self, handle: ServerGoalHandle) -> None:
        """Run the goal's trajectory now; a running goal ends aborted."""
        goal = handle.request
        self._end("aborted", INVALID_GOAL, "replaced by a new goal")
        try:
            end = self._world.command_arm(**command_of(goal.trajectory))
        except ValueError as error:  # the world moved on since the goal callback
            self._finish(handle, "aborted", INVALID_GOAL, str(error))
            return
        names = self._world.config.robot.arm_joints

        def given(items) -> dict[str, tuple[float, float]]:
            return {t.name: (t.position, t.velocity) for t in items}

        self._goal = (
            handle,
            TrajectoryGoal(
                names,
                end,
                tolerances(names, given(goal.path_tolerance), Tolerance()),
                tolerances(names, given(goal.goal_tolerance), self._default),
                _seconds(goal.goal_time_tolerance),
            ),
            0,
        )
        self._node.get_logger().info(
            f"trajectory goal: {len(goal.trajectory.points)} points until t = {end:.3f} s (sim)"
        )

    def track(self) -> None:
        """Check the running goal: feedback, its end, or its cancellation."""
        if self._goal is None:
            return
        handle, goal, checks = self._goal
        world = self._world
        desired, _ = world.arm_set_point
        positions, velocities = (np.array(x[: len(goal.names)]) for x in world.joint_state()[1:3])
        if handle.is_cancel_requested:
            world.hold_arm()
            self._end("canceled", SUCCESSFUL, "cancelled")
            return
        ended = goal.check(world.time, desired, positions, velocities, world.arm_final)
        if ended is not None:
            code, text = ended
            if code != SUCCESSFUL:
                world.hold_arm()
            self._end("succeeded" if code == SUCCESSFUL else "aborted", code, text)
            return
        if checks % _FEEDBACK_EVERY == 0:
            feedback = FollowJointTrajectory.Feedback(joint_names=list(goal.names))
            feedback.header.stamp.sec, feedback.header.stamp.nanosec = divmod(
                world.time_ns, 1_000_000_000
            )
            feedback.desired = JointTrajectoryPoint(positions=desired.tolist())
            feedback.actual = JointTrajectoryPoint(
                positions=positions.tolist(), velocities=velocities.tolist()
            )
            feedback.error = JointTrajectoryPoint(positions=(positions - desired).tolist())
            handle.publish_feedback(feedback)
        self._goal = (handle, goal, checks + 1)

    def _end(self, how: str, code: int, text: str) -> None:
        """End the running goal (if any) ``how`` (succeeded, aborted, canceled) with
        ``code`` and ``text``; its result goes out at the next spin."""
        if self._goal is None:
            return
        handle, _, _ = self._goal
        self._goal = None
        self._finish(handle, how, code, text)

    def _finish(self, handle: ServerGoalHandle, how: str, code: int, text: str) -> None:
        """End ``handle``'s goal ``how`` with ``code`` and ``text`` (logged)."""
        self._ended[bytes(handle.goal_id.uuid)] = (how, code, text)
        handle.execute()  # runs _result
        log = self._node.get_logger()
        line = f"trajectory goal {how}{f': {text}' if text else ''}"
        if how == "aborted" and code != INVALID_GOAL:
            log.error(line)
        else:
            log.info(line)

    def _result(self, handle: ServerGoalHandle) -> FollowJointTrajectory.Result:
        """The ended goal's terminal state and result (``_end``)."""
        how, code, text = self._ended.pop(bytes(handle.goal_id.uuid))
        {"succeeded": handle.succeed, "aborted": handle.abort, "canceled": handle.canceled}[how]()
        return FollowJointTrajectory.Result(error_code=code, error_string=text)
