"""exploration_sequencer node: tare, grasp, tilt (or move), release; one recorded bag per run.

Action ``~/explore`` (com_interfaces/action/Explore) runs one exploration with this
goal's options over the parameters, with feedback (phase, progress as time done over time
planned, time remaining, the estimate so far as windows close) and cancel: the arm puts
back what it holds and goes home, the bag gets a ``cancelled`` label and is closed, the
estimator drops the run's windows, and the result says CANCELLED. Stopping the node
(SIGINT) cancels a running exploration the same way. One goal at a time: another one is
answered ERROR with the reason. The service ``~/explore`` (std_srvs/Trigger), for
scripts, runs the same exploration with the parameters and answers with a one-line
summary (status, mass, COM, sigma, predicted sigma, bag path); ``success`` is true only
when the estimator's status is OK (a WARN, e.g. the object moved in the grasp, answers
false with the reason). A second call while one runs is refused. Each run starts from a
known state: the estimator is reset, an arm that holds something (fingers closed) puts
it back on the stand first, an arm away from home goes home; and the grasp must hold a
load before the object pass (closed through the gripper's GripperCommand action, its
result must show the fingers stalled on the object, ``arm``). Pose labels go out on
``~/pose`` (std_msgs/Header:
frame_id = label, stamp = the sim time from which it applies; reliable, transient local,
depth 1) only once the arm has settled; each label waits for every reader's
acknowledgement before the next goes out, so a reader that falls behind (a starved
process) is late, never without a label.
The arm is the robot configuration's (``robot_config``: the parameters of
``config/<robot>.yaml``, given with ``--params-file``; the Panda's by default) on the URDF of
/robot_description: each pose is solved for its joints (``com_core.robot.choreography``)
before anything moves, and a tilt the arm cannot reach is lowered to the largest it reaches
(logged as a plan change) or the run is refused. What a run decides (its plan, the noise it
plans for, the tare's reuse, the grasp's load) is ``com_core.planning.decisions``.
Every run is recorded to ``<bag_dir>/<run-id>/`` (rosbag2, MCAP) with a PNG report.
With ``excitation: motion`` the tilts held still are replaced by a designed wrist motion
(``_explore_in_motion``; docs/design.md, Identification in motion).

Threads: the high-rate subscriptions (joint states, sim clock) live on a second node,
``exploration_sequencer_io`` (``io_node``), spun by an EventsExecutor in the main thread;
this node is spun by a MultiThreadedExecutor in another thread, so a running exploration
(which blocks its service callback) never stalls them. The recorder runs in a process of
its own (``recorder_process``), so nothing this process computes delays it. The arm's
motion is ``arm``; the estimation is the estimator's (and ``com_core``'s).
"""

from __future__ import annotations

import contextlib
import math
import sys
import threading
import time
import traceback
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Header, String
from std_srvs.srv import Trigger

from com_core.bags.cdr import decode_wrench_batch
from com_core.contract import (
    CANCELLED,
    DONE,
    ERROR,
    EXPLORE_SERVICE,
    INTERNAL_ERROR,
    JOINT_STATES_TOPIC,
    MOTION_OBJECT,
    MOTION_TARE,
    MOTION_VERIFY,
    MOVING,
    OBJECT_PREFIX,
    OK,
    POSE_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    STATIC_PREFIXES,
    TARE_PREFIX,
    VERIFY_PREFIX,
    WRENCH_TOPIC,
    status_of,
)
from com_core.estimation.exploration import Exploration
from com_core.estimation.fits import WRENCHES
from com_core.estimation.hand_motion import (
    HAND_MOTION_FILE,
    HandMotion,
    hand_motion_path,
    load_hand_motion,
    save_hand_motion,
)
from com_core.estimation.motion_solution import MOTION
from com_core.estimation.settings import (
    BAG_SETTINGS_FILE,
    SETTINGS,
    write_bag_settings,
)
from com_core.estimation.solution import noise_line, vector_value, verification_lines
from com_core.estimation.tare_cache import (
    BAG_TARE_FILE,
    save_tares,
    tare_signature,
    use_tares,
)
from com_core.estimation.windows import Window
from com_core.inputs import problems, unwritable
from com_core.planning.decisions import (
    BIAS_AFTER_SUFFIX,
    BIAS_WINDOW_SUFFIX,
    GRIPPER_TIME,
    PlanInfeasible,
    Poses,
    RunSettings,
    bag_room_refusal,
    cached_tare,
    closing_problem,
    complete_tare_pass,
    estimator_calibration,
    free_room,
    grasp_holds,
    held_mass,
    may_hold_object,
    newest_hand_model,
    plan_within_reach,
    planning_noise,
    predicted_run,
    tare_cache_path,
    tare_decision,
    tare_reuse,
)
from com_core.planning.excitation import Excitation, cached_excitation
from com_core.planning.planner import HOME, Plan
from com_core.planning.prediction import Prediction
from com_core.planning.run_time import (
    ESTIMATE,
    GRASP,
    OBJECT_MOTION,
    OBJECT_PASS,
    RETURN,
    TARE,
    VERIFICATION,
    WALL,
    PhaseTime,
    motion_run_phases,
    static_run_phases,
    time_left,
)
from com_core.report import RunData, read_run, write_report
from com_core.robot.choreography import VERIFY_POSE, Choreography
from com_core.robot.config import (
    BAG_ROBOT_FILE,
    KEYS,
    RobotConfig,
    RobotConfigError,
    default_robot_config,
    write_robot_config,
)
from com_core.runtime.lifeline import stop_with_parent
from com_core.runtime.rosenv import discovery_line, keep_dds_local, start_refusal, stop_on_signals
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import NoiseModel
from com_core.sequencing.errors import (
    CancelledRunError,
    RecordingError,
    RunError,
    TimeoutRunError,
)
from com_core.sequencing.motion import ArmMotion
from com_interfaces.action import Explore
from exploration_sequencer.explore_action import feedback_of, goal_options, result_of
from exploration_sequencer.io_node import IoNode
from exploration_sequencer.parameters import PARAMETERS
from exploration_sequencer.ros_arm import ActionArm, TopicArm
from exploration_sequencer.ros_estimator import EstimatorLink
from exploration_sequencer.ros_gripper import ActionGripper, TopicGripper

CANCEL_TIMEOUT = 8.0  # s (wall) a node stopping mid-run gives the way back (SIGINT: 10 s)
FEEDBACK_PERIOD = 0.5  # s (wall) between an action's feedback messages
LABEL_ACK_TIMEOUT = 10.0  # s (wall) a pose label waits for its readers' acknowledgement
EXCITATION_LEAD = 0.5  # s (sim) between sending an excitation and its start: the arm holds
# still at its first point until then; a stamp the controller gets late would jump the arm
EXCITATION_REST = 0.3  # s (sim) at rest after an excitation, within its span
EXCITATION_CACHE = "excitation_cache.json"  # beside the tare cache
VERIFY_ITERATIONS = 40  # the verification's motion needs no optimum, only another motion
CLOCKS_APART = 3600 * 10**9  # ns between the sensor's stamps and this clock: two clocks


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
        for name, default in default_robot_config().parameters().items():
            self.declare_parameter(name, default, robot)
        self.io = io
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.pose_pub = self.create_publisher(Header, POSE_TOPIC, latched)  # the current label
        # read-only: one configuration for the node's life
        self.config = RobotConfig.from_parameters({name: self.p(name) for name in KEYS})
        self.arm = ArmMotion(io, io, self.config, self.get_logger().warning)
        # the ports' adapters, one of each picked per run (arm_interface, gripper_interface)
        self._arms = {"action": ActionArm(self, io, self.config), "topic": TopicArm(self)}
        self._grippers = {"action": ActionGripper(self, io, self.config),
                          "topic": TopicGripper(self)}  # fmt: skip
        # the choreography on the latest /robot_description, or why there is none
        self._motion: Choreography | str = ""
        self.create_subscription(
            String,
            ROBOT_DESCRIPTION_TOPIC,
            self.robot_description_callback,
            QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )
        self._lock = threading.Lock()
        self._cancel_lock = threading.Lock()  # a cancel, and the way back from one
        self._running: str | None = None
        self.internal_errors = 0  # defects that reached a run's top level (INTERNAL_ERROR)
        self._labels: list[tuple[int, str]] = []  # this run's labels
        # each window's middle (s, sim time) and mean joint positions (rad, m), by label:
        # a tare window's are cached with it
        self._window_seen: dict[str, tuple[float, dict[str, float]]] = {}
        group = ReentrantCallbackGroup()
        self.create_service(Trigger, EXPLORE_SERVICE, self.explore_callback, callback_group=group)
        self._status: DiagnosticStatus | None = None  # the estimator's answer to the run
        self._bag: Path | None = None
        self._goal = None  # the running goal's handle
        self._phase = ""
        self._start_ns, self._planned_s = 0, math.inf  # the run's start (sim ns), plan (s)
        self._goal_ns = 0  # sim ns: when the run began to plan (its progress counts from it)
        self._recording_failed = False  # the recorder's failure was raised once
        self._recording_ns = 0  # sim time (ns) at which the run's recording started
        self._phases: tuple[PhaseTime, ...] = ()  # the run's phases as planned
        self._current, self._phase_ns = -1, 0  # the phase under way (index), its start (sim ns)
        self._clock_mark = (0.0, 0)  # (wall s, sim ns) when the run first read the clock
        self._rate = 1.0  # sim s per wall s, as measured when the phases were planned
        self._wall_seen: dict[str, float] = dict(WALL)  # s (wall) of own work per phase
        self._progress = 0.0  # the run's progress as last published
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

    def settings(self) -> RunSettings:
        """The run's settings, from the parameters."""
        return RunSettings.from_parameters(self.p)

    def _planned(
        self,
        settings: RunSettings,
        noise: NoiseModel,
        method: str,
        information: str,
        bias_drift_rate: tuple[float, ...],
        motion: Choreography,
        calibration: Calibration | None = None,
    ) -> tuple[Plan, Poses, Prediction]:
        """The plan of ``settings``, the joints of its poses and its prediction
        (``plan_within_reach``, ``predicted_run``), each pose refused and each change
        logged. RunError when no plan is feasible (the reason says what would be)."""
        try:
            planned = plan_within_reach(settings, motion, noise, calibration, bias_drift_rate)
            for refusal in planned.refusals:
                self.get_logger().warning(f"refused before moving: {refusal}")
            planned, prediction = predicted_run(planned, settings, motion, method, information)
        except PlanInfeasible as exc:
            raise RunError(str(exc)) from exc
        for change in planned.changes:
            self.get_logger().warning(f"plan changed: {change}")
        return planned.plan, planned.poses, prediction

    def _cache_path(self) -> Path:
        return tare_cache_path(self.p("tare_cache"), self.p("bag_dir"))

    def planning_noise(self, settings: RunSettings) -> tuple[NoiseModel, str]:
        """(the sensor's noise to plan for, where it comes from): ``planning_noise`` of
        the newest tare pass of this hand in the tare cache."""
        cache = newest_hand_model(self._cache_path(), self.p("hand_id"))
        return planning_noise(cache, settings)

    # --- the service ---------------------------------------------------------------------

    def explore_callback(self, request: Trigger.Request, response: Trigger.Response):
        status, response.message = self._run({})
        response.success = status == OK
        return response

    def goal_callback(self, goal: Explore.Goal) -> GoalResponse:
        """Reject a goal with bad options, or while an exploration runs, with an ERROR log
        that says why (as a trajectory controller rejects a goal it cannot run)."""
        _, problems = goal_options(goal)
        if self.running:
            problems.append(f"exploration {self._running} is still running")
        if problems:
            self.get_logger().error(f"rejected Explore goal: {'; '.join(problems)}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def execute_goal(self, goal_handle) -> Explore.Result:
        """The action: an accepted goal's options over the parameters; the result with
        the estimate, its covariance and the bag."""
        overrides, _ = goal_options(goal_handle.request)
        status, message = self._run(overrides, goal_handle)
        values = {kv.key: kv.value for kv in self._status.values} if self._status else {}
        frame = self._status.hardware_id if self._status else ""
        result = result_of(status, message, self._bag, values, frame)
        if status == Explore.Result.CANCELLED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif status == OK:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def _run(self, overrides: dict[str, object], goal_handle=None) -> tuple[str, str]:
        """One exploration with ``overrides`` over the parameters; (status: OK, WARN,
        ERROR or CANCELLED, the summary). A second one while one runs is refused."""
        if not self._lock.acquire(blocking=False):
            message = f"refused: exploration {self._running} is still running"
            self.get_logger().warning(message)
            return ERROR, message
        run_id = datetime.now().strftime("%Y%m%d-%H%M%S-%f")[:-3]
        self._running, self._overrides, self._goal = run_id, overrides, goal_handle
        self._status, self._bag = None, None
        self._start_ns, self._planned_s = 0, math.inf  # no progress before the plan
        self.io.cancel.clear()
        try:
            success, message = self.explore(run_id)
            status = OK if success else status_of(self._status.level) if self._status else ERROR
        except CancelledRunError as exc:
            status, message = Explore.Result.CANCELLED, self._cancel(run_id, str(exc))
        except RecordingError as exc:  # the bag so far closed, the arm back
            status, message = ERROR, f"run {run_id} failed: {exc}"
            self.get_logger().error(message)
            self._label(self.io.now_ns(), MOVING)
            self._go_back(run_id, "after the recording stopped")
            self._stop_recording()
        except RunError as exc:
            status, message = ERROR, f"run {run_id} failed: {exc}"
            self.get_logger().error(message)
            self._stop_recording()
        except Exception as exc:  # a defect: the call fails, the node lives
            self.internal_errors += 1
            status = ERROR
            message = f"run {run_id} failed: {INTERNAL_ERROR} #{self.internal_errors} {exc!r}"
            self.get_logger().error(f"{message}\n{traceback.format_exc()}")
            self._stop_recording()
        finally:
            self.estimator.restore()
            self._running, self._overrides, self._goal = None, {}, None
            self._phase = ""
            self.io.cancel.clear()
            self._lock.release()
        return status, message

    @property
    def running(self) -> bool:
        return self._running is not None

    def cancel_run(self) -> bool:
        """Cancel the running exploration (the node is stopping); False when none runs."""
        if self._running is None:
            return False
        with self._cancel_lock:
            if self._phase != "cancelling":
                self.io.cancel.set()
        return True

    def _cancel(self, run_id: str, why: str) -> str:
        """After a cancel: the run's windows dropped (a ``cancelled`` label), the object
        put back and the arm home, the bag closed; the summary."""
        log = self.get_logger()
        log.warning(f"run {run_id}: {why}")
        with self._cancel_lock:  # the way back must move: no cancel from here on
            self._phase = "cancelling"
            self.io.cancel.clear()
        self._label(self.io.now_ns(), CANCELLED)
        self._label(self.io.now_ns(), MOVING)
        self._go_back(run_id, "after the cancel")
        self._stop_recording()
        bag = f"; bag {self._bag}" if self._bag else ""
        return f"[CANCELLED] run {run_id} cancelled: {why}{bag}"

    def _go_back(self, run_id: str, when: str) -> None:
        """The object put back and the arm home (nothing when nothing moved yet); a way
        back that fails is logged."""
        try:
            if self.arm.motion is not None:
                self.arm.come_to_rest()
                home, pick = list(self.config.home_joints), list(self.config.pick_joints)
                self._to_known_state(home, pick, when)
        except RunError as exc:
            self.get_logger().error(f"run {run_id}: not back home {when}: {exc}")

    def feedback_callback(self) -> None:
        """The running goal's feedback; a cancel it asked for stops the run."""
        goal = self._goal
        if goal is None or not goal.is_active:
            return
        with self._cancel_lock:
            if goal.is_cancel_requested and self._phase != "cancelling":
                self.io.cancel.set()
        now = self.io.now_ns()
        # from the run's start, once it has a plan: the planning's own time is done time
        elapsed = (now - self._goal_ns) * 1e-9 if self._start_ns else 0.0
        feedback = feedback_of(self._phase or "starting", elapsed, self._left(now), self.io.live)
        if elapsed > 0:  # never back, though a tare check that fails plans a tare pass
            feedback.progress = self._progress = max(feedback.progress, self._progress)
        goal.publish_feedback(feedback)

    def _left(self, now_ns: int) -> float:
        """s (sim) the run has left at ``now_ns`` (sim): ``time_left`` of its phases from
        the current one's start, at the sim's rate measured when they were planned
        (before the run has phases, what ``_start_bag`` planned)."""
        if not self._phases:
            return self._planned_s - (now_ns - self._start_ns) * 1e-9
        in_phase = (now_ns - self._phase_ns) * 1e-9 if self._current >= 0 else 0.0
        return time_left(self._phases, self._current, in_phase, self._rate)

    def _plan_phases(self, phases: tuple[PhaseTime, ...]) -> float:
        """Count the run's progress on ``phases`` from now, none of them under way yet;
        returns the s (sim) they take at the sim's rate measured so far."""
        self._phases, self._current = phases, -1
        self._rate = self._measured_rate()
        return time_left(phases, -1, 0.0, self._rate)

    def _measured_rate(self) -> float:
        """sim s per wall s since the run first read the clock; 1 within its first 0.5 s
        (wall) or when the sim's clock went back."""
        wall, sim = self._clock_mark
        spent = time.monotonic() - wall
        rate = (self.io.now_ns() - sim) * 1e-9 / spent if sim and spent >= 0.5 else 1.0
        return rate if rate > 0 else 1.0

    def _static_phases(
        self, plan: Plan, motion: Choreography, bracket: bool, tare_check: bool
    ) -> tuple[PhaseTime, ...]:
        """The phases of a static run of ``plan`` on ``motion`` (``static_run_phases``)
        with this run's parameters and the wall time of own work as last measured;
        ``bracket``: kinematic information; ``tare_check``: a cached tare is checked."""
        config, verify_dwell = self.config, self.p("verify_dwell")
        verify = motion.verify_joints()[0] if bracket and verify_dwell > 0 else None
        return static_run_phases(
            plan,
            motion.pose_joints(plan.tare_plan()),
            motion.pose_joints(plan),
            motion=motion,
            speed=self.arm.speed,
            home=config.home_joints,
            pick=config.pick_joints,
            verify=verify,
            tare_check=tare_check,
            bias_dwell=self.p("bias_dwell"),
            grasp_check_dwell=self.p("grasp_check_dwell"),
            verify_dwell=verify_dwell,
            bracket=bracket,
            release=self.p("release"),
            wall=self._wall_seen,
        )

    def _phase_ended(self, now_ns: int) -> None:
        """The phase under way ended at ``now_ns`` (sim): the time it took beyond its sim
        plan, in wall s at the sim's rate, is the wall time of own work planned for it
        from the next run on."""
        if 0 <= self._current < len(self._phases):
            phase = self._phases[self._current]
            over = (now_ns - self._phase_ns) * 1e-9 - phase.sim
            self._wall_seen[phase.phase] = max(over, 0.0) / self._measured_rate()

    def _enter(self, phase: str, line: str) -> None:
        """Log the phase's line; the feedback names it, and counts the time left from its
        start: its plan and every later phase's."""
        names, now = [p.phase for p in self._phases], self.io.now_ns()
        if phase in names[self._current + 1 :]:
            self._phase_ended(now)
            self._phase_ns, self._current = now, names.index(phase, self._current + 1)
        self._phase = phase
        self.get_logger().info(line)

    def explore(self, run_id: str) -> tuple[bool, str]:
        """One exploration; returns (success, summary). Raises RunError."""
        log = self.get_logger()
        for name, path, directory in (
            ("bag_dir", self.p("bag_dir"), True),
            ("tare_cache", self._cache_path(), False),
        ):
            if why := unwritable(name, path, directory):
                raise RunError(why)  # before anything moves
        self.io.sim_timeout = self.p("sim_timeout")
        self.arm.speed, self.arm.settle = self.p("speed"), self.p("settle")
        self.arm.arm = self._arms[self.p("arm_interface")]
        self.arm.gripper_port = self._grippers[self.p("gripper_interface")]
        self.arm.max_effort = self.p("gripper_max_effort")
        self._grippers["action"].timeout = self.p("gripper_timeout")
        self.io.wait(lambda: self.io.joints, "waiting for the joint states", wall_timeout=None)
        self._clock_mark = (time.monotonic(), self.io.now_ns())  # the sim's rate from here
        self._goal_ns = self._clock_mark[1]  # the progress counts the run's time from here
        self._phases, self._current, self._progress = (), -1, 0.0
        config, motion = self.config, self._choreography()
        self.arm.motion = motion
        with contextlib.suppress(TimeoutRunError):  # missing: named below
            self.io.wait(  # a gripper's publisher may be heard before the arm's
                lambda: all(name in self.io.joints for name in config.arm_joints),
                "waiting for the arm's joint states",
                wall_timeout=self.io.sim_timeout,
            )
        missing = [name for name in config.arm_joints if name not in self.io.joints]
        if missing:
            raise RunError(
                f"{JOINT_STATES_TOPIC} has no {', '.join(missing)} of the robot configuration's "
                f"arm_joints (it names {', '.join(self.io.joints)})"
            )
        self.io.arm_joints = frozenset(config.arm_joints)  # their messages: the arm answers
        self._handshake()
        if information := self._overrides.get("information"):  # before the reset: the
            self.estimator.set("information", information)  # the estimator reads it there
        self.estimator.reset()
        self.io.diagnostics.clear()  # only this run's answers from here on
        home, pick = list(config.home_joints), list(config.pick_joints)
        # the estimator's settings, once: the run's plan, and the bag's copy for the replay
        values = self.estimator.settings([n for n in SETTINGS if n != "robot_description"])
        method, information = values["method"], values["information"]
        if self.p("excitation") == MOTION:
            return self._explore_in_motion(run_id, motion, values)
        drift_rate = tuple(values["bias_drift_rate"])
        calibration = estimator_calibration(values["accuracy"], values["full_scale"])
        settings = self.settings()
        noise, source = self.planning_noise(settings)
        plan, poses, prediction = self._planned(
            settings, noise, method, information, drift_rate, motion, calibration
        )
        log.info(f"planned for the sensor's {noise.summary()} ({source})")
        log.info(
            f"run {run_id}: {config.robot}, poses {[n for n, _ in poses]}, "
            f"tilt {plan.tilt:.3f} rad, dwell {plan.dwell:g} s; predicted {prediction}"
        )
        if self.p("preview"):
            verify = motion.verify_joints()[0] if information != WRENCHES else None
            moves = [("home", home), ("pick", pick), *poses]
            moves += [(VERIFY_POSE, verify)] if verify else []
            return True, self._preview(run_id, moves)
        phases = self._static_phases(plan, motion, information != WRENCHES, False)
        bag = self._start_bag(run_id, self._plan_phases(phases), values)
        self._to_known_state(home, pick)
        self.arm.gripper(close=False)
        tare_home = self._tare(plan, motion, bag, values["tare_cache"], information != WRENCHES)
        self._enter(GRASP, "phase 2/4: grasp and lift")
        self.arm.move(home, "home")
        self.arm.move(pick, "the object")
        self._close_on_object(home)
        self._check_grasp(home, tare_home, pick)
        self._enter(OBJECT_PASS, "phase 3/4: object pass")
        start = self.io.now_ns()
        self._pass(OBJECT_PREFIX, poses, plan.dwell)
        end = self._labels[-1][0]  # the last window's end: the same windows if "moving" is lost
        object_time = (end - start) * 1e-9
        bracket = information != WRENCHES  # an empty-hand window after the pass brackets
        if bracket and self.p("verify_dwell") > 0:  # the fit predicts the wrench there
            verify, reason = motion.verify_joints()
            if verify is None:
                log.warning(f"no verification: its pose is out of reach ({reason})")
            else:
                self._enter(VERIFICATION, "verification pose: a tilt no fit uses")
                self._pass(VERIFY_PREFIX, [(VERIFY_POSE, verify)], self.p("verify_dwell"))
                end = self._labels[-1][0]
        release = self.p("release")
        self._enter(RETURN, f"phase 4/4: return{' and release' if release else ', holding'}")
        if bracket and release:  # the bias's drift (kinematic information): done after it
            self.arm.put_back(home, pick)
            after = f"{poses[0][0]}{BIAS_AFTER_SUFFIX}"
            self._pass(TARE_PREFIX, [(after, home)], self.p("bias_dwell"))
            end = self._labels[-1][0]
        self._label(end, DONE)
        self._label(max(end, self.io.now_ns()), MOVING)  # the latched label is no "done"
        if not release:
            self.arm.move(home, "home")
        elif not bracket:
            self.arm.put_back(home, pick)
        plan_line = f"predicted {prediction}; object pass {object_time:.1f} s (sim)"
        return self._estimate(run_id, end, plan_line, bag)

    def _preview(self, run_id: str, moves: list[tuple[str, list[float]]]) -> str:
        """Log every move's joint targets (deg, the configuration's arm_joints) and return
        the summary: where the arm would go, without moving it (``preview``)."""
        log, names = self.get_logger(), self.config.arm_joints
        here = [self.io.joints[name][0] for name in names]
        log.info(f"preview of run {run_id}: joint targets in deg of {', '.join(names)}")
        for name, joints in moves:
            log.info(f"  {name}: " + ", ".join(f"{math.degrees(v):7.1f}" for v in joints))
        excursion = max(
            abs(v - h) for _, joints in moves for v, h in zip(joints, here, strict=True)
        )
        return (
            f"[PREVIEW] run {run_id}: {len(moves)} targets logged, the largest joint "
            f"excursion from where the arm is {math.degrees(excursion):.1f} deg at speed "
            f"{self.p('speed'):g} rad/s; nothing moved (set preview false to run)"
        )

    def _estimate(self, run_id: str, end: int, plan_line: str, bag: Path) -> tuple[bool, str]:
        """``_finish`` as the run's last phase, the time it took kept for the next run's
        plan; returns (success, summary)."""
        self._enter(ESTIMATE, "the estimate: the estimator's answer, the payload, the report")
        outcome = self._finish(run_id, end, plan_line, bag)
        self._phase_ended(self.io.now_ns())
        return outcome

    def _start_bag(self, run_id: str, planned_s: float, settings: dict[str, object]) -> Path:
        """Start recording the run to <bag_dir>/<run_id> (with the robot configuration the
        replay takes its frames from and the estimator's ``settings``, its defaults) and
        its progress, ``planned_s`` s (sim) long."""
        bag = Path(self.p("bag_dir")).resolve() / run_id
        if why := bag_room_refusal(bag.parent, planned_s):
            raise RunError(why)  # before anything moves
        self._labels = []
        self._recording_failed = False
        self.io.recorder.start(bag)
        self._recording_ns = self.io.now_ns()  # no window of the run starts before it
        self._bag = bag
        self._start_ns, self._planned_s = self.io.now_ns(), planned_s
        write_robot_config(self.config, bag / BAG_ROBOT_FILE)  # the replay's frames
        write_bag_settings(settings, bag / BAG_SETTINGS_FILE)  # the replay's defaults
        return bag

    def _finish(self, run_id: str, end: int, plan_line: str, bag: Path) -> tuple[bool, str]:
        """After the ``done`` label at ``end`` (ns): the estimator's answer, the payload
        files when it holds a payload now, the bag closed, the summary and the report;
        returns (success, summary)."""
        status = self._status = self._estimator_answer(end)
        if (
            status is not None
            and {kv.key: kv.value for kv in status.values}.get("payload") == "True"
        ):
            self.estimator.save_payload(bag)  # this run's estimate is its payload now
        counts = self._stop_recording()
        run = self._read_run(bag)
        summary = _summary(status, plan_line, bag, run.incomplete if run else [])
        self.get_logger().info(
            f"run {run_id}: {summary} ({sum(counts.values())} messages recorded)"
        )
        if run is not None and run.incomplete:
            self.get_logger().warning(f"the bag is incomplete: {'; '.join(run.incomplete)}")
        self._write_report(bag, run)
        return status is not None and status_of(status.level) == OK, summary

    # --- an exploration in motion -------------------------------------------------------

    def _explore_in_motion(
        self, run_id: str, motion: Choreography, settings: dict[str, object]
    ) -> tuple[bool, str]:
        """An exploration in motion (docs/design.md, Identification in motion): the empty
        hand at rest at home (the sensor's noise and bias) and along the excitation (not
        when the hand's motion fit of an earlier run serves, ``_cached_hand``), the grasp,
        the object along the excitation, then along another motion no fit uses, and the
        return. RunError before anything moves when the estimator's information has no
        kinematics. ``settings``: the estimator's."""
        if settings["information"] == WRENCHES:
            raise RunError(
                "excitation 'motion' needs the estimator's information 'kinematics' or "
                "'kinematics+mount' (it has 'wrenches'): the fit takes the wrist's motion "
                "from the URDF and the joint states"
            )
        config, period = self.config, self.p("motion_period")
        home, pick = list(config.home_joints), list(config.pick_joints)
        excitation, verification = self._excitations(motion, period)
        if self.p("preview"):
            names = config.arm_joints
            moves = [("home", home), ("pick", pick)]
            for name, ex in ((MOTION_OBJECT, excitation), (MOTION_VERIFY, verification)):
                q = ex.waypoints(names)[1]  # the path's extremes, joint by joint
                moves += [(f"{name} lowest", list(q.min(axis=0))),
                          (f"{name} highest", list(q.max(axis=0)))]  # fmt: skip
            return True, self._preview(run_id, moves)
        hand = self._cached_hand(motion, excitation, settings["tare_cache"])
        phases = motion_run_phases(
            motion=motion,
            speed=self.arm.speed,
            settle=self.arm.settle,
            home=home,
            pick=pick,
            period=period,
            lead=EXCITATION_LEAD,
            rest=EXCITATION_REST,
            hand_moves=hand is None,
            bias_dwell=self.p("bias_dwell"),
            grasp_check_dwell=self.p("grasp_check_dwell"),
            release=self.p("release"),
            wall=self._wall_seen,
        )
        bag = self._start_bag(run_id, self._plan_phases(phases), settings)
        if hand is not None:
            save_hand_motion(bag / HAND_MOTION_FILE, hand)  # the replay's
        self._to_known_state(home, pick)
        self.arm.gripper(close=False)
        line = "at rest" + (", then along the excitation" if hand is None else "")
        self._enter(TARE, f"phase 1/4: the empty hand {line}")
        tare_home = self._captured_tares([(HOME, home)], self.p("bias_dwell"))[0].get(HOME)
        if tare_home is None:
            raise RunError(f"the empty hand's window at {HOME} was not recorded")
        if hand is None:
            self._excite(MOTION_TARE, excitation)
        self._enter(GRASP, "phase 2/4: grasp and lift")
        self.arm.move(pick, "the object")
        self._close_on_object(home)
        self._check_grasp(home, tare_home, pick)
        self._enter(OBJECT_MOTION, "phase 3/4: the object along the excitation")
        end = self._excite(MOTION_OBJECT, excitation)
        self._enter(VERIFICATION, "verification: the object along a motion no fit uses")
        end = self._excite(MOTION_VERIFY, verification)
        release = self.p("release")
        self._enter(RETURN, f"phase 4/4: return{' and release' if release else ', holding'}")
        self._label(end, DONE)
        self._label(max(end, self.io.now_ns()), MOVING)  # the latched label is no "done"
        if release:
            self.arm.put_back(home, pick)
        joints = ", ".join(excitation.joints)
        plan_line = f"excitation of {joints}, {period:g} s; object motion {period:.1f} s (sim)"
        return self._estimate(run_id, end, plan_line, bag)

    def _cached_hand(
        self, motion: Choreography, excitation: Excitation, estimator_cache: str
    ) -> HandMotion | None:
        """The empty hand's motion fit that the estimator saved beside the tare cache after
        an earlier run, when it serves this one (``HandMotion.serves``: this hand and
        robot model, the path of this run's excitation, younger than ``tare_max_age``)
        and the estimator reads that cache too; else None (the empty hand moves again)."""
        path = hand_motion_path(self._cache_path())
        entry = load_hand_motion(path)
        if entry is None:
            return None
        log = self.get_logger()
        if not estimator_cache or Path(estimator_cache).resolve() != self._cache_path().resolve():
            log.warning(
                f"the estimator reads the tare cache {estimator_cache or '(none)'!r}, not "
                f"{str(self._cache_path())!r}: the empty hand moves again (give both nodes "
                "one tare_cache)"
            )
            return None
        why = entry.serves(self.p("hand_id"), motion.robot.urdf_sha256,
                           lambda t: excitation.at(t)[0], self.p("tare_max_age"))  # fmt: skip
        if why:
            log.info(f"the empty hand's motion fit in {path} not reused: {why}")
            return None
        log.info(f"the empty hand's motion fit reused ({entry.age():.0f} s old, {path})")
        return entry

    def _excitations(self, motion: Choreography, period: float) -> tuple[Excitation, Excitation]:
        """(the excitation of the wrist's last three joints, another one for the
        verification), each designed once per arm, home and period and cached beside the
        tare cache (``planning.excitation.cached_excitation``)."""
        path = self._cache_path().with_name(EXCITATION_CACHE)
        robot = motion.robot
        home = [motion.home_positions()[name] for name in robot.joint_names]
        joints = self.config.arm_joints[-3:]
        started = time.monotonic()
        excitation = cached_excitation(path, robot, home, joints, period)
        verification = cached_excitation(path, robot, home, joints, period,
                                         iterations=VERIFY_ITERATIONS, seed=1)  # fmt: skip
        self.get_logger().info(
            f"excitation: {', '.join(joints)} over {period:g} s, log det "
            f"{excitation.log_det:.1f} ({time.monotonic() - started:.1f} s, cache {path})"
        )
        return excitation, verification

    def _excite(self, label: str, excitation: Excitation) -> int:
        """Run ``excitation`` from home, labelled ``label`` from its start to
        ``EXCITATION_REST`` s after its end (the joint states must reach beyond the last
        wrench the fit takes); returns that end, sim time, ns."""
        self.arm.move(list(self.config.home_joints), "home")
        start = self.io.now_ns() + round(EXCITATION_LEAD * 1e9)
        end = self.arm.follow(excitation, start, label) + round(EXCITATION_REST * 1e9)
        self._label(start, label)
        self.get_logger().info(f"span {label} from t={start * 1e-9:.3f} s")
        self.io.sleep_until(end, f"recording {label}")
        self.arm.finished(wall_timeout=10.0)
        self._label(end, MOVING)
        return end

    # --- steps ------------------------------------------------------------------------

    def _tare(
        self,
        plan: Plan,
        motion: Choreography,
        bag: Path,
        estimator_cache: str,
        hand_model: bool,
    ) -> Window:
        """Phase 1: reuse the cached tare pass of this hand if still valid, else take a new
        one; returns an empty-hand window at home (of this run when it has one). The
        policy: docs/design.md, "The tare cache"."""
        log = self.get_logger()
        path = self._cache_path()
        tare_poses = motion.pose_joints(plan.tare_plan())
        home_name, home = tare_poses[0]
        signature = tare_signature(self.p("hand_id"), tare_poses)
        cache, unreadable = cached_tare(path, self.p("hand_id"), signature, hand_model)
        if unreadable:
            log.warning(f"tare cache {path} unreadable ({unreadable}): taking a new tare")
        decision = tare_decision(
            cache,
            path,
            estimator_cache,
            self.p("tare_max_age"),
            [name for name, _ in plan.poses()],
            hand_model,
        )
        if decision.unshared:
            log.warning(
                f"the estimator reads the tare cache {estimator_cache or '(none)'!r}, not "
                f"{str(path)!r}: taking a fresh tare pass (give both nodes one tare_cache)"
            )
        if decision.check and cache is not None:
            what = "this run's bias" if hand_model else "drift check of the cached tare"
            self._plan_phases(self._static_phases(plan, motion, hand_model, True))
            self._enter(TARE, f"phase 1/4: {what} ({cache.age():.0f} s old), empty hand at home")
            self.arm.move(home, "home")
            check = f"{home_name}{BIAS_WINDOW_SUFFIX}"  # matches no object window
            fresh = self._captured_tares([(check, home)], self.p("bias_dwell"))[0].get(check)
            reuse = tare_reuse(cache, home_name, fresh, hand_model)
            if reuse.reuse:
                use_tares(path, cache)
                use_tares(bag / BAG_TARE_FILE, cache)
                log.info(f"tare: reusing the cache ({reuse.verdict})")
                return reuse.home
            log.warning(f"tare not reusable ({reuse.verdict}): new tare pass")
            self._plan_phases(self._static_phases(plan, motion, hand_model, False))
        self._enter(TARE, "phase 1/4: tare pass with the empty hand")
        windows, noise = self._captured_tares(tare_poses, plan.tare_dwell or plan.dwell)
        if home_name not in windows:
            raise RunError(f"the tare window at {home_name} was not recorded")
        if complete_tare_pass(windows, [name for name, _ in tare_poses]):
            seen = {pose: self._window_seen[TARE_PREFIX + pose] for pose in windows}
            times = {pose: time for pose, (time, _) in seen.items()}
            joints = {p: j for p, (_, j) in seen.items()}
            save_tares(path, signature, windows, joints, times, noise)
            log.info(f"tare: saved to {path}")
        return windows[home_name]

    def _to_known_state(
        self, home: list[float], pick: list[float], when: str = "before the run"
    ) -> None:
        """Start from the empty hand at home: fingers that are not open may hold an object
        (a run that stopped mid-way), so it is put back on the stand first; an arm away
        from home goes home."""
        log = self.get_logger()
        closed = self.arm.gripper_closed()
        if may_hold_object(closed):
            log.warning(
                f"the gripper is {closed:.0%} closed: the hand may hold an object; putting "
                f"it back on the stand {when}"
            )
            self.arm.put_back(home, pick)
        elif not self.arm.at(home):
            log.warning(f"the arm is away from home: moving it home {when}")
            self.arm.move(home, "home")

    def _close_on_object(self, home: list[float]) -> None:
        """Close the gripper on the object: the action's result (stalled on it, not at the
        closed goal) and the finger joint states (short of closed) must show the fingers
        stopped on something (``closing_problem``), else the gripper opens, the arm goes
        home and RunError."""
        result = self.arm.gripper(close=True, wait=GRIPPER_TIME)
        what = "the gripper"
        stalled = reached = None
        if result is not None:  # the driver's outcome (an action's result)
            what = f"the gripper action {self.config.gripper_action}"
            stalled, reached = result.stalled, result.reached_goal
        problem = closing_problem(stalled, reached, self.arm.gripper_closed(), what)
        if problem:
            self.arm.gripper(close=False, wait=GRIPPER_TIME)
            self.arm.move(home, "home")
            raise RunError(
                f"grasp failed: {problem}: the object was not picked up; check pick_joints "
                "and where the object stands"
            )

    def _check_grasp(self, home: list[float], tare_home: Window, pick: list[float]) -> None:
        """Lift and weigh: the wrench at home beyond the tare must hold ``min_load`` kg
        along gravity, else the object was not picked up (RunError, hand emptied)."""
        dwell = round(self.p("grasp_check_dwell") * 1e9)

        def lift_and_weigh() -> int:
            end = self.arm.move(home, "lifting") + dwell
            self.io.sleep_until(end, "weighing the grasp")
            return end

        raws, end = self._wrenches_during(lift_and_weigh, "the grasp check")
        stamps, wrenches, _ = decode_wrench_batch(raws)
        mass = held_mass(stamps, wrenches, end - dwell, end, tare_home.force)
        if mass is None:
            raise RunError(
                "the grasp cannot be weighed: no wrenches arrived, or the empty hand's tare "
                "weighs nothing (a force resolution coarser than the hand's weight?)"
            )
        if not grasp_holds(mass, self.p("min_load")):
            self.arm.put_back(home, pick)
            raise RunError(
                f"grasp failed: after lifting the hand holds {mass * 1e3:.1f} g beyond the "
                f"tare (< min_load {self.p('min_load') * 1e3:g} g): the object was not "
                "picked up; check pick_joints and where the object stands"
            )
        self.get_logger().info(f"grasp holds {mass * 1e3:.1f} g")

    def _captured_tares(
        self, poses: list[tuple[str, list[float]]], dwell: float
    ) -> tuple[dict[str, Window], NoiseModel | None]:
        """Run a tare pass and reduce its windows from the wrenches the recorder saw, with
        the noise they learn (``com_core.sensing.noise``); (windows by pose, that noise)."""

        def tare_pass() -> int:
            self._pass(TARE_PREFIX, poses, dwell)
            return self._labels[-1][0]  # the last window's end

        raws, end = self._wrenches_during(tare_pass, "the tare")
        exploration = Exploration(expected_frame="")  # the driver's frame, whatever it is
        if raws:
            exploration.add_samples(*decode_wrench_batch(raws))
        for stamp, label in self._labels:
            exploration.add_label(stamp, label)
        noise = exploration.noise_model(end)
        tares, _, _, refused = exploration.reduced_windows(end, noise)
        for note in refused:
            self.get_logger().warning(f"not usable: {note}")
        learnt = f"; {noise.summary()}" if noise is not None else ""
        self.get_logger().info(
            f"{TARE_PREFIX}: {len(tares)} windows from {len(raws)} wrenches{learnt}"
        )
        return tares, noise

    def _wrenches_during(self, act: Callable[[], int], what: str) -> tuple[list[bytes], int]:
        """(the raw wrenches the recorder saw while ``act`` ran, and up to the sim time
        it returns; that time, ns): the stream is awaited until it reaches it."""
        recorder = self.io.recorder
        recorder.capture(WRENCH_TOPIC)
        try:
            end = act()
            self.io.wait(
                lambda: recorder.latest_ns >= end,
                f"waiting for the wrenches of {what}",
                wall_timeout=10.0,
            )
        finally:
            raws = self.io.recorder.release(WRENCH_TOPIC)
        return raws, end

    def _pass(self, prefix: str, poses: list[tuple[str, list[float]]], dwell: float) -> None:
        """A window at each pose. Each window starts ``settle`` s after the joint states
        first show the arm resting at its pose; the move to the next pose is sent once the
        window has ended (a trajectory controller starts a trajectory when it arrives)."""
        dwell_ns = round(dwell * 1e9)
        # an arm at rest all along rests from before the recording: the bag starts there
        start = max(self.arm.move(poses[0][1], poses[0][0]), self._recording_ns)
        for k, (name, _) in enumerate(poses):
            end = start + dwell_ns
            self._label(start, prefix + name)
            self.io.sleep_until(end, f"recording {prefix}{name}")
            joints = self.io.joints_over(start, end)
            self._window_seen[prefix + name] = ((start + end) * 0.5e-9, joints)
            self._label(end, MOVING)
            if k + 1 < len(poses):
                start = self.arm.move(poses[k + 1][1], poses[k + 1][0])

    def _label(self, stamp_ns: int, label: str) -> None:
        header = Header(frame_id=label)
        header.stamp.sec, header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.pose_pub.publish(header)
        if not self.pose_pub.wait_for_all_acked(Duration(seconds=LABEL_ACK_TIMEOUT)):
            self.get_logger().warning(
                f"label {label!r} not acknowledged by every reader of {POSE_TOPIC} within "
                f"{LABEL_ACK_TIMEOUT:g} s: a reader that falls this far behind may miss it"
            )
        self._labels.append((stamp_ns, label))
        self._check_recording()
        if label.startswith(STATIC_PREFIXES):
            self.get_logger().info(f"window {label} from t={stamp_ns * 1e-9:.3f} s")

    def _handshake(self) -> None:
        """Wait until the estimator hears the sensor on this node's clock (a wrench stamped
        after now, not ahead of it: not a sensor that was restarted, nor another one) and
        this node's labels: a "moving" now, which begins no window, must come back in its
        input status (a subscriber can match a publisher seconds after the publisher
        matched it, and then the first window labels would be lost). Its status comes at
        1 Hz wall: a sim faster than real time is seconds ahead of it by then. RunError at
        once when the sensor's stamps and this clock are far apart: the two run on
        different clocks (sim time without ``use_sim_time``)."""
        handshake = self.io.now_ns()
        self._label(handshake, MOVING)

        def heard() -> bool:
            latest, now = self.io.estimator_latest, self.io.now_ns()
            if abs(latest - now) > CLOCKS_APART and latest > 0:
                raise RunError(
                    f"the estimator hears {WRENCH_TOPIC} stamped {latest * 1e-9:.3f} s while "
                    f"this node's clock reads {now * 1e-9:.3f} s: they run on different "
                    "clocks; with a simulator's sensor (sim time on /clock) start this node "
                    "with use_sim_time:=true"
                )
            return handshake <= latest < now + 1_000_000_000 and (
                self.io.estimator_label == handshake
            )

        self.io.wait(
            heard,
            f"waiting for the estimator to hear {WRENCH_TOPIC} and {POSE_TOPIC}",
            wall_timeout=self.p("estimate_timeout"),
        )

    def _estimator_answer(self, done_ns: int):
        """The estimator's diagnostics status for this run's 'done', or None."""

        def answered():
            return next((s for stamp, s in self.io.diagnostics if stamp == done_ns), None)

        try:
            self.io.wait(
                answered, "waiting for the estimator", wall_timeout=self.p("estimate_timeout")
            )
        except RunError as exc:
            self.get_logger().error(f"no estimate: {exc}")
            return None
        return answered()

    def _stop_recording(self) -> dict[str, int]:
        """Close the bag; messages written per topic ({} when none or the recording
        failed: the bag holds what was written before, logged)."""
        if not self.io.recorder.recording:
            return {}
        try:
            return self.io.recorder.stop()
        except RuntimeError as exc:
            self.get_logger().error(f"{exc}; {free_room(self._bag)}")
            return {}

    def _check_recording(self) -> None:
        """RecordingError once the recorder says its writer stopped (a full disk)."""
        if self._recording_failed or not self.io.recorder.recording:
            return
        if why := self.io.recorder.failure():
            self._recording_failed = True
            raise RecordingError(f"{why}; {free_room(self._bag)}")

    def _read_run(self, bag: Path) -> RunData | None:
        """The closed bag read back (the report's ``read_run``: what it lacks of the run
        among the rest), or None when it cannot be read (logged)."""
        try:
            return read_run(bag)
        except Exception as exc:  # a bag that cannot be read back must never fail a run
            self.get_logger().error(f"bag {bag} not read back: {exc!r}")
            return None

    def _write_report(self, bag: Path, run: RunData | None) -> None:
        try:
            self.get_logger().info(f"report: {write_report(bag, run=run)}")
        except Exception as exc:  # a report must never fail a run
            self.get_logger().error(f"report not written: {exc!r}")


def _summary(status, plan_line: str, bag: Path, incomplete: list[str]) -> str:
    """One line: the estimator's status and message, for a kinematic fit the COM sigma
    the wrenches alone give on the same windows and the verification, the ``plan_line``
    (the prediction and the pass), the bag and what it lacks (``RunData.incomplete``)."""
    if status is None:
        head = "[ERROR] the estimator did not answer"
    else:
        head = f"[{status_of(status.level)}] {status.message}"
        values = {kv.key: kv.value for kv in status.values}
        if alone := vector_value(values, "wrenches_sigma_com", 1e3):
            head += f" (wrenches alone: COM +- ({', '.join(f'{v:.2f}' for v in alone)}) mm)"
        head += "".join(f"; {line}" for line in verification_lines(values))
        head += f"; {noise}" if (noise := noise_line(values)) else ""
    lacks = "".join(f"; incomplete: {line}" for line in incomplete)
    return f"{head}; {plan_line}{lacks}; bag {bag}"


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
