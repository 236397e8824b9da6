"""com_estimator node: object mass and COM from the wrist F/T stream and pose labels.

Subscribes
    /ft_sensor/wrench (geometry_msgs/WrenchStamped; best effort, depth 5000; raw CDR
    decoded in batches), /exploration_sequencer/pose (std_msgs/Header: frame_id is the
    label, stamp the sensor time from which it applies; reliable, transient local).
Publishes
    ~/estimate (geometry_msgs/InertiaStamped: m, com in ft_sensor; transient local): only
    usable estimates (``Solution.usable``: status OK, or WARN for dropped input with a
    consistent fit); an inconsistent fit (the object moved) is on /diagnostics only,
    /diagnostics (diagnostic_msgs/DiagnosticArray: ``com_estimator: exploration`` with the
    status, reason, sigmas, chi-square of each solution; ``com_estimator: input`` at 1 Hz
    with the wrench rate and the stamps of the latest wrench and label, so a sequencer
    knows the estimator hears the sensor and its labels).
Services
    ~/solve (std_srvs/Trigger): estimate now from what has arrived; success only on OK.
    ~/reset (std_srvs/Trigger): forget the current exploration.
The estimation is ``com_core.exploration``; this node only moves messages in and out.
"""

from __future__ import annotations

import math
import time
import traceback

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import InertiaStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Header, String
from std_srvs.srv import Trigger

from com_core.bags.cdr import decode_header, decode_wrenches
from com_core.contract import (
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    DONE,
    ESTIMATE_TOPIC,
    ESTIMATOR_RESET_SERVICE,
    ESTIMATOR_SOLVE_SERVICE,
    INPUT_STATUS_NAME,
    JOINT_STATES_TOPIC,
    LATEST_LABEL_KEY,
    LATEST_STAMP_KEY,
    POSE_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    WRENCH_TOPIC,
    level_of,
)
from com_core.estimator_settings import (
    SETTINGS,
    exploration_from,
    robot_from,
    setting_problem,
    use_cached_tares,
)
from com_core.exploration import (
    ERROR,
    OK,
    WARN,
    WRENCHES,
    Exploration,
    Solution,
    format_solution,
    shorten,
)
from com_core.rosenv import keep_dds_local, stop_on_signals

MAX_MESSAGE_LENGTH = 1000  # characters of a diagnostic message

PARAMETERS = SETTINGS | {
    "solve_timeout": (1.0, "s (wall) to wait after 'done' for samples up to its stamp"),
}


class EstimatorNode(Node):
    """Thin adapter from messages to ``com_core.exploration.Exploration``."""

    def __init__(self) -> None:
        super().__init__("com_estimator")
        for name, (default, text) in PARAMETERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(description=text))
        self.add_on_set_parameters_callback(self.validate_parameters)
        self._raw: list[bytes] = []
        self._urdf = ""  # the latest /robot_description
        self._exploration = self._new_exploration()
        self._done_stamp: int | None = None
        self._done_wall = 0.0
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._estimate_pub = self.create_publisher(InertiaStamped, ESTIMATE_TOPIC, latched)
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        wrench_qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.create_subscription(
            WrenchStamped, WRENCH_TOPIC, self.wrench_callback, wrench_qos, raw=True
        )
        pose_qos = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(Header, POSE_TOPIC, self.pose_callback, pose_qos, raw=True)
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.joint_state_callback, 100)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(
            String, ROBOT_DESCRIPTION_TOPIC, self.robot_description_callback, latched
        )
        self.create_service(Trigger, ESTIMATOR_SOLVE_SERVICE, self.solve_callback)
        self.create_service(Trigger, ESTIMATOR_RESET_SERVICE, self.reset_callback)
        steady = Clock(clock_type=ClockType.STEADY_TIME)  # keeps running if /clock stops
        self.create_timer(0.02, self.drain_callback, clock=steady)
        self._received = 0  # wrench messages since the last input status
        self._latest_stamp = 0  # ns, of the latest wrench received
        self._latest_label: int | None = None  # ns, stamp of the latest label received
        self.create_timer(1.0, self.input_status_callback, clock=steady)
        self.get_logger().info(
            f"estimating with method={self._param('method')}; waiting for {POSE_TOPIC} labels"
        )

    # --- parameters -----------------------------------------------------------------

    def _param(self, name: str):
        return self.get_parameter(name).value

    def validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Refuse a value ``setting_problem`` refuses (they apply from the next exploration)."""
        for p in params:
            if p.name == "solve_timeout":
                problem = None if p.value > 0.0 else f"solve_timeout={p.value!r} refused: > 0 s"
            elif p.name in SETTINGS:
                problem = setting_problem(p.name, p.value)
            else:  # rclpy's own (use_sim_time, ...)
                continue
            if problem:
                self.get_logger().error(problem)
                return SetParametersResult(successful=False, reason=problem)
        return SetParametersResult(successful=True)

    def _settings(self) -> dict:
        """The estimator settings (``SETTINGS``) as the parameters hold them now."""
        return {name: self._param(name) for name in SETTINGS}

    def _new_exploration(self) -> Exploration:
        exploration = exploration_from(self._settings(), self._urdf)
        if exploration.robot_problem and self._urdf:
            self.get_logger().error(f"robot model: {exploration.robot_problem}")
        return exploration

    def _solve(self, until_ns: int) -> Solution:
        """Solve the current exploration with the parameters in force now."""
        try:
            use_cached_tares(self._exploration, self._param("tare_cache"))
            solution = self._exploration.solve(until_ns=until_ns)
        except Exception as exc:  # a defect must not kill the node: report it as ERROR
            self.get_logger().error(f"solve failed: {traceback.format_exc()}")
            solution = Solution(ERROR, f"internal error: {exc!r}", self._param("method"))
        self._publish(solution, until_ns)
        return solution

    # --- input --------------------------------------------------------------------

    def wrench_callback(self, raw: bytes) -> None:
        self._raw.append(raw)

    def joint_state_callback(self, msg: JointState) -> None:
        """Joint positions for the gravity of each window (information 'kinematics')."""
        if self._exploration.information != WRENCHES:
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            self._exploration.add_joint_state(stamp, msg.name, msg.position)

    def robot_description_callback(self, msg: String) -> None:
        """The URDF (latched): the robot model of this and the next explorations."""
        self._urdf = msg.data
        if self._exploration.information != WRENCHES:
            robot, problem = robot_from(self._settings(), self._urdf)
            self._exploration.robot, self._exploration.robot_problem = robot, problem
            if problem:
                self.get_logger().error(f"robot model: {problem}")
            else:
                self.get_logger().info(f"robot model {robot.model.name!r}: {robot.sensor_frame}")

    def pose_callback(self, raw: bytes) -> None:
        self._drain()
        try:
            stamp, label = decode_header(raw)
        except ValueError as exc:  # malformed bytes: drop the label, say so
            self.get_logger().error(f"dropped an undecodable label: {exc}")
            self._exploration.count_dropped("undecodable (malformed CDR)", 1, labels=True)
            return
        stale = self._exploration.stale_drops
        self._exploration.add_label(stamp, label)
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
        resets = self._exploration.time_resets
        self._exploration.add_samples(stamps, wrenches, frames)
        self._latest_stamp = int(stamps[-1])
        if self._exploration.time_resets > resets:
            self.get_logger().warning("sensor time jumped back by more than 1 s: restarted clock")

    def input_status_callback(self) -> None:
        """1 Hz ``com_estimator: input`` status: the wrench rate (Hz, wall clock), the
        stamp of the latest wrench (ns), by which a sequencer knows the estimator hears
        the sensor on its own clock, and the stamp of the latest label (ns), by which it
        knows the estimator hears its labels."""
        self._drain()
        rate, self._received = self._received, 0
        level = DiagnosticStatus.OK if rate else DiagnosticStatus.WARN
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
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    def drain_callback(self) -> None:
        self._drain()
        if self._done_stamp is None:
            return
        latest = self._exploration.latest_stamp
        caught_up = latest is not None and latest >= self._done_stamp
        if caught_up or time.monotonic() - self._done_wall > self._param("solve_timeout"):
            self._solve(self._done_stamp)
            self._exploration, self._done_stamp = self._new_exploration(), None

    # --- services -----------------------------------------------------------------

    def solve_callback(self, request: Trigger.Request, response: Trigger.Response):
        self._drain()
        latest = self._exploration.latest_stamp
        until = (
            self._done_stamp
            if self._done_stamp is not None
            else (latest + 1 if latest is not None else 0)
        )
        solution = self._solve(until)
        response.success = solution.status == OK
        response.message = format_solution(solution)
        return response

    def reset_callback(self, request: Trigger.Request, response: Trigger.Response):
        self._drain()
        n = self._exploration.sample_count
        self._exploration, self._done_stamp = self._new_exploration(), None
        response.success, response.message = True, f"cleared {n} samples"
        self.get_logger().info(response.message)
        return response

    # --- output -------------------------------------------------------------------

    def _publish(self, solution: Solution, stamp_ns: int) -> None:
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
            self._estimate_pub.publish(msg)
        values = [KeyValue(key=k, value=v) for k, v in solution.diagnostic_values()]
        values.append(KeyValue(key="samples", value=str(self._exploration.sample_count)))
        status = DiagnosticStatus(
            level=level_of(solution.status),
            name=DIAGNOSTIC_NAME,
            message=shorten(solution.reason, MAX_MESSAGE_LENGTH),
            hardware_id=header.frame_id,
            values=values,
        )
        self._diag_pub.publish(DiagnosticArray(header=header, status=[status]))


def main(args: list[str] | None = None) -> None:
    keep_dds_local()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stopping = stop_on_signals()
    node = EstimatorNode()
    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok() and not stopping.is_set():
            executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
