"""exploration_sequencer node: tare, grasp, tilt (or move), release; one recorded bag per run.

Action ``~/explore`` (com_interfaces/action/Explore) runs one exploration with this
goal's options over the parameters, with feedback (phase, progress as time done over time
planned, time remaining, the estimate so far as windows close) and cancel: the arm puts
back what it holds and goes home, the bag gets a ``cancelled`` label and is closed, the
estimator drops the run's windows, and the result says CANCELLED. Stopping the node
(SIGINT) cancels a running exploration the same way. One goal at a time: a goal with bad
options, or sent while a run goes on, is rejected in the goal callback with an ERROR log
that says why. The service ``~/explore`` (std_srvs/Trigger), for scripts, runs the same
exploration with the parameters and answers with a one-line summary (status, mass, COM,
sigma, predicted sigma, bag path); ``success`` is true only when the estimator's status
is OK (a WARN, e.g. the object moved in the grasp, answers false with the reason). A
second call while one runs is refused.

The run itself (its choreography and decisions) is ``com_core.sequencing.run``; this node
is its wiring: the parameters, the robot configuration (``robot_config``: the parameters
of ``config/<robot>.yaml``, given with ``--params-file``; the Panda's by default) on the
URDF of /robot_description, and the ports' ROS adapters, an arm and a gripper of each
picked per run (``ros_arm``, ``ros_gripper``: ``arm_interface``, ``gripper_interface``),
the pose labels on ``~/pose`` (``ros_labels``), the estimator (``ros_estimator``), the
clock and joint states (``io_node``) and the recorder (``recorder_process``).

Threads: the high-rate subscriptions (joint states, sim clock) live on a second node,
``exploration_sequencer_io`` (``io_node``), spun by an EventsExecutor in the main thread;
this node is spun by a MultiThreadedExecutor in another thread, so a running exploration
(which blocks its service callback) never stalls them. The recorder runs in a process of
its own (``recorder_process``), so nothing this process computes delays it.
"""

from __future__ import annotations

import itertools
import sys
import threading
import time
from datetime import datetime

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String
from std_srvs.srv import Trigger

from com_core.contract import ERROR, EXPLORE_SERVICE, OK, ROBOT_DESCRIPTION_TOPIC
from com_core.inputs import problems
from com_core.planning.run_time import WALL
from com_core.robot.choreography import Choreography
from com_core.robot.config import KEYS, RobotConfig, RobotConfigError, declared_parameters
from com_core.runtime.lifeline import stop_with_parent
from com_core.runtime.rosenv import discovery_line, keep_dds_local, start_refusal, stop_on_signals
from com_core.sequencing.errors import RunError
from com_core.sequencing.run import ExplorationRun, RunOutcome, RunPorts
from com_interfaces.action import Explore
from exploration_sequencer.explore_action import (
    estimator_options,
    feedback_of,
    goal_options,
    result_of,
)
from exploration_sequencer.io_node import IoNode
from exploration_sequencer.parameters import PARAMETERS
from exploration_sequencer.ros_arm import ActionArm, TopicArm
from exploration_sequencer.ros_estimator import EstimatorLink
from exploration_sequencer.ros_gripper import ActionGripper, TopicGripper
from exploration_sequencer.ros_labels import PoseLabels

CANCEL_TIMEOUT = 8.0  # s (wall) a node stopping mid-run gives the way back (SIGINT: 10 s)
FEEDBACK_PERIOD = 0.5  # s (wall) between an action's feedback messages


class SequencerNode(Node):
    """Runs explorations on request; see module."""

    def __init__(self, io: IoNode) -> None:
        # Sim time is the I/O node's (``io.now_ns``): this node keeps no /clock
        # subscription, whose 250 Hz callbacks would only load its executor.
        super().__init__(
            "exploration_sequencer",
            parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, False)],
        )
        self._overrides: dict[str, object] = {}  # the running goal's options (``p``)
        # checked from the first value on: one given at start is refused as a set one is
        self.add_on_set_parameters_callback(self.validate_parameters)
        for row in PARAMETERS.values():
            self.declare_parameter(row.name, row.default, ParameterDescriptor(**row.descriptor()))
        robot = ParameterDescriptor(
            description="robot configuration (robot_config; read at start-up)",
            read_only=True,
            dynamic_typing=True,  # a file's 0 for 0.0
        )
        for name, default in declared_parameters().items():
            self.declare_parameter(name, default, robot)
        self.io = io
        # read-only: one configuration for the node's life
        self.config = RobotConfig.from_parameters({name: self.p(name) for name in KEYS})
        # the ports' adapters, one of each picked per run (arm_interface, gripper_interface)
        self._arms = {"action": ActionArm(self, io, self.config), "topic": TopicArm(self)}
        self._grippers = {"action": ActionGripper(self, io, self.config),
                          "topic": TopicGripper(self)}  # fmt: skip
        self._labels = PoseLabels(self)
        # the choreography on the latest /robot_description, or why there is none
        self._motion: Choreography | str = ""
        self.create_subscription(
            String,
            ROBOT_DESCRIPTION_TOPIC,
            self.robot_description_callback,
            QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )
        self._lock = threading.Lock()  # one run at a time
        self._run_now: ExplorationRun | None = None
        self._goal = None  # the running goal's handle
        self._progress = 0.0  # the running goal's progress as last published
        self._defects = itertools.count(1)  # defects that reached a run's top level
        self._wall_seen: dict[str, float] = dict(WALL)  # s (wall) of own work per phase
        group = ReentrantCallbackGroup()
        self.create_service(Trigger, EXPLORE_SERVICE, self.explore_callback, callback_group=group)
        ActionServer(
            self,
            Explore,
            EXPLORE_SERVICE,
            execute_callback=self.execute_goal,
            goal_callback=self.goal_callback,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=group,
        )
        self.create_timer(FEEDBACK_PERIOD, self.feedback_callback, callback_group=group)
        self.estimator = EstimatorLink(self, io, group, lambda: self.p("sim_timeout"))
        self.get_logger().info("ready: call ~/explore to run an exploration")

    # --- parameters ------------------------------------------------------------------

    def p(self, name: str):
        """The parameter ``name``, or the running goal's option of that name."""
        if name in self._overrides:
            return self._overrides[name]
        return self.get_parameter(name).value

    def validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Refuse a value its row in ``PARAMETERS`` refuses, with the reason."""
        values = {prm.name: prm.value for prm in params if prm.name in PARAMETERS}
        if refused := problems(PARAMETERS, values):
            self.get_logger().error("; ".join(refused))
            return SetParametersResult(successful=False, reason="; ".join(refused))
        return SetParametersResult(successful=True)

    def robot_description_callback(self, msg: String) -> None:
        """The URDF (latched): checked against the robot configuration at once, so a
        frame or joint it lacks is an ERROR when the robot comes up, not at a run."""
        try:
            motion = Choreography.of(self.config, msg.data)
        except (RobotConfigError, ValueError) as exc:
            self._motion = f"the robot cannot run an exploration: {exc}"
            self.get_logger().error(self._motion)
            return
        self._motion = motion
        self.get_logger().info(
            f"robot {motion.robot.model.name!r}: sensor {motion.robot.sensor_frame}, grasp "
            f"centre ({', '.join(f'{1e3 * v:.1f}' for v in motion.pivot)}) mm, "
            f"{len(motion.arm_joints)} arm joints"
        )

    def _choreography(self) -> Choreography:
        """The arm's choreography on the latest /robot_description; RunError naming what
        does not serve."""
        self.io.wait(
            lambda: self._motion,
            f"waiting for {ROBOT_DESCRIPTION_TOPIC}",
            wall_timeout=self.p("sim_timeout"),
        )
        if isinstance(self._motion, str):
            raise RunError(self._motion)
        return self._motion

    # --- the service and the action ------------------------------------------------------

    def explore_callback(self, request: Trigger.Request, response: Trigger.Response):
        outcome = self._run({})
        response.success, response.message = outcome.status == OK, outcome.message
        return response

    def goal_callback(self, goal: Explore.Goal) -> GoalResponse:
        """Reject a goal with bad options, or while an exploration runs, with an ERROR log
        that says why (as a trajectory controller rejects a goal it cannot run)."""
        _, refused = goal_options(goal)
        if (run := self._run_now) is not None:
            refused.append(f"exploration {run.run_id} is still running")
        if refused:
            self.get_logger().error(f"rejected Explore goal: {'; '.join(refused)}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def execute_goal(self, goal_handle) -> Explore.Result:
        """The action: an accepted goal's options over the parameters; the result with
        the estimate, its covariance and the bag."""
        overrides, _ = goal_options(goal_handle.request)
        outcome = self._run(overrides, goal_handle)
        answer = outcome.answer
        values, frame = (answer.values, answer.frame) if answer else ({}, "")
        result = result_of(outcome.status, outcome.message, outcome.bag, values, frame)
        if outcome.status == Explore.Result.CANCELLED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif outcome.status == OK:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def _run(self, overrides: dict[str, object], goal_handle=None) -> RunOutcome:
        """One exploration (``ExplorationRun``) with ``overrides`` over the parameters, on
        the ports its parameters pick. A second one while one runs is refused."""
        if not self._lock.acquire(blocking=False):
            run = self._run_now
            message = f"refused: exploration {run.run_id if run else ''} is still running"
            self.get_logger().warning(message)
            return RunOutcome(ERROR, message)
        try:
            self._overrides = overrides
            self._grippers["action"].timeout = self.p("gripper_timeout")
            ports = RunPorts(
                clock=self.io,
                feed=self.io,
                arm=self._arms[self.p("arm_interface")],
                gripper=self._grippers[self.p("gripper_interface")],
                labels=self._labels,
                recorder=self.io.recorder,
                estimator=self.estimator,
                robot=self._choreography,
                log=self.get_logger(),
            )
            run_id = datetime.now().strftime("%Y%m%d-%H%M%S-%f")[:-3]
            run = ExplorationRun(run_id, self.config, ports, self.p, self._wall_seen,
                                 self._defects, estimator_options(overrides))  # fmt: skip
            self._goal, self._progress, self._run_now = goal_handle, 0.0, run
            return run.execute()
        finally:
            self._run_now, self._goal, self._overrides = None, None, {}
            self._lock.release()

    @property
    def running(self) -> bool:
        return self._run_now is not None

    def cancel_run(self) -> bool:
        """Cancel the running exploration (the node is stopping); False when none runs."""
        run = self._run_now
        if run is None:
            return False
        run.cancel()
        return True

    def feedback_callback(self) -> None:
        """The running goal's feedback; a cancel it asked for stops the run."""
        goal, run = self._goal, self._run_now
        if goal is None or run is None or not goal.is_active:
            return
        if goal.is_cancel_requested:
            run.cancel()
        now, progress = self.io.now_ns(), run.progress
        elapsed = progress.elapsed(now)  # the planning's own time is done time
        feedback = feedback_of(progress.phase or "starting", elapsed, progress.left(now),
                               self.io.live)  # fmt: skip
        if elapsed > 0:  # never back, though a tare check that fails plans a tare pass
            feedback.progress = self._progress = max(feedback.progress, self._progress)
        goal.publish_feedback(feedback)


def _spin_until_shutdown(executor: MultiThreadedExecutor) -> None:
    """Spin; an error once the context is shutting down (SIGINT) just ends the thread."""
    try:
        executor.spin()
    except Exception:
        if rclpy.ok():
            raise


def main(args: list[str] | None = None) -> int:
    keep_dds_local()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    rclpy.logging.get_logger("exploration_sequencer").info(discovery_line())
    stopping = stop_on_signals()
    io = IoNode()
    try:
        node = SequencerNode(io)
    except (RobotConfigError, ParameterException) as error:  # a robot file that cannot serve
        io.get_logger().error(f"exploration_sequencer cannot start: {start_refusal(error)}")
        io.destroy_node()
        rclpy.try_shutdown()
        return 1
    io_executor = EventsExecutor()
    io_executor.add_node(io)
    executor = MultiThreadedExecutor(num_threads=3)
    executor.add_node(node)
    worker = threading.Thread(target=_spin_until_shutdown, args=(executor,), daemon=True)
    worker.start()
    stop_with_parent(node.get_logger().warning)  # SIGINT once the demo that started it ended
    try:
        while rclpy.ok() and not stopping.is_set():
            io_executor.spin_once(timeout_sec=0.1)
        if node.cancel_run():  # stopped mid-run: put back, home, the bag closed
            deadline = time.monotonic() + CANCEL_TIMEOUT
            while node.running and time.monotonic() < deadline and rclpy.ok():
                io_executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    finally:
        # In this order: the context (the service thread ends with it, a running
        # exploration ends: "shutting down"), the recording, the executors, the nodes.
        rclpy.try_shutdown()
        worker.join(timeout=5.0)
        if node._lock.acquire(timeout=10.0):
            node._lock.release()
        io.recorder.close()  # a recording still open is closed first
        executor.shutdown()
        io_executor.shutdown()
        node.destroy_node()
        io.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
