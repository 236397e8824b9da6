"""ROS 2 node around ``physics.ArmWorld``: sim time, wrenches, joint states, ground truth.

The arm is the robot configuration in its parameters (``com_core.robot.config.KEYS``, the
Panda's by default; ``--ros-args --params-file <com_core>/config/xarm6.yaml`` runs the xArm6).
A configuration that does not serve (a bad value, a frame or joint its URDF lacks, home
joints outside the limits) is an ERROR log naming it, and the node exits with code 1.

The node does not spin on a timer: ``run`` steps the physics at 1 kHz as fast as it can (or at
``real_time_factor``), publishes /clock every ``1000 / clock_rate`` steps (4 ms by default:
fine enough to sequence, a quarter of the load of every step at 5x real time) and the wrench
every ``1000 / rate`` steps, and services its subscriptions every 50 steps with
``spin_once(timeout_sec=0)`` and, while it waits for the wall clock to hold
``real_time_factor``, each as it comes. The wrenches and /clock go out as serialized messages (the
same messages, without rclpy's conversion of a Python one at every sample).

Publishes (names in ``com_core.contract``; stamps in sim time):

- CLOCK_TOPIC (rosgraph_msgs/Clock): sim time, ``clock_rate`` Hz.
- WRENCH_TOPIC (geometry_msgs/WrenchStamped): the sensor reading, frame ``ft_sensor`` (the
  mounted sensor's, ``sensor_mount_rpy``), ``rate`` Hz.
- APPLIED_WRENCH_TOPIC (geometry_msgs/WrenchStamped): while a push acts, the push as the
  sensor reads it (``ArmWorld.applied_wrench``, about the sensor origin, frame
  ``ft_sensor`` as the readings), one per wrench sample with the same stamp; then one zero
  wrench, at the first wrench sample after the last push ended.
- JOINT_STATES_TOPIC (sensor_msgs/JointState) from two publishers, as a real arm and its
  gripper's driver: the configuration's ``arm_joints`` at its ``joint_state_rate`` and its
  ``gripper_joints`` at its ``gripper_joint_state_rate``, each stamped when it is sent.
- TRUTH_TOPIC, HAND_TRUTH_TOPIC (geometry_msgs/InertiaStamped, latched): the object's and the
  hand's mass and COM in ``ft_sensor``, republished when they change.
- OBJECT_TOPIC (std_msgs/String, latched): shape, mass, grasp mode and held state.
- ROBOT_DESCRIPTION_TOPIC (std_msgs/String, latched): the URDF the sim loaded.

Subscribes:

- ARM_COMMAND_TOPIC (trajectory_msgs/JointTrajectory): a trajectory of the configuration's
  ``arm_joints`` (any subset, any order), followed as the Jazzy joint_trajectory_controller
  does (``wrench_sim.trajectory``): it replaces the running one on arrival, runs from the
  measured state to its first point at ``header.stamp`` + time_from_start, and interpolates
  linearly, cubically or quintically by what its points carry.
- HAND_COMMAND_TOPIC (std_msgs/Float64MultiArray): one value, the gripper's position from
  ``gripper_open`` to ``gripper_closed`` (m per finger on the Panda, rad on the xArm6); it
  aborts a running gripper goal.
- APPLY_WRENCH_TOPIC (geometry_msgs/WrenchStamped): a push on the held object, force (N) at
  its COM and a pure couple (N m), ``header.frame_id`` ``world`` or ``ft_sensor`` (the
  mounted sensor's axes; the push then turns with the hand), from ``header.stamp`` (sim
  time; zero or past: now) for ``push_duration`` s. Pushes add up. Refused with an ERROR log
  for another frame, a non-finite value or no object held; the start and end are logged.

Serves the configuration's ``arm_action`` (control_msgs/action/FollowJointTrajectory, as a
joint_trajectory_controller does; ``wrench_sim.arm_action``): the same trajectories, checked
in the goal callback, with path and goal tolerances (the configuration's ``goal_tolerance``
and ``stopped_velocity_tolerance`` by default) and the controller's result codes.

Serves the configuration's ``gripper_action`` (control_msgs/action/GripperCommand, as a
real gripper's driver does): ``command.position`` from ``gripper_open`` to
``gripper_closed`` (m per finger on the Panda, as franka_gripper's; rad on the xArm6) and
``command.max_effort`` (N, caps the fingers' force; 0: ``grip_force``); a goal outside these
is rejected with an ERROR log. The fingers move at the gripper's speed and stop on the
object; the goal ends (``wrench_sim.gripper.GripperGoal``) succeeded with ``reached_goal``
within 2 % of the stroke of its position, or with ``stalled`` when the fingers stayed still
0.1 s short of it (on the object: position beyond ``gripper_closed``, effort the grip
force); the result and the feedback (every 50 ms while they move) carry position, effort,
stalled and reached_goal. A new goal or a topic command aborts the running one; a cancelled
goal stops the fingers where they are. Until the fingers stop, a goal's status reads
ACCEPTED (the physics loop, not an executor thread, moves them), then SUCCEEDED.

The world's events (grasp, release, pushes, grasp shifts) are logged as INFO; a collision
(``ArmWorld.collisions``) as a WARN.
"""

from __future__ import annotations

import array
import signal
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from control_msgs.action import GripperCommand
from geometry_msgs.msg import InertiaStamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.exceptions import ParameterException, ParameterUninitializedException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from com_core.bags.cdr import WrenchStampedEncoder, encode_clock
from com_core.contract import (
    APPLIED_WRENCH_TOPIC,
    APPLY_WRENCH_TOPIC,
    CLOCK_TOPIC,
    HAND_COMMAND_TOPIC,
    HAND_TRUTH_TOPIC,
    JOINT_STATES_TOPIC,
    OBJECT_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    TRUTH_MOVE_M,
    TRUTH_TOPIC,
    WRENCH_TOPIC,
)
from com_core.inputs import InputError
from com_core.robot.config import KEYS, RobotConfig, RobotConfigError
from com_core.robot.dynamics import INERTIA_ELEMENTS, inertia_elements
from com_core.runtime.lifeline import stop_with_parent
from com_core.runtime.rosenv import discovery_line, keep_dds_local, start_refusal
from com_core.sensing.sensor_profiles import SensorProfile
from com_core.sensing.wrench_model import SensorModel, rotation_about
from wrench_sim.arm_action import ArmController
from wrench_sim.gauges import profile_gauges
from wrench_sim.gripper import GripperGoal, GripperOutcome
from wrench_sim.joint_torques import profile_joint_torques, wrench_in
from wrench_sim.objects import reference_weight_mass
from wrench_sim.parameters import (
    SENSOR_PARAMETERS,
    check_parameter,
    declare_parameters,
    sensor_profile,
)
from wrench_sim.physics import SENSOR_FRAME, TIME_STEP, ArmWorld, SimConfig
from wrench_sim.sensor import WrenchSensor, profile_calibration, profile_drift, random_streams

_SPIN_EVERY = 50  # steps between spin_once calls (50 ms of sim time; one costs ~0.2 ms)
_REPORT_EVERY = 50  # steps between checks of events, saturation and ground truth
_GOALS_EVERY = 10  # steps between checks of the arm's and the gripper's goals (10 ms)
_GRIPPER_FEEDBACK_EVERY = 5  # checks between a gripper goal's feedback messages (50 ms)
STREAM_HISTORY = 10_000  # messages: 2 s (wall) of a 1 kHz stream at 5x real time
_LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class SimNode(Node):
    """The simulated arm: publishes what a real arm with a wrist F/T sensor would."""

    def __init__(self) -> None:
        super().__init__("wrench_sim")
        self.add_on_set_parameters_callback(self.parameters_callback)
        declare_parameters(self)
        parameter = self.get_parameter
        try:
            offset = parameter("object_com_offset").value
        except ParameterUninitializedException:
            offset = None  # drawn from the seed
        robot = RobotConfig.from_parameters({key: parameter(key).value for key in KEYS})
        self.profile = self._profile()
        streams = random_streams(parameter("seed").value)
        p = self.profile
        self._calibration = profile_calibration(p, parameter("sensor_serial").value)
        self.world = ArmWorld(
            SimConfig(
                robot=robot,
                object_shape=parameter("object").value,
                object_mass=self._object_mass(),
                object_com_offset=tuple(offset) if offset is not None else None,
                seed=parameter("seed").value,
                grasp_mode=parameter("grasp_mode").value,
                slip_sigma=parameter("slip_sigma").value,
                hand_mass=parameter("hand_mass").value,
                grip_force=parameter("grip_force").value,
                gui=parameter("gui").value,
                vibration=p.modes,
                vibration_gain=p.vibration_gain,
            )
        )
        roll, pitch, yaw = parameter("sensor_mount_rpy").value
        # the mounted sensor's axes in its URDF frame; readings and truth are in its own
        self._mount = (
            rotation_about("z", yaw) @ rotation_about("y", pitch) @ rotation_about("x", roll)
        )
        self._mount_identity = bool(np.array_equal(self._mount, np.eye(3)))
        drift = profile_drift(p, streams["drift"])
        own = random_streams(parameter("sensor_serial").value)
        gauges = profile_gauges(p, own["gauges"], streams["hysteresis"])
        arm = profile_joint_torques(p, self.world, own["joint_torques"])
        self.sensor = WrenchSensor(self._sensor_model(), streams["sensor"], drift, gauges, arm)
        self._drift = np.array(parameter("bias_drift").value, dtype=np.float64)  # per s
        self._real_time_factor = parameter("real_time_factor").value
        self._publish_every = round(1000.0 / parameter("rate").value)
        self._joint_state_every = round(1000.0 / robot.joint_state_rate)  # steps
        self._finger_state_every = round(1000.0 / robot.gripper_joint_state_rate)
        self._clock_every = round(1000.0 / parameter("clock_rate").value)
        self._pace_origin: tuple[float, float] | None = None

        # reliable, keep last STREAM_HISTORY: what a subscriber starved for 2 s (wall) at
        # the fastest sim needs repaired (com_estimator.stream_qos)
        stream = STREAM_HISTORY
        self.clock_publisher = self.create_publisher(Clock, CLOCK_TOPIC, stream // 4)
        self.wrench_publisher = self.create_publisher(WrenchStamped, WRENCH_TOPIC, stream)
        self.applied_publisher = self.create_publisher(WrenchStamped, APPLIED_WRENCH_TOPIC, stream)
        self.joint_state_publishers = [  # the arm's and the gripper's drivers
            self.create_publisher(JointState, JOINT_STATES_TOPIC, stream // 5) for _ in "ag"
        ]
        self.truth_publisher = self.create_publisher(InertiaStamped, TRUTH_TOPIC, _LATCHED)
        self.hand_truth_publisher = self.create_publisher(
            InertiaStamped, HAND_TRUTH_TOPIC, _LATCHED
        )
        self.object_publisher = self.create_publisher(String, OBJECT_TOPIC, _LATCHED)
        description = self.create_publisher(String, ROBOT_DESCRIPTION_TOPIC, _LATCHED)
        description.publish(String(data=self.world.urdf_text))  # the URDF loaded, as is
        self.arm_controller = ArmController(self, self.world)
        self.create_subscription(Float64MultiArray, HAND_COMMAND_TOPIC, self.gripper_callback, 10)
        self.create_subscription(WrenchStamped, APPLY_WRENCH_TOPIC, self.push_callback, 10)
        # the running gripper goal, its progress and checks so far; finished goals' outcomes
        self._gripper_goal: tuple[ServerGoalHandle, GripperGoal, int] | None = None
        self._gripper_outcomes: dict[bytes, tuple[str, GripperOutcome]] = {}
        ActionServer(
            self,
            GripperCommand,
            robot.gripper_action,
            execute_callback=self._gripper_result,
            goal_callback=self._gripper_goal_callback,
            handle_accepted_callback=self._gripper_accepted,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
        )
        self.executor_ = SingleThreadedExecutor(context=self.context)
        self.executor_.add_node(self)

        self._wrench_encoder = WrenchStampedEncoder(SENSOR_FRAME)
        self._push_scheduled = False  # a push was accepted and its zero not yet published
        self._push_published = False  # the last applied wrench published was not zero
        arm = len(robot.arm_joints)
        names = self.world.joint_state()[0]
        self._joint_states = (JointState(), JointState())
        self._joint_cuts = (slice(0, arm), slice(arm, None))
        for msg, cut in zip(self._joint_states, self._joint_cuts, strict=True):
            msg.name = list(names[cut])
        self._saturated = False  # in a saturation episode
        self._saturated_readings = 0  # since the last report
        self._published_object: tuple[bool, np.ndarray] | None = None
        self._published_hand: np.ndarray | None = None
        self._publish_truth(force=True)
        spec = self.world.object
        offset_mm = ", ".join(f"{1e3 * v:.1f}" for v in spec.com_offset)
        self.get_logger().info(f"sensor: {parameter('sensor_profile').value} profile, {p}")
        self.get_logger().info(
            f"ready: robot {robot.robot}, {spec.shape} {spec.mass:.3f} kg, COM offset "
            f"({offset_mm}) mm, grasp {self.world.config.grasp_mode}, seed "
            f"{self.world.config.seed}, wrench at "
            f"{1.0 / (self._publish_every * TIME_STEP):.0f} Hz, joint states at "
            f"{1.0 / (self._joint_state_every * TIME_STEP):.0f} Hz, real-time factor "
            f"{self._real_time_factor or 'max'}"
        )

    def _object_mass(self) -> float:
        """kg: ``object_mass``, or a reference weight's true mass off that nominal."""
        nominal = self.get_parameter("object_mass").value
        if not self.get_parameter("reference_weight").value:
            return nominal
        return reference_weight_mass(nominal, self.get_parameter("seed").value)

    def _profile(self, overrides: dict | None = None) -> SensorProfile:
        """The ``sensor_profile`` with every part its parameters set."""
        names = (*SENSOR_PARAMETERS, "sensor_profile")
        values = {name: self.get_parameter(name).value for name in names}
        return sensor_profile(values | (overrides or {}))

    def _sensor_model(self, overrides: dict | None = None) -> SensorModel:
        """The sensor of the profile and the parameters (with ``overrides``)."""
        p = self._profile(overrides)
        values = {name: self.get_parameter(name).value for name in ("bias_f", "bias_tau", "rate")}
        values.update({k: v for k, v in (overrides or {}).items() if k in values})
        return SensorModel.from_scalars(
            p.sigma_f,
            p.sigma_tau,
            bias_f=values["bias_f"],
            bias_tau=values["bias_tau"],
            resolution_f=p.resolution_f,
            resolution_tau=p.resolution_tau,
            limit_f=p.limit_f,
            limit_tau=p.limit_tau,
            rate_hz=values["rate"],
            correlation_time=p.correlation_time,
            calibration=self._calibration,
        )

    def parameters_callback(self, parameters: list[Parameter]) -> SetParametersResult:
        """Refuse invalid values with a reason; apply sensor and timing changes at run time."""
        others = {n: self.get_parameter(n).value for n in ("object", "grasp_mode") if
                  self.has_parameter(n)}  # fmt: skip
        for parameter in parameters:
            reason = check_parameter(parameter.name, parameter.value, others)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        if not hasattr(self, "world"):
            return SetParametersResult(successful=True)  # still declaring
        changes = {p.name: p.value for p in parameters}
        if set(changes) & {*SENSOR_PARAMETERS, "rate"}:
            try:
                self.sensor.model = self._sensor_model(changes)
            except ValueError as error:
                return SetParametersResult(successful=False, reason=str(error))
            self._publish_every = round(1000.0 / self.sensor.model.rate_hz)
        if "bias_drift" in changes:
            self._drift = np.array(changes["bias_drift"], dtype=np.float64)
        if "real_time_factor" in changes:
            self._real_time_factor = changes["real_time_factor"]
            self._pace_origin = None
        if "slip_sigma" in changes:
            self.world.set_slip_sigma(changes["slip_sigma"])
        for name, value in changes.items():
            self.get_logger().info(f"parameter {name} set to {value}")
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ commands
    def gripper_callback(self, msg: Float64MultiArray) -> None:
        """Move the gripper: one value, its position from ``gripper_open`` to
        ``gripper_closed`` (m or rad); a running gripper goal is aborted."""
        try:
            if len(msg.data) != 1:
                raise ValueError(f"expected 1 value (the gripper's position), got {len(msg.data)}")
            self.world.command_gripper(float(msg.data[0]))
        except ValueError as error:
            self.get_logger().error(f"rejected gripper command: {error}")
            return
        self._end_gripper_goal("aborted", "a topic command replaced it")
        self.get_logger().info(f"gripper to {msg.data[0]:.4f}")

    def _gripper_goal_callback(self, goal: GripperCommand.Goal) -> GoalResponse:
        """Accept a goal the gripper can take; reject one outside its range (ERROR log)."""
        robot = self.world.config.robot
        low, high = sorted((robot.gripper_open, robot.gripper_closed))
        position, effort = goal.command.position, goal.command.max_effort
        if not (np.isfinite(position) and low <= position <= high):
            why = f"position {position} outside [{low}, {high}]"
        elif not (np.isfinite(effort) and effort >= 0.0):
            why = f"max_effort {effort} N is not >= 0 (0: no limit)"
        else:
            return GoalResponse.ACCEPT
        self.get_logger().error(f"rejected gripper goal: {why}")
        return GoalResponse.REJECT

    def _gripper_accepted(self, goal_handle: ServerGoalHandle) -> None:
        """Start the fingers toward the goal; a running goal is aborted where it is."""
        self._end_gripper_goal("aborted", "a new goal replaced it")
        command = goal_handle.request.command
        robot = self.world.config.robot
        self.world.command_gripper(command.position, command.max_effort)
        stroke = robot.gripper_closed - robot.gripper_open
        self._gripper_goal = (
            goal_handle,
            GripperGoal(command.position, stroke, self.world.time),
            0,
        )
        self.get_logger().info(
            f"gripper goal: to {command.position:.4f}, max effort {command.max_effort:g} N"
        )

    def _track_gripper(self) -> None:
        """Check the running gripper goal: feedback while the fingers move, its end once
        they reach the goal or stall; a cancelled goal stops the fingers where they are."""
        assert self._gripper_goal is not None
        handle, goal, checks = self._gripper_goal
        done = goal.update(self.world.time, *self.world.gripper_state())
        if handle.is_cancel_requested:
            self.world.command_gripper(self._within_stroke(goal.outcome.position))
            self._end_gripper_goal("canceled", "cancelled")
        elif done:
            self._end_gripper_goal("succeeded", "")
        else:
            if checks % _GRIPPER_FEEDBACK_EVERY == 0:
                handle.publish_feedback(_gripper_message(GripperCommand.Feedback(), goal.outcome))
            self._gripper_goal = (handle, goal, checks + 1)

    def _within_stroke(self, position: float) -> float:
        """``position`` (m or rad) clipped to the gripper's range."""
        robot = self.world.config.robot
        low, high = sorted((robot.gripper_open, robot.gripper_closed))
        return min(max(position, low), high)

    def _end_gripper_goal(self, how: str, why: str) -> None:
        """End the running gripper goal (if any) ``how`` (succeeded, aborted, canceled) with
        the gripper's state now; its result goes out at the next spin."""
        if self._gripper_goal is None:
            return
        handle, goal, _ = self._gripper_goal
        self._gripper_goal = None
        goal.update(self.world.time, *self.world.gripper_state())
        outcome = goal.outcome
        self._gripper_outcomes[bytes(handle.goal_id.uuid)] = (how, outcome)
        handle.execute()  # runs _gripper_result
        state = "reached its goal" if outcome.reached_goal else (
            "stalled" if outcome.stalled else "stopped")  # fmt: skip
        self.get_logger().info(
            f"gripper goal {how}{f' ({why})' if why else ''}: {state} at "
            f"{outcome.position:.4f}, effort {outcome.effort:.2f} N"
        )

    def _gripper_result(self, goal_handle: ServerGoalHandle) -> GripperCommand.Result:
        """The ended goal's terminal state and result (``_end_gripper_goal``)."""
        how, outcome = self._gripper_outcomes.pop(bytes(goal_handle.goal_id.uuid))
        ends = {"succeeded": goal_handle.succeed, "aborted": goal_handle.abort,
                "canceled": goal_handle.canceled}  # fmt: skip
        ends[how]()
        return _gripper_message(GripperCommand.Result(), outcome)

    def push_callback(self, msg: WrenchStamped) -> None:
        """Push the held object from the header stamp (sim time; zero or past: now) for
        ``push_duration`` s; a push in another frame, with a non-finite value or with no
        object held is logged and ignored."""
        frame = msg.header.frame_id
        f, t = msg.wrench.force, msg.wrench.torque
        force = np.array([f.x, f.y, f.z])
        torque = np.array([t.x, t.y, t.z])
        if frame == SENSOR_FRAME:  # the mounted sensor's axes, to the URDF's sensor frame
            force, torque = self._mount @ force, self._mount @ torque
        try:
            start = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
            duration = self.get_parameter("push_duration").value
            start, end = self.world.apply_wrench(force, torque, frame, start, duration)
        except ValueError as error:
            self.get_logger().error(f"rejected push: {error}")
            return
        self._push_scheduled = True
        values = ", ".join(f"{v:.3f}" for v in (f.x, f.y, f.z))
        couple = ", ".join(f"{v:.4f}" for v in (t.x, t.y, t.z))
        self.get_logger().info(
            f"push accepted: ({values}) N at the object's COM, couple ({couple}) N m, frame "
            f"{frame}, from t = {start:.3f} s until t = {end:.3f} s (sim)"
        )

    # ------------------------------------------------------------------ loop
    def run(self, duration: float | None = None, publish: bool = True) -> None:
        """Step and publish until shutdown, or for ``duration`` s of sim time.

        ``publish=False`` skips the DDS publishing (for the benchmark's comparison).
        """
        world, sensor, mounted = self.world, self.sensor, self._mounted
        step, read, arm = world.step, sensor.read, sensor.joint_torques
        clock_every, joint_every = self._clock_every, self._joint_state_every
        finger_every = self._finger_state_every
        end_steps = None if duration is None else round(duration / TIME_STEP)
        steps = 0
        self._pace_origin = None
        while end_steps is None or steps < end_steps:
            step()
            steps += 1
            now = world.time_ns
            reading = None
            if steps % self._publish_every == 0:  # the rate may be set meanwhile
                t = now * 1e-9
                reading = read(mounted(wrench_in(world, arm)) + self._drift * t, t)
                self._saturated_readings += sensor.saturated
            if publish:
                if steps % clock_every == 0:
                    self._publish_clock(now)
                if reading is not None:
                    self._publish_wrench(now, reading)
                    if self._push_scheduled:
                        self._publish_applied(now)
                if steps % joint_every == 0:
                    self._publish_joint_state(now, 0)
                if steps % finger_every == 0:
                    self._publish_joint_state(now, 1)
            if steps % _GOALS_EVERY == 0:
                self.arm_controller.track()
                if self._gripper_goal is not None:
                    self._track_gripper()
            if steps % _REPORT_EVERY == 0:
                self._report()
            if steps % _SPIN_EVERY == 0:
                if not rclpy.ok(context=self.context):
                    break
                self._pace()

    def _pace(self) -> None:
        """Service subscriptions; to hold the real-time factor, go on serving them until
        the wall clock catches up with the sim (each request as it comes, not one per
        ``_SPIN_EVERY`` steps)."""
        self.executor_.spin_once(timeout_sec=0)
        factor = self._real_time_factor  # one value throughout: a set may change it meanwhile
        if factor <= 0.0:
            return
        if self._pace_origin is None:
            self._pace_origin = (time.perf_counter(), self.world.time)
        wall0, sim0 = self._pace_origin
        due = wall0 + (self.world.time - sim0) / factor
        while factor == self._real_time_factor and (ahead := due - time.perf_counter()) > 0.0:
            self.executor_.spin_once(timeout_sec=ahead)

    def _publish_clock(self, now: int) -> None:
        """Sim time ``now`` (ns) on /clock, serialized (``encode_clock``)."""
        self.clock_publisher.publish(encode_clock(now))

    def _publish_wrench(self, now: int, reading: np.ndarray) -> None:
        """The reading (6,), N and N m in ``ft_sensor``, stamped ``now`` (ns)."""
        self.wrench_publisher.publish(self._wrench_encoder.encode(now, reading.tolist()))

    def _publish_applied(self, now: int) -> None:
        """The pushes of the last step as the sensor reads them, in the mounted sensor's
        frame, with the wrench sample's stamp; one zero when the last push has ended."""
        world = self.world
        if world.push_active:
            wrench = self._mounted(world.applied_wrench())
            self._push_published = True
        elif self._push_published:
            wrench = np.zeros(6)
            self._push_published = False
        else:  # waiting for its start (or dropped before it)
            self._push_scheduled = world.push_scheduled
            return
        self._push_scheduled = world.push_scheduled or self._push_published
        self.applied_publisher.publish(self._wrench_encoder.encode(now, wrench.tolist()))

    def _publish_joint_state(self, now: int, part: int) -> None:
        """The arm's joints (``part`` 0) or the gripper's (1), from their own publisher;
        the message (its names set once) reused, its values as ``array('d')``, which rclpy
        takes without checking each element."""
        msg = self._joint_states[part]
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
        _, positions, velocities, efforts = self.world.joint_state()
        cut = self._joint_cuts[part]
        msg.position = array.array("d", positions[cut])
        msg.velocity = array.array("d", velocities[cut])
        msg.effort = array.array("d", efforts[cut])
        self.joint_state_publishers[part].publish(msg)

    def _report(self) -> None:
        """Log the world's events and saturation; republish ground truth that moved."""
        for event in self.world.events:  # one call site per severity (rclpy's rule)
            if "collision:" in event:
                self.get_logger().warning(event)
            else:
                self.get_logger().info(event)
        self.world.events.clear()
        saturated, self._saturated_readings = self._saturated_readings, 0
        if saturated and not self._saturated:
            self.get_logger().warning(
                f"t = {self.world.time:.3f} s: F/T sensor saturated, readings clipped to its range"
            )
        elif self._saturated and not saturated:
            self.get_logger().info(f"t = {self.world.time:.3f} s: F/T sensor back in range")
        self._saturated = bool(saturated)
        self._publish_truth()

    def _publish_truth(self, force: bool = False) -> None:
        """Publish the object's and the hand's ground truth if forced, or if it changed.

        The object's is republished when it is grasped or released and, while held, when its
        COM moved in ``ft_sensor`` by more than 0.05 mm (a slip or a grasp shift).
        """
        world = self.world
        stamp = Time()
        stamp.sec, stamp.nanosec = divmod(world.time_ns, 1_000_000_000)
        held = world.object_held
        last = self._published_object
        changed = force or last is None or held != last[0]
        mount = self._mount
        if changed or held:
            mass, com = world.object_ground_truth()
            if changed or np.max(np.abs(com - last[1])) > TRUTH_MOVE_M:
                inertia = mount.T @ world.inertia_ground_truth()[1] @ mount
                self.truth_publisher.publish(_inertia(stamp, mass, mount.T @ com, inertia))
                self._published_object = (held, com)
            if changed:
                state = "held" if held else "not_held"
                description = (
                    f"shape={world.object.shape} mass={mass:.4f} "
                    f"grasp_mode={world.config.grasp_mode} state={state}"
                )
                self.object_publisher.publish(String(data=description))
        hand_mass, hand_com = world.hand_ground_truth()
        last_hand = self._published_hand
        if force or last_hand is None or np.max(np.abs(hand_com - last_hand)) > TRUTH_MOVE_M:
            inertia = mount.T @ world.inertia_ground_truth()[0] @ mount
            self.hand_truth_publisher.publish(
                _inertia(stamp, hand_mass, mount.T @ hand_com, inertia)
            )
            self._published_hand = hand_com

    def _mounted(self, wrench: np.ndarray) -> np.ndarray:
        """A wrench (6,) in the URDF's sensor frame expressed in the mounted sensor's (a new
        array).

        A sensor mounted as its URDF frame (the default) takes ``wrench + 0.0``, without the
        two matrix products: for finite values the product with the identity bit for bit
        (each element 1 x plus two signed zeros: x, and 0.0 for -0.0, as x + 0.0 gives).
        """
        if self._mount_identity:
            return wrench + 0.0
        return np.concatenate([self._mount.T @ wrench[:3], self._mount.T @ wrench[3:]])

    def close(self) -> None:
        """Release pybullet and the executor."""
        self.executor_.shutdown(timeout_sec=0.0)
        self.world.close()


def _gripper_message(
    msg: GripperCommand.Result | GripperCommand.Feedback, outcome: GripperOutcome
) -> GripperCommand.Result | GripperCommand.Feedback:
    """``msg`` filled with ``outcome``: position (m or rad), effort (N), stalled,
    reached_goal."""
    msg.position, msg.effort = float(outcome.position), float(outcome.effort)
    msg.stalled, msg.reached_goal = bool(outcome.stalled), bool(outcome.reached_goal)
    return msg


def _inertia(stamp, mass: float, com: np.ndarray, inertia: np.ndarray) -> InertiaStamped:
    """Mass (kg), COM (m) and inertia about the COM (kg m^2), all in ``ft_sensor``."""
    msg = InertiaStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = SENSOR_FRAME
    msg.inertia.m = float(mass)
    msg.inertia.com.x, msg.inertia.com.y, msg.inertia.com.z = (float(v) for v in com)
    for name, value in zip(INERTIA_ELEMENTS, inertia_elements(inertia), strict=True):
        setattr(msg.inertia, name, float(value))
    return msg


def main(args: list[str] | None = None) -> int:
    """Console script ``sim_node``."""
    keep_dds_local()
    # SIGINT raises KeyboardInterrupt in the physics loop, which then tears down in order
    # (rclpy's own handler would shut the context down under the running loop); also in a
    # process started with SIGINT ignored (a background job of a script).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    rclpy.logging.get_logger("wrench_sim").info(discovery_line())
    try:
        node = SimNode()
    except (ParameterException, InputError, RobotConfigError) as error:  # the user's input
        rclpy.logging.get_logger("wrench_sim").error(f"cannot start: {start_refusal(error)}")
        rclpy.try_shutdown()
        return 1
    try:
        stop_with_parent(node.get_logger().warning)  # SIGINT once the demo that started it ended
        node.run()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.close()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
