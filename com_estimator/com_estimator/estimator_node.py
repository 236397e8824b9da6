"""com_estimator node: object mass and COM from the wrist F/T stream and pose labels.

Subscribes
    /ft_sensor/wrench (geometry_msgs/WrenchStamped; best effort, depth 5000; raw CDR
    decoded in batches), /exploration_sequencer/pose (std_msgs/Header: frame_id is the
    label, stamp the sensor time from which it applies; reliable, transient local).
Publishes
    ~/estimate (geometry_msgs/InertiaStamped: m, com in ft_sensor, and from an exploration
    in motion the inertia about the COM when the motion told it,
    ``MotionResult.inertia_identified``; transient local): only
    usable estimates (``Solution.usable``: status OK, or WARN for dropped input with a
    consistent fit); an inconsistent fit (the object moved) is on /diagnostics only,
    /diagnostics (diagnostic_msgs/DiagnosticArray: ``com_estimator: exploration`` with the
    status, reason, sigmas, chi-square of each solution; ``com_estimator: live`` with the
    estimate so far each time an object window closes (progress: it never goes to
    ~/estimate, as no verification has checked it yet); ``com_estimator: input`` at 1 Hz
    with the wrench rate and the stamps of the latest wrench and label, so a sequencer
    knows the estimator hears the sensor and its labels).
    /ft_sensor/wrench_compensated (geometry_msgs/WrenchStamped; best effort): each wrench
    less the bias, the hand and the payload at its orientation (``com_core.payload.compensation``),
    same stamp and frame, once there is a payload: the latest usable estimate with a
    kinematic fit, or the ``payload_file`` loaded at start; ``com_estimator:
    compensation`` on /diagnostics at 1 Hz says from what, how many samples, how many
    left out (joint states older than ``max_joint_state_age``), or why nothing is
    published.
Services
    ~/solve (std_srvs/Trigger): estimate now from what has arrived; success only on OK.
    ~/reset (std_srvs/Trigger): forget the current exploration.
    ~/save_payload (std_srvs/Trigger): write the payload files (``com_core.payload.files``) to
    the directory ``payload_save_dir`` (set it first); the answer names them, or why not.
The estimation is ``com_core.estimation.runs.exploration``; this node only moves messages in
and out.
After a usable exploration in motion that moved the empty hand, the hand's motion fit is
written beside ``tare_cache`` (``com_core.estimation.runs.hand_motion``), for the next run.
The compensation runs here, not in a node of its own: this node holds the fit (bias,
hand, payload) the moment it is made, and already decodes every wrench.
"""

from __future__ import annotations

import math
import sys
import time
import traceback

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import InertiaStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Header, String
from std_srvs.srv import Trigger

from com_core.bags.cdr import decode_header, decode_wrench, decode_wrenches, with_wrench
from com_core.contract import (
    CANCELLED,
    COMPENSATED_TOPIC,
    COMPENSATION_STATUS_NAME,
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    DONE,
    ERROR,
    ESTIMATE_TOPIC,
    ESTIMATOR_RESET_SERVICE,
    ESTIMATOR_SAVE_PAYLOAD_SERVICE,
    ESTIMATOR_SOLVE_SERVICE,
    INPUT_STATUS_NAME,
    INTERNAL_ERROR,
    JOINT_STATES_TOPIC,
    LATEST_LABEL_KEY,
    LATEST_STAMP_KEY,
    LIVE_STATUS_NAME,
    OBJECT_PREFIX,
    OK,
    POSE_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    WARN,
    WRENCH_TOPIC,
    level_of,
)
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.fit_setup import WRENCHES
from com_core.estimation.runs.hand_motion import (
    hand_motion_path,
    load_hand_motion,
    save_hand_motion,
)
from com_core.estimation.runs.inbox import TIME_RESET_NS, shorten
from com_core.estimation.runs.motion_solution import hand_motion_of
from com_core.estimation.runs.sensor_calibration import (
    SensorCalibration,
    calibrated_owner,
    calibration_path,
    kept_calibration,
    save_calibration,
)
from com_core.estimation.runs.settings import (
    SETTINGS,
    exploration_from,
    robot_from,
    use_cached_hand_motion,
    use_cached_tares,
    use_sensor_calibration,
)
from com_core.estimation.runs.solution import Solution, format_solution
from com_core.estimation.runs.tare_cache import cache_owner
from com_core.inputs import Input, problems, table_of
from com_core.payload.compensation import MAX_JOINT_STATE_AGE, Compensator
from com_core.payload.files import read_payload, write_payload_files
from com_core.payload.model import Payload, PayloadError, payload_from_solution
from com_core.robot.config import default_robot_config
from com_core.robot.dynamics import INERTIA_ELEMENTS, inertia_elements
from com_core.robot.model import RobotModel
from com_core.runtime.lifeline import stop_with_parent
from com_core.runtime.rosenv import discovery_line, keep_dds_local, start_refusal, stop_on_signals
from com_core.sensing.calibration import reading_correction
from com_estimator.stream_qos import subscribe_adapted

MAX_MESSAGE_LENGTH = 1000  # characters of a diagnostic message
SOLVE_TIMEOUT = 4.0
"""s (wall): how long a run's ``done`` waits for its input: a reliable stream's sample lost
at a starved process's transport comes again at its publisher's next heartbeat, 3 s apart
in Fast DDS (``WriterTimes.heartbeat_period``; docs/design.md, Pose labels)."""
LIVE_KEYS = frozenset(
    ["mass", "sigma_mass", "information"]
    + [f"{k}_{a}" for k in ("com", "sigma_com") for a in "xyz"]
)
"""What the live status carries of a solution (and its windows' ``samples <label>``)."""

PARAMETERS = SETTINGS | table_of([
    Input("solve_timeout", SOLVE_TIMEOUT, "(wall) to wait after 'done' for the wrenches, "
          "and the joint states of the joints that move the sensor, up to its stamp",
          unit="s", low=0.0, high=60.0, low_open=True),
    Input("payload_file", "", "payload.yaml to compensate with from the start ('': none); "
          "read at start", kind="str", read_only=True),
    Input("payload_save_dir", "", "directory ~/save_payload writes the payload files to",
          kind="str"),
    Input("hand_id", default_robot_config().hand_id, "names the hand; a payload file of "
          "another hand is refused (robot configuration)", kind="str"),
    Input("sensor_id", default_robot_config().sensor_id, "names the sensor and its settings; "
          "a cached hand motion of another sensor is not used, and its calibration in place "
          "is kept and read under it (robot configuration)", kind="str"),
    Input("max_joint_state_age", MAX_JOINT_STATE_AGE, "a wrench this much past the latest "
          "joint state is not compensated", unit="s", low=0.0, high=60.0, low_open=True),
])  # fmt: skip


class EstimatorNode(Node):
    """Thin adapter from messages to ``com_core.estimation.runs.exploration.Exploration``."""

    def __init__(self) -> None:
        super().__init__("com_estimator")
        # checked from the first value on: one given at start is refused as a set one is
        self.add_on_set_parameters_callback(self.validate_parameters)
        for row in PARAMETERS.values():
            self.declare_parameter(row.name, row.default, ParameterDescriptor(**row.descriptor()))
        self._raw: list[bytes] = []
        self.internal_errors = 0  # defects that reached a solve's top level (INTERNAL_ERROR)
        self._urdf = ""  # the latest /robot_description
        self._robot: RobotModel | None = None  # its model, for the compensation
        self._payload: Payload | None = None
        self._payload_source = ""  # what the payload is: an estimate, a file
        self._compensator: Compensator | None = None
        self._compensation_problem = ""  # why a payload file was refused
        self._exploration = self._new_exploration()
        self._calibration_of: Exploration | None = None  # whose calibration was kept
        self._done_stamp: int | None = None
        self._done_wall = 0.0
        self._live_stamp: int | None = None  # an object window closed here: solve so far
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._estimate_pub = self.create_publisher(InertiaStamped, ESTIMATE_TOPIC, latched)
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        self._compensated_pub = self.create_publisher(
            WrenchStamped,
            COMPENSATED_TOPIC,
            QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT),
        )
        # reliable when the sensor's publishers are (stream_qos): none lost while starved
        subscribe_adapted(self, WrenchStamped, WRENCH_TOPIC, self.wrench_callback, raw=True)
        pose_qos = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(Header, POSE_TOPIC, self.pose_callback, pose_qos, raw=True)
        # as the wrenches: a window's mean joint state is the bag's, so the replay's
        subscribe_adapted(self, JointState, JOINT_STATES_TOPIC, self.joint_state_callback)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(
            String, ROBOT_DESCRIPTION_TOPIC, self.robot_description_callback, latched
        )
        self.create_service(Trigger, ESTIMATOR_SOLVE_SERVICE, self.solve_callback)
        self.create_service(Trigger, ESTIMATOR_RESET_SERVICE, self.reset_callback)
        self.create_service(Trigger, ESTIMATOR_SAVE_PAYLOAD_SERVICE, self.save_payload_callback)
        steady = Clock(clock_type=ClockType.STEADY_TIME)  # keeps running if /clock stops
        self.create_timer(0.02, self.drain_callback, clock=steady)
        self._received = 0  # wrench messages since the last input status
        self._latest_stamp = 0  # ns, of the latest wrench received
        self._latest_frame = ""  # its frame_id
        self._latest_label: int | None = None  # ns, stamp of the latest label received
        self.create_timer(1.0, self.input_status_callback, clock=steady)
        self.get_logger().info(
            f"estimating with method={self._param('method')}; waiting for {POSE_TOPIC} labels"
        )
        if self._param("robot_description"):  # a URDF given as a parameter, not on a topic
            self._robot, problem = robot_from(self._settings())
            if problem:
                self.get_logger().error(f"robot model: {problem}")
        self._load_payload_file()

    # --- parameters -----------------------------------------------------------------

    def _param(self, name: str):
        return self.get_parameter(name).value

    def _calibration(self) -> SensorCalibration | None:
        """The sensor's calibration in place, kept beside the tare cache; None without."""
        return kept_calibration(self._param("tare_cache"), self._param("sensor_id"))

    def _owner(self, calibration: SensorCalibration | None) -> str:
        """The hand on the sensor as ``calibration`` left it, which the cached hand motion
        must belong to."""
        owner = cache_owner(self._param("hand_id"), self._param("sensor_id"))
        return calibrated_owner(owner, calibration)

    def validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Refuse a value its row in ``PARAMETERS`` refuses (settings apply from the next
        exploration)."""
        values = {p.name: p.value for p in params if p.name in PARAMETERS}
        if refused := problems(PARAMETERS, values):
            self.get_logger().error("; ".join(refused))
            return SetParametersResult(successful=False, reason="; ".join(refused))
        return SetParametersResult(successful=True)

    def _settings(self) -> dict:
        """The estimator settings (``SETTINGS``) as the parameters hold them now."""
        return {name: self._param(name) for name in SETTINGS}

    def _new_exploration(self) -> Exploration:
        exploration = exploration_from(self._settings(), self._urdf)
        if exploration.robot_problem and self._urdf:
            self.get_logger().error(f"robot model: {exploration.robot_problem}")
        return exploration

    def _solution(self, until_ns: int) -> Solution:
        """The current exploration solved up to ``until_ns`` with the parameters in force
        now; a defect is an ERROR solution, with its traceback in the log."""
        try:
            cache, calibration = self._param("tare_cache"), self._calibration()
            if self._exploration.reference is None:  # a calibration reads the sensor raw
                use_sensor_calibration(self._exploration, calibration)
            use_cached_tares(self._exploration, cache)
            if cache:
                owner = self._owner(calibration)
                use_cached_hand_motion(self._exploration, hand_motion_path(cache), owner)
            return self._exploration.solve(until_ns=until_ns)
        except Exception as exc:  # a defect must not kill the node: report it as ERROR
            self.internal_errors += 1
            why = f"{INTERNAL_ERROR} #{self.internal_errors}: {exc!r}"
            self.get_logger().error(f"solve failed: {why}\n{traceback.format_exc()}")
            return Solution(ERROR, why, self._param("method"))

    def _keep_hand_motion(self, solution: Solution, cache: str) -> None:
        """Save the empty hand's motion fit of ``solution`` (usable, in motion, the empty
        hand moved) beside the tare cache ``cache``, unless it holds that motion's already."""
        entry = hand_motion_of(
            self._exploration, solution.motion if solution.usable else None,
            self._exploration.robot, self._owner(self._calibration()),
        )  # fmt: skip
        if entry is None:
            return
        path = hand_motion_path(cache)
        saved = load_hand_motion(path)
        if saved is not None and saved.stamp_ns == entry.stamp_ns:
            return
        try:
            save_hand_motion(path, entry)
            self.get_logger().info(f"the empty hand's motion fit saved beside {cache}")
        except OSError as exc:
            self.get_logger().error(f"the empty hand's motion fit not saved: {exc}")

    def _keep_calibration(self, solution: Solution, cache: str) -> None:
        """Keep the calibration in place that ``solution`` (of a reference weight)
        identified, for the sensor ``sensor_id``, beside the tare cache ``cache``
        (``sensor_calibration``): once per exploration."""
        if solution.calibration is None or self._calibration_of is self._exploration:
            return
        sensor = self._param("sensor_id")
        if not sensor or not cache:
            why = "no sensor_id names the sensor" if not sensor else "no tare_cache to keep it by"
            self.get_logger().error(f"the calibration in place not kept: {why}")
            return
        path = calibration_path(cache)
        try:
            save_calibration(path, SensorCalibration(sensor, time.time(), solution.calibration))
            self._calibration_of = self._exploration
            self.get_logger().info(f"the calibration in place of {sensor!r} kept in {path}")
        except OSError as exc:
            self.get_logger().error(f"the calibration in place not kept: {exc}")

    def _solve(self, until_ns: int, done: bool = False) -> Solution:
        """Solve the current exploration and publish it (``_publish``); the empty hand's
        motion fit of a usable exploration in motion goes to the cache beside the tare
        cache (``hand_motion``), once per motion (a later ~/solve of the same run does
        not make it younger), and a calibration in place of a run that is ``done`` (its
        every pose; ``_keep_calibration``)."""
        solution = self._solution(until_ns)
        if cache := self._param("tare_cache"):
            self._keep_hand_motion(solution, cache)
        if done:
            self._keep_calibration(solution, cache)
        payload = self._payload_of(solution)
        if payload is not None:
            self._payload, self._payload_source = payload, f"estimate of {payload.time}"
            self._start_compensating()
        self._publish(solution, until_ns, payload is not None)
        return solution

    def _payload_of(self, solution: Solution) -> Payload | None:
        """The payload of a usable solution with a kinematic or a motion fit, else None (the
        wrenches alone give no bias nor hand model; a fit without the hand's windows none
        either)."""
        robot = self._exploration.robot
        fitted = solution.fit is not None or solution.motion is not None
        if not solution.usable or not fitted or robot is None or solution.calibrated:
            return None  # a calibration's fit is of raw readings: no payload to compensate
        try:
            frame = self._param("expected_frame") or self._latest_frame  # '': the wrenches'
            return payload_from_solution(
                solution, robot, frame=frame, hand_id=self._param("hand_id")
            )
        except PayloadError as exc:
            self.get_logger().warning(f"no payload to compensate with: {exc}")
            return None

    # --- compensation -----------------------------------------------------------------

    def _load_payload_file(self) -> None:
        """Read ``payload_file`` (at start): a payload of another frame or hand, or a file
        that does not parse, is an ERROR that names the field; the node runs on."""
        path = self._param("payload_file")
        if not path:
            return
        try:
            payload = read_payload(
                path, frame=self._param("expected_frame") or None, hand_id=self._param("hand_id")
            )
            if payload.sensor_frame != self._param("sensor_frame"):
                raise PayloadError(
                    f"field 'sensor_frame' is {payload.sensor_frame!r}, this estimator's "
                    f"sensor_frame {self._param('sensor_frame')!r}"
                )
        except (PayloadError, OSError) as exc:
            self._compensation_problem = f"payload_file {path} refused: {exc}"
            self.get_logger().error(self._compensation_problem)
            return
        self._payload, self._payload_source = payload, f"payload file {path}"
        self.get_logger().info(f"payload file {path}: {payload.mass * 1e3:.2f} g")
        self._start_compensating()

    def _start_compensating(self) -> None:
        """Compensate from now on with the current payload and robot model (both needed);
        a model of the same joints keeps the joint states and the counts since the last
        status (a new estimate or the URDF again leaves no sample out, loses no count)."""
        if self._payload is None or self._robot is None:
            self._compensator = None  # a robot model refused since: nothing to compensate with
            return
        for field, ours in (
            ("sensor_frame", self._robot.sensor_frame),
            ("base_frame", self._robot.base_frame),
        ):
            theirs = getattr(self._payload, field)
            if theirs != ours:
                self._compensator = None
                self._compensation_problem = (
                    f"the {self._payload_source}'s field {field!r} is {theirs!r}, the robot "
                    f"model's {ours!r}"
                )
                self.get_logger().error(f"not compensating: {self._compensation_problem}")
                return
        previous = self._compensator
        calibration = self._calibration()  # the payload is of the load: read it corrected
        matrix = reading_correction(calibration and calibration.calibration,
                                    self._exploration.hysteresis)  # fmt: skip
        correction = None if matrix is None else tuple(map(tuple, matrix.tolist()))
        self._compensator = Compensator(
            self._payload, self._robot, self._payload_source, self._param("max_joint_state_age"),
            correction,
        )  # fmt: skip
        if previous is not None:
            self._compensator.take_over(previous)
        self._compensation_problem = ""
        self.get_logger().info(
            f"publishing {COMPENSATED_TOPIC}: {WRENCH_TOPIC} less the {self._payload_source}"
        )

    def _publish_compensated(self, raw: bytes, compensator: Compensator) -> None:
        """The compensated wrench of one message (its stamp and frame), if its frame is the
        payload's and its joints are known; else nothing (a bad message is counted where it
        is drained, a stale one by the compensator)."""
        try:
            stamp, frame, wrench = decode_wrench(raw)
        except ValueError:
            return
        if frame != compensator.payload.frame:
            return
        sign = self._param("wrench_sign")  # as the exploration's inbox takes the samples
        contact = compensator.compensate(
            stamp, wrench if sign == 1.0 else [sign * v for v in wrench]
        )
        if contact is not None:
            self._compensated_pub.publish(with_wrench(raw, contact))

    def _compensation_status(self, received: int) -> DiagnosticStatus:
        """``com_estimator: compensation``: OK while every sample since the last status
        was compensated; WARN with the reason when samples were left out (stale joint
        states), when ``received`` wrenches came and none was in the payload's frame, or
        nothing is published (no payload, no robot model, a refused file)."""
        c = self._compensator
        values = []
        if c is None:
            level = level_of(WARN)
            why = self._compensation_problem or (
                "no payload: no usable estimate with a kinematic fit yet and no payload_file"
                if self._payload is None
                else "no robot model (waiting for /robot_description)"
            )
            text = f"{COMPENSATED_TOPIC} not published: {why}"
        else:
            done, stale = c.compensated, c.stale
            c.compensated = c.stale = 0
            level = level_of(WARN if stale or (received and not done) else OK)
            text = f"{done} samples compensated with the {c.source}"
            if received and not done and not stale:
                text += f": none of the {received} wrenches is in its frame {c.payload.frame!r}"
            if stale:
                text += (
                    f"; {stale} left out: joint states older than {c.max_age:g} s at their stamps"
                )
            values = [
                KeyValue(key="compensated", value=str(done)),
                KeyValue(key="stale", value=str(stale)),
                KeyValue(key="payload_mass", value=repr(c.payload.mass)),
            ]
        return DiagnosticStatus(
            level=level,
            name=COMPENSATION_STATUS_NAME,
            message=text,
            hardware_id=self._param("expected_frame"),
            values=values,
        )

    # --- input --------------------------------------------------------------------

    def wrench_callback(self, raw: bytes) -> None:
        self._raw.append(raw)
        if self._compensator is not None:
            self._publish_compensated(raw, self._compensator)

    def joint_state_callback(self, msg: JointState) -> None:
        """Joint positions for the gravity of each window (information 'kinematics') and
        for the orientation of each sample to compensate. A message may name some joints
        only (another publisher's: a gripper's): the windows take each joint from the
        messages that name it (``cutting.window_rotation``), the compensation the messages
        that name every joint that moves the sensor (``RobotModel.chain_names``)."""
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if len(msg.position) != len(msg.name):  # malformed: not one position per joint
            self.get_logger().warning(
                f"dropped a joint state of {len(msg.name)} names and {len(msg.position)} "
                "positions",
                throttle_duration_sec=10.0,
            )
            return
        if self._compensator is not None:
            self._compensator.add_joint_state(stamp, msg.name, msg.position, msg.velocity)
        if self._exploration.information != WRENCHES:
            self._exploration.add_joint_state(stamp, msg.name, msg.position)

    def robot_description_callback(self, msg: String) -> None:
        """The URDF (latched): the robot model of this and the next explorations, and of
        the compensation."""
        self._urdf = msg.data
        robot, problem = robot_from(self._settings(), self._urdf)
        if problem:
            self.get_logger().error(f"robot model: {problem}")
        else:
            self.get_logger().info(f"robot model {robot.model.name!r}: {robot.sensor_frame}")
        if self._exploration.information != WRENCHES:
            self._exploration.robot, self._exploration.robot_problem = robot, problem
        self._robot = robot
        self._start_compensating()

    def pose_callback(self, raw: bytes) -> None:
        self._drain()
        try:
            stamp, label = decode_header(raw)
        except ValueError as exc:  # malformed bytes: drop the label, say so
            self.get_logger().error(f"dropped an undecodable label: {exc}")
            self._exploration.count_dropped("undecodable (malformed CDR)", 1, labels=True)
            return
        stale = self._exploration.stale_drops
        labels = self._exploration.labels
        objects = {lbl for _, lbl in labels if lbl.startswith(OBJECT_PREFIX)}
        if labels and labels[-1][1].startswith(OBJECT_PREFIX) and len(objects) > 1:
            self._live_stamp = stamp  # this label closes the second object window or later
        self._exploration.add_label(stamp, label)
        if label == CANCELLED:
            self.get_logger().warning("the run was cancelled: its windows are dropped")
            self._done_stamp = self._live_stamp = None
        self._latest_label = stamp
        self.get_logger().info(f"pose {shorten(label)!r} from t={stamp * 1e-9:.3f} s")
        if self._exploration.stale_drops > stale:
            self.get_logger().warning(
                f"no label for over {self._param('max_label_gap'):g} s before this one: "
                "dropped the earlier exploration (a sequencer that stopped mid-run)"
            )
        if label == DONE and self._done_stamp is None:
            done = self._exploration.done_stamp()
            if done is None:  # a done with no window before it: say so, start anew
                self._solve(stamp)
                self._exploration = self._new_exploration()
            else:
                self._done_stamp, self._done_wall = done, time.monotonic()

    def _drain(self) -> None:
        if not self._raw:
            return
        raws, self._raw = self._raw, []
        self._received += len(raws)
        stamps, wrenches, frames, bad = decode_wrenches(raws)
        if bad:  # malformed bytes: those messages only, counted in the solution
            self._exploration.count_dropped("undecodable (malformed CDR)", bad)
        if not len(stamps):
            return
        latest = self._exploration.latest_stamp
        if self._done_stamp is not None and latest is not None:
            back = np.flatnonzero(stamps <= latest - TIME_RESET_NS)
            if back.size:  # a restarted clock before the run's done caught up: solve the
                first = int(back[0])  # run on what it has, the new timeline apart
                self._exploration.add_samples(stamps[:first], wrenches[:first], frames[:first])
                self._solve_done()
                stamps, wrenches, frames = stamps[first:], wrenches[first:], frames[first:]
        resets = self._exploration.time_resets
        self._exploration.add_samples(stamps, wrenches, frames)
        self._latest_stamp, self._latest_frame = int(stamps[-1]), str(frames[-1])
        self._exploration.forget_idle()  # no exploration running: a bounded lead-in
        if self._exploration.time_resets > resets:
            self.get_logger().warning("sensor time jumped back by more than 1 s: restarted clock")

    def input_status_callback(self) -> None:
        """1 Hz ``com_estimator: input`` status: the wrench rate (Hz, wall clock), the
        stamp of the latest wrench (ns), by which a sequencer knows the estimator hears
        the sensor on its own clock, and the stamp of the latest label (ns), by which it
        knows the estimator hears its labels."""
        self._drain()
        rate, self._received = self._received, 0
        level = level_of(OK if rate else WARN)
        text = f"receiving {rate} wrenches/s" if rate else f"no wrenches on {WRENCH_TOPIC}"
        values = [
            KeyValue(key="rate_hz", value=str(rate)),
            KeyValue(key=LATEST_STAMP_KEY, value=str(self._latest_stamp)),
        ]
        if self._latest_label is not None:
            values.append(KeyValue(key=LATEST_LABEL_KEY, value=str(self._latest_label)))
        status = DiagnosticStatus(
            level=level,
            name=INPUT_STATUS_NAME,
            message=text,
            hardware_id=self._param("expected_frame"),
            values=values,
        )
        msg = DiagnosticArray(status=[status, self._compensation_status(rate)])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    def drain_callback(self) -> None:
        self._drain()
        latest = self._exploration.latest_stamp
        if self._live_stamp is not None and latest is not None and latest >= self._live_stamp:
            self._publish_live(self._solution(self._live_stamp))
            self._live_stamp = None
        if self._done_stamp is None:
            return
        lacking = self._exploration.lacking(self._done_stamp)
        if not lacking:
            self._solve_done()
        elif time.monotonic() - self._done_wall > self._param("solve_timeout"):
            self.get_logger().warning(
                f"solving at solve_timeout ({self._param('solve_timeout'):g} s after "
                f"'done' at t={self._done_stamp * 1e-9:.3f} s) without {lacking}"
            )
            self._solve_done()

    def _solve_done(self) -> None:
        """Solve the run up to its ``done`` and start a new exploration."""
        self._solve(self._done_stamp, done=True)
        self._start_anew()

    def _start_anew(self) -> None:
        """A new exploration: no ``done`` pending, no live estimate due."""
        self._exploration, self._done_stamp = self._new_exploration(), None
        self._live_stamp = None

    # --- services -----------------------------------------------------------------

    def solve_callback(self, request: Trigger.Request, response: Trigger.Response):
        self._drain()
        latest = self._exploration.latest_stamp
        until = (
            self._done_stamp
            if self._done_stamp is not None
            else (latest + 1 if latest is not None else 0)
        )
        solution = self._solve(until, done=self._done_stamp is not None)
        response.success = solution.status == OK
        response.message = format_solution(solution)
        return response

    def reset_callback(self, request: Trigger.Request, response: Trigger.Response):
        self._drain()
        n = self._exploration.sample_count
        self._start_anew()
        response.success, response.message = True, f"cleared {n} samples"
        self.get_logger().info(response.message)
        return response

    def save_payload_callback(self, request: Trigger.Request, response: Trigger.Response):
        """Write the payload files to ``payload_save_dir``; failure with the reason."""
        directory = self._param("payload_save_dir")
        if self._payload is None:
            response.success = False
            response.message = "no payload: no usable estimate with a kinematic fit yet"
        elif not directory:
            response.success = False
            response.message = "payload_save_dir is not set"
        else:
            try:
                paths = write_payload_files(directory, self._payload)
            except OSError as exc:
                response.success, response.message = False, f"not written: {exc}"
            else:
                response.success = True
                response.message = ", ".join(str(p) for p in paths)
        if response.success:  # one call site per severity (rclpy requires it)
            self.get_logger().info(f"save_payload: {response.message}")
        else:
            self.get_logger().error(f"save_payload: {response.message}")
        return response

    # --- output -------------------------------------------------------------------

    def _publish_live(self, solution: Solution) -> None:
        """The estimate so far on ``com_estimator: live`` (contract.LIVE_STATUS_NAME)."""
        values = [
            KeyValue(key=k, value=v)
            for k, v in solution.diagnostic_values()
            if k in LIVE_KEYS or k.startswith("samples ")
        ]
        status = _status(solution, LIVE_STATUS_NAME, self._param("expected_frame"), values)
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    def _publish(self, solution: Solution, stamp_ns: int, payload: bool = False) -> None:
        """The solution on the logs, ~/estimate (usable only) and /diagnostics, whose
        ``payload`` value says whether it is now the compensation's payload (the one
        ~/save_payload writes)."""
        for window in solution.windows:
            f = window.force
            self.get_logger().info(
                f"window {window.pose!r}: {window.n} samples, |f| = {math.hypot(*f):.4f} N"
            )
        summary = format_solution(solution)
        if solution.status == OK:  # one call site per severity (rclpy requires it)
            self.get_logger().info(summary)
        elif solution.status == WARN:
            self.get_logger().warning(summary)
        else:
            self.get_logger().error(summary)
        header = Header(frame_id=self._param("expected_frame") or "ft_sensor")
        header.stamp.sec, header.stamp.nanosec = divmod(max(stamp_ns, 0), 1_000_000_000)
        if solution.usable:
            msg = InertiaStamped(header=header)
            msg.inertia.m = solution.estimate.mass
            msg.inertia.com.x, msg.inertia.com.y, msg.inertia.com.z = (
                float(c) for c in solution.estimate.com
            )
            if solution.motion is not None and solution.motion.inertia_identified:  # kg m^2
                elements = inertia_elements(solution.motion.inertia)
                for name, value in zip(INERTIA_ELEMENTS, elements, strict=True):
                    setattr(msg.inertia, name, float(value))
            self._estimate_pub.publish(msg)
        values = [KeyValue(key=k, value=v) for k, v in solution.diagnostic_values()]
        values.append(KeyValue(key="samples", value=str(self._exploration.sample_count)))
        values.append(KeyValue(key="payload", value=str(payload)))
        status = _status(solution, DIAGNOSTIC_NAME, header.frame_id, values)
        self._diag_pub.publish(DiagnosticArray(header=header, status=[status]))


def _status(solution: Solution, name: str, frame: str, values: list[KeyValue]) -> DiagnosticStatus:
    """A solution's diagnostics status ``name``: its level and reason, ``values``."""
    return DiagnosticStatus(
        level=level_of(solution.status),
        name=name,
        message=shorten(solution.reason, MAX_MESSAGE_LENGTH),
        hardware_id=frame or "ft_sensor",
        values=values,
    )


def main(args: list[str] | None = None) -> int:
    keep_dds_local()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    rclpy.logging.get_logger("com_estimator").info(discovery_line())
    stopping = stop_on_signals()
    try:
        node = EstimatorNode()
    except ParameterException as error:  # a parameter refused (com_core.inputs)
        rclpy.logging.get_logger("com_estimator").error(f"cannot start: {start_refusal(error)}")
        rclpy.try_shutdown()
        return 1
    executor = EventsExecutor()
    executor.add_node(node)
    stop_with_parent(node.get_logger().warning)  # SIGINT once the demo that started it ended
    try:
        while rclpy.ok() and not stopping.is_set():
            executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
