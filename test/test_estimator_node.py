"""The estimator node as a process over DDS: accuracy, online == offline, bad input; the
compensated wrench stream from a payload file, what stops it, and ~/save_payload."""

from __future__ import annotations

import math
import re
import time
from pathlib import Path

import numpy as np
import pybullet_data
import pytest
from conftest import PANDA_JOINTS, replay_json, spin_until

from com_core.contract import (
    COMPENSATED_TOPIC,
    COMPENSATION_STATUS_NAME,
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    ESTIMATE_TOPIC,
    ESTIMATOR_PARAMETERS_SERVICE,
    ESTIMATOR_RESET_SERVICE,
    ESTIMATOR_SAVE_PAYLOAD_SERVICE,
    ESTIMATOR_SOLVE_SERVICE,
    INPUT_STATUS_NAME,
    JOINT_STATES_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    WRENCH_TOPIC,
)
from com_core.estimation.runs.solution import window_counts
from com_core.payload.files import (
    GRAVITY_COMPENSATION_FILE,
    PAYLOAD_FILE,
    URDF_FILE,
    read_payload,
    write_payload_files,
)
from com_core.payload.model import Payload, payload_wrench
from com_core.planning.planner import Plan
from com_core.planning.prediction import predict
from com_core.robot.model import RobotModel
from com_core.sensing.wrench_model import SensorModel

pytestmark = pytest.mark.system

PACKAGE = "com_estimator"
WRENCHES_ONLY = {"information": "wrenches", "accuracy": 0.0}
"""A synthetic stream has no robot model, and its sensor an exact calibration."""
SET_PARAMETERS_SERVICE = ESTIMATOR_PARAMETERS_SERVICE.replace("/get_", "/set_")
TRUTH_MASS, TRUTH_COM = 0.1, (0.01, -0.02, 0.10)


def run_publisher(start_node, *args: str, timeout: float = 60.0, spin=None) -> None:
    """synthetic_exploration with ``args``, to its end; ``spin``: a node spun meanwhile
    (its subscriptions' depth would not hold all that arrives while it waits)."""
    proc = start_node("synthetic_exploration", PACKAGE, args=list(args))
    if spin is not None:
        spin_until(spin, lambda: proc.poll() is not None, timeout)
    assert proc.wait(timeout=timeout) == 0, Path(proc.log_path).read_text()


class Listener:
    """Collects the diagnostics and the node's ~/estimate in the test's rclpy context."""

    def __init__(self, context) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import InertiaStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile

        self.node = rclpy.create_node("test_listener", context=context)
        self.diagnostics: list = []
        self.estimates: list = []
        self.inputs: list = []  # the 1 Hz input status
        self.input_times: list[float] = []  # s, the stamps of the arrays that carried them
        self.compensation: list = []  # the 1 Hz compensation status
        self.node.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self.on_diagnostics, 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(
            InertiaStamped, ESTIMATE_TOPIC, self.estimates.append, latched
        )

    def on_diagnostics(self, msg) -> None:
        self.diagnostics += [s for s in msg.status if s.name == DIAGNOSTIC_NAME]
        inputs = [s for s in msg.status if s.name == INPUT_STATUS_NAME]
        self.inputs += inputs
        if inputs:
            self.input_times.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
        self.compensation += [s for s in msg.status if s.name == COMPENSATION_STATUS_NAME]

    def wait_for_node(self, timeout: float = 30.0) -> None:
        """Until the node's 1 Hz input status arrives: it hears us, we hear it."""
        assert spin_until(self.node, lambda: self.inputs, timeout), "no estimator status"

    def next_status(self, seen: int, timeout: float = 20.0):
        assert spin_until(self.node, lambda: len(self.diagnostics) > seen, timeout), (
            f"no {DIAGNOSTICS_TOPIC} from the estimator"
        )
        status = self.diagnostics[seen]
        return status, {kv.key: kv.value for kv in status.values}

    def call(self, service_type, name: str, request, timeout: float = 10.0):
        client = self.node.create_client(service_type, name)
        assert client.wait_for_service(timeout_sec=timeout), f"{name} not available"
        future = client.call_async(request)
        assert spin_until(self.node, future.done, timeout), f"{name} did not answer"
        return future.result()


@pytest.fixture
def listener(rclpy_context):
    lst = Listener(rclpy_context)
    yield lst
    lst.node.destroy_node()


def test_estimate_is_within_its_sigma_band_and_replay_matches_to_the_bit(
    start_node, listener, ros_env, tmp_path
):
    # the synthetic sensor holds its bias: no drift between tare and object to allow for,
    # so the sigmas are the noise's, which the planner predicts
    steady = {"bias_drift_rate": [0.0, 0.0]}
    start_node("estimator_node", PACKAGE, params=WRENCHES_ONLY | steady)
    listener.wait_for_node()
    bag = tmp_path / "run"
    run_publisher(start_node, "--bag", str(bag), "--seed", "4", "--speed", "3000")
    status, values = listener.next_status(0)
    assert status.level == b"\x00", status.message
    assert any(s.message.startswith("receiving") for s in listener.inputs)
    assert spin_until(listener.node, lambda: listener.estimates, 5.0)
    estimate = listener.estimates[-1].inertia

    # the reported sigmas agree with the planner's prediction for this plan
    plan = Plan(
        dwell=0.5,
        sensor=SensorModel.from_scalars(0.1, 0.005),
        mass_guess=TRUTH_MASS,
        com_guess=TRUTH_COM,
        gravity_home=(0, 0, 1),
    )
    pred = predict(plan)
    sigma_com = np.array([float(values[f"sigma_com_{a}"]) for a in "xyz"])
    np.testing.assert_allclose(sigma_com, pred.sigma_com, rtol=0.15)
    # and the estimate is within 4 of them of the truth
    assert abs(estimate.m - TRUTH_MASS) < 4 * float(values["sigma_mass"])
    com = np.array([estimate.com.x, estimate.com.y, estimate.com.z])
    assert np.all(np.abs(com - TRUTH_COM) < 4 * sigma_com)

    offline = replay_json(bag, ros_env, "--information", "wrenches", "--accuracy", "0.0",
                          "--bias-drift-rate", "0", "0")  # fmt: skip
    assert offline["status"] == "OK" and offline["messages"] == 8050  # 1 s lead-in + run
    node_windows = window_counts(values)
    assert node_windows == offline["window_samples"], "the node lost messages in a window"
    assert set(node_windows.values()) == {500}
    assert offline["mass"] == estimate.m  # bit for bit
    assert offline["com"] == [estimate.com.x, estimate.com.y, estimate.com.z]
    assert offline["sigma_mass"] == float(values["sigma_mass"])
    assert offline["sigma_com"] == sigma_com.tolist()
    assert offline["chi2"] == float(values["chi2"])


BAD_INPUTS = [
    ("nan", "WARN", "5 samples not finite"),
    ("frame", "WARN", "100 samples in frame 'tool0'"),
    ("order", "WARN", "3 samples out of time order"),
    ("duplicate", "WARN", "dropped 3 samples with a duplicate stamp"),
    ("long-label", "WARN", "dropped 1 labels longer than 128 characters (object/xxx"),
    ("no-windows", "ERROR", "no windows: no tare/ or object/ label before the end"),
    ("motion", "WARN", "window 'tilt_x+': motion"),
    ("no-tare", "ERROR", "no tare for pose(s) home, tilt_x+"),
    ("one-pose", "ERROR", "need at least 2 poses"),
]


QUICK = ("--dwell", "0.4", "--rate", "500", "--speed", "4000")
"""A short exploration at 500 Hz, played at 4,000 wrenches per second (wall)."""


def test_every_bad_input_gives_its_status_and_the_node_keeps_serving(start_node, listener):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from std_srvs.srv import Trigger

    start_node("estimator_node", PACKAGE, params=WRENCHES_ONLY)
    listener.wait_for_node()
    # the object moved in the grasp: WARN in the diagnostics, and no estimate on ~/estimate
    run_publisher(start_node, "--shift-sigma", "0.01", *QUICK)
    status, values = listener.next_status(0)
    assert status.level == b"\x01" and "moved in the grasp" in status.message, status.message
    assert "mass" in values  # its numbers, for diagnosis
    spin_until(listener.node, lambda: bool(listener.estimates), 1.0)
    assert not listener.estimates, "an inconsistent fit was published on ~/estimate"
    faults = [fault for fault, _, _ in BAD_INPUTS]  # one exploration each, in order
    run_publisher(start_node, "--fault", *faults, *QUICK, timeout=120.0, spin=listener.node)
    seen = 1
    for fault, level, text in BAD_INPUTS:
        status, _ = listener.next_status(seen)
        seen += 1
        assert status.level == {"WARN": b"\x01", "ERROR": b"\x02"}[level], (fault, status.message)
        assert text in status.message, (fault, status.message)
        assert len(status.message) < 400, status.message  # a long label is never copied whole

    # still serving: a bad parameter is refused, a clean run is OK, services answer
    bad = Parameter(
        name="method",
        value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="least_squares"),
    )
    result = listener.call(
        SetParameters, SET_PARAMETERS_SERVICE, SetParameters.Request(parameters=[bad])
    ).results[0]
    assert not result.successful and "method" in result.reason
    run_publisher(start_node, *QUICK, "--seed", "9")
    status, values = listener.next_status(seen)
    assert status.level == b"\x00", status.message
    assert math.isclose(float(values["mass"]), TRUTH_MASS, rel_tol=0.02)
    solve = listener.call(Trigger, ESTIMATOR_SOLVE_SERVICE, Trigger.Request())
    assert not solve.success and "no windows" in solve.message
    reset = listener.call(Trigger, ESTIMATOR_RESET_SERVICE, Trigger.Request())
    assert reset.success


# --- the compensated stream and the payload files -----------------------------------------

PANDA_URDF = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
JOINTS = PANDA_JOINTS
POSE = dict(zip(JOINTS, (0.3, -0.5, 0.2, -2.0, 0.4, 1.9, 0.6, 0.03, 0.03), strict=True))
"""A still arm; gravity is 27 degrees off the hand's z axis."""
CONTACT = np.array([1.5, -0.7, 2.0, 0.05, -0.12, 0.03])  # N, N m: a push on the held object
SENSOR_START = 1_000_000_000_000  # ns: the sensor time of the first joint state
PERIOD = 10_000_000  # ns: joint states at 100 Hz
WRENCH_LAG = 5_000_000  # ns: a wrench's stamp after the joint state of its tick
MAX_AGE = 50_000_000  # ns: the node's default max_joint_state_age
NO_PAYLOAD = (
    f"{COMPENSATED_TOPIC} not published: no payload: no usable estimate with a kinematic fit "
    "yet and no payload_file"
)


def panda_payload(**changes) -> Payload:
    """An object in the Panda's hand, with a bias, a mounting and a base tilt, in the frames
    the estimator's defaults name (wrenches 'ft_sensor', URDF 'panda_hand', hand
    'panda_hand')."""
    fields = {
        "mass": 0.3,
        "com": np.array([0.01, -0.02, 0.1]),
        "cov": np.diag([1e-6, 4e-8, 9e-8, 1e-7]),
        "hand_mass": 0.73,
        "hand_com": np.array([0.001, -0.002, 0.04]),
        "bias": np.array([0.5, -0.3, 0.2, 0.01, -0.02, 0.005]),
        "mount": np.array([0.02, -0.03, 0.05]),
        "base_tilt": np.array([0.004, -0.003, 0.0]),
        "frame": "ft_sensor",
        "sensor_frame": "panda_hand",
        "base_frame": "panda_link0",
        "information": "kinematics+mount",
        "time": "2026-01-02T03:04:05Z",
        "hand_id": "panda_hand",
    }
    return Payload(**(fields | changes))


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def status_counts(statuses) -> tuple[int, int]:
    """(samples compensated, samples left out) summed over compensation statuses."""
    values = [{kv.key: kv.value for kv in s.values} for s in statuses]
    return (
        sum(int(v.get("compensated", 0)) for v in values),
        sum(int(v.get("stale", 0)) for v in values),
    )


class Arm:
    """The robot as the estimator hears it, from the listener's node: the Panda's URDF on
    /robot_description (latched) and, on each 10 ms tick of a sensor clock that starts at
    SENSOR_START, a joint state of the arm still at POSE and a wrench stamped WRENCH_LAG
    after it (frame 'ft_sensor') that reads ``payload`` at POSE plus CONTACT. ``run``
    queues phases of (ticks, joint states?, wrenches?[, URDF again on the first tick?]);
    with none left, joint states only. Collects /ft_sensor/wrench_compensated in
    ``compensated``."""

    def __init__(self, node, payload: Payload) -> None:
        from geometry_msgs.msg import WrenchStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String

        self._joint_state, self._wrench = JointState, WrenchStamped
        urdf = PANDA_URDF.read_text()
        rotation = RobotModel(urdf, payload.sensor_frame).sensor_rotation(POSE)
        self.reading = payload_wrench(payload, rotation) + CONTACT
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.description = String(data=urdf)
        self.description_pub = node.create_publisher(String, ROBOT_DESCRIPTION_TOPIC, latched)
        self.description_pub.publish(self.description)
        self.joint_pub = node.create_publisher(JointState, JOINT_STATES_TOPIC, 100)
        best_effort = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.wrench_pub = node.create_publisher(WrenchStamped, WRENCH_TOPIC, best_effort)
        self.compensated: list = []
        self.compensated_sub = node.create_subscription(
            WrenchStamped, COMPENSATED_TOPIC, self.compensated.append, best_effort
        )
        self.phases: list[list] = []
        self.tick = 0
        self.joint_stamps: list[int] = []  # ns, as published
        self.wrench_stamps: list[int] = []
        self.node = node
        node.create_timer(PERIOD * 1e-9, self.on_tick)

    def run(self, *phases: tuple) -> None:
        self.phases += [[*p, False][:4] for p in phases]

    @property
    def idle(self) -> bool:
        return not self.phases

    def on_tick(self) -> None:
        joint_states, wrenches = True, False
        if self.phases:
            self.phases[0][0] -= 1
            _, joint_states, wrenches, description = self.phases[0]
            if description:
                self.description_pub.publish(self.description)
                self.phases[0][3] = False
            if self.phases[0][0] <= 0:
                self.phases.pop(0)
        stamp = SENSOR_START + self.tick * PERIOD
        self.tick += 1
        if joint_states:
            msg = self._joint_state(name=list(JOINTS), position=[POSE[n] for n in JOINTS])
            msg.velocity = [0.0] * len(JOINTS)
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
            self.joint_pub.publish(msg)
            self.joint_stamps.append(stamp)
        if wrenches:
            msg = self._wrench()
            msg.header.frame_id = "ft_sensor"
            sec_nsec = divmod(stamp + WRENCH_LAG, 1_000_000_000)
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec_nsec
            f, t = self.reading[:3], self.reading[3:]
            msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = map(float, f)
            msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = map(float, t)
            self.wrench_pub.publish(msg)
            self.wrench_stamps.append(stamp + WRENCH_LAG)

    def wait_for_estimator(self, timeout: float = 10.0) -> None:
        """Until the estimator and the test hear each other on the three streams."""
        assert spin_until(
            self.node,
            lambda: (
                self.wrench_pub.get_subscription_count() > 0
                and self.joint_pub.get_subscription_count() > 0
                and self.compensated_sub.get_publisher_count() > 0
            ),
            timeout,
        ), "the estimator's wrench and joint state subscriptions or its compensated stream"

    def run_to_end(self, listener: Listener, timeout: float = 15.0) -> None:
        """Until the phases are done and two compensation statuses came after them: the
        first may have left before the last samples arrived, the second (1 s later) counts
        every sample they sent, and their compensated messages are in."""
        assert spin_until(self.node, lambda: self.idle, timeout), "the phases did not end"
        seen = len(listener.compensation)
        assert spin_until(self.node, lambda: len(listener.compensation) > seen + 1, 4.0), (
            "no compensation status after the phases"
        )

    def contact_error(self) -> float:
        """N, N m: the largest difference of the compensated stream from CONTACT."""
        errors = [
            np.array([*_xyz(m.wrench.force), *_xyz(m.wrench.torque)]) - CONTACT
            for m in self.compensated
        ]
        return float(np.max(np.abs(errors)))


def _xyz(vector) -> tuple[float, float, float]:
    return vector.x, vector.y, vector.z


def wait_for_compensation_status(listener: Listener, message: str, timeout: float = 15.0):
    """The first compensation status with ``message``."""
    found = lambda: [s for s in listener.compensation if s.message == message]  # noqa: E731
    assert spin_until(listener.node, lambda: bool(found()), timeout), (
        message,
        [s.message for s in listener.compensation],
    )
    return found()[0]


def set_parameter(listener: Listener, name: str, value) -> None:
    """Set one of the estimator's parameters through its set_parameters service."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter

    request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
    result = listener.call(SetParameters, SET_PARAMETERS_SERVICE, request).results[0]
    assert result.successful, result.reason


def save_payload(listener: Listener):
    from std_srvs.srv import Trigger

    return listener.call(Trigger, ESTIMATOR_SAVE_PAYLOAD_SERVICE, Trigger.Request())


def compensating(start_node, listener: Listener, tmp_path: Path):
    """The estimator started with a payload file of ``panda_payload``, the test's arm
    publishing the robot model, and the first compensation status in: (arm, the payload
    file's path, the node's process)."""
    payload = panda_payload()
    path = write_payload_files(tmp_path / "payload", payload)[0]
    arm = Arm(listener.node, payload)
    node = start_node("estimator_node", PACKAGE, params={"payload_file": str(path)})
    listener.wait_for_node()
    arm.wait_for_estimator()
    wait_for_compensation_status(listener, f"0 samples compensated with the payload file {path}")
    return arm, path, node


def test_a_payload_file_compensates_from_the_first_sample_to_the_contact_wrench(
    start_node, listener, tmp_path
):
    """A payload file loaded at start (a payload with a bias, a mounting and a base tilt)
    compensates each sample once the robot model is in: at a still pose with the hand
    tilted, 100 wrenches that read the payload plus a contact wrench come out as the contact
    wrench, every one, in order, with its stamp and frame, and the status counts them as
    compensated with the payload file. Tolerance 1e-9 N (N m): the node computes the same
    forward kinematics and payload wrench from the same doubles as the test, so only the
    rounding of a subtraction from ~10 N readings (~1e-15 N) is left."""
    arm, path, _ = compensating(start_node, listener, tmp_path)
    seen = len(listener.compensation)
    arm.run((100, True, True))
    arm.run_to_end(listener)

    assert [stamp_ns(m.header) for m in arm.compensated] == arm.wrench_stamps
    assert len(arm.wrench_stamps) == 100
    assert {m.header.frame_id for m in arm.compensated} == {"ft_sensor"}
    assert arm.contact_error() < 1e-9
    assert np.max(np.abs(arm.reading - CONTACT)) > 1.0  # the raw stream holds the payload
    statuses = listener.compensation[seen:]
    assert status_counts(statuses) == (100, 0)
    pattern = rf"\d+ samples compensated with the payload file {re.escape(str(path))}"
    for status in statuses:
        assert status.level == b"\x00" and re.fullmatch(pattern, status.message), status


def test_without_a_payload_nothing_is_compensated_and_save_payload_says_why(
    start_node, listener, tmp_path
):
    """No usable estimate and no payload file: with the robot model, joint states and 1 s
    of wrenches all heard, nothing is published on the compensated topic, the compensation
    status is WARN and says there is no payload, and ~/save_payload answers false saying
    so, writing nothing."""
    arm = Arm(listener.node, panda_payload())
    start_node("estimator_node", PACKAGE)
    listener.wait_for_node()
    arm.wait_for_estimator()
    seen, heard = len(listener.compensation), len(listener.inputs)
    arm.run((100, True, True))
    arm.run_to_end(listener)

    assert arm.compensated == []
    assert any(s.message.startswith("receiving") for s in listener.inputs[heard:]), [
        s.message for s in listener.inputs[heard:]
    ]
    statuses = listener.compensation[seen:]
    assert statuses
    for status in statuses:
        assert status.level == b"\x01" and status.message == NO_PAYLOAD, status
    directory = tmp_path / "saved"
    set_parameter(listener, "payload_save_dir", str(directory))
    answer = save_payload(listener)
    assert not answer.success
    assert answer.message == "no payload: no usable estimate with a kinematic fit yet"
    assert not directory.exists()


def _unparsable(directory: Path) -> Path:
    path = directory / PAYLOAD_FILE
    path.write_text("mass: [0.3\ncom: {\n")
    return path


def _mass_not_a_number(directory: Path) -> Path:
    path = write_payload_files(directory, panda_payload())[0]
    text = path.read_text()
    assert "\nmass: 0.3\n" in text
    path.write_text(text.replace("\nmass: 0.3\n", "\nmass: heavy\n"))
    return path


def _payload_of(**changes):
    return lambda directory: write_payload_files(directory, panda_payload(**changes))[0]


REFUSED_FILES = {
    "yaml": (_unparsable, "{path}: does not parse as YAML"),
    "field": (_mass_not_a_number, "{path}: field 'mass' must be a number, got 'heavy'"),
    "frame": (
        _payload_of(frame="tool0"),
        "{path}: field 'frame' is 'tool0', expected 'ft_sensor'",
    ),
    "hand": (
        _payload_of(hand_id="other_hand"),
        "{path}: field 'hand_id' is 'other_hand', expected 'panda_hand'",
    ),
    "sensor_frame": (
        _payload_of(sensor_frame="panda_link8"),
        "field 'sensor_frame' is 'panda_link8', this estimator's sensor_frame 'panda_hand'",
    ),
}


@pytest.mark.parametrize("case", list(REFUSED_FILES))
def test_a_refused_payload_file_is_an_error_and_the_node_runs_on(
    start_node, listener, tmp_path, case
):
    """A payload file that does not parse (as YAML, or a field), or is of another wire frame,
    hand or URDF sensor frame than the node's expected_frame, hand_id and sensor_frame: an
    ERROR at start says the file was refused and names the field (or the YAML error); the
    node runs on (its input status every 1 s +-0.25 s, a scheduling margin; the wrenches
    heard), publishes nothing compensated, and its compensation status is WARN with the
    refusal, robot model or not."""
    write, problem = REFUSED_FILES[case]
    path = write(tmp_path)
    refusal = f"payload_file {path} refused: " + problem.format(path=path)
    arm = Arm(listener.node, panda_payload())
    node = start_node("estimator_node", PACKAGE, params={"payload_file": str(path)})
    listener.wait_for_node()
    arm.wait_for_estimator()
    arm.run((50, True, True))
    arm.run_to_end(listener)
    assert spin_until(listener.node, lambda: len(listener.input_times) >= 3, 3.0)

    assert node.poll() is None
    gaps = np.diff(listener.input_times)
    assert np.all(np.abs(gaps - 1.0) < 0.25), gaps
    assert any(s.message.startswith("receiving") for s in listener.inputs)
    assert arm.compensated == []
    statuses = listener.compensation
    assert len(statuses) >= 2
    for status in statuses:
        expected = f"{COMPENSATED_TOPIC} not published: {refusal}"
        assert status.level == b"\x01" and status.message.startswith(expected), status
    log = Path(node.log_path).read_text()
    assert re.search(
        rf"^\[ERROR\] \[[\d.]+\] \[com_estimator\]: {re.escape(refusal)}", log, re.M
    ), log


def test_samples_past_the_joint_states_are_left_out_and_counted_until_they_return(
    start_node, listener, tmp_path
):
    """Joint states stop for 0.3 s while the wrenches go on: the wrenches stamped more than
    max_joint_state_age (0.05 s) past the latest joint state (26 of the 30: the first 4 are
    within it, at 15 to 45 ms) are not compensated, and the status is WARN with their count
    left out; when the joint states return, every wrench is compensated again (an OK status
    with only those). Every compensated one is the contact wrench to 1e-9 N (N m), the
    rounding of the subtraction (see the payload file test)."""
    arm, path, _ = compensating(start_node, listener, tmp_path)
    seen = len(listener.compensation)
    arm.run((50, True, True), (30, False, True), (250, True, True))
    arm.run_to_end(listener, timeout=20.0)

    def latest_joint_state(stamp: int) -> int:
        return max(j for j in arm.joint_stamps if j <= stamp)

    left_out = [w for w in arm.wrench_stamps if w - latest_joint_state(w) > MAX_AGE]
    assert len(left_out) == 26 and len(arm.wrench_stamps) == 330
    expected = [w for w in arm.wrench_stamps if w not in set(left_out)]
    assert [stamp_ns(m.header) for m in arm.compensated] == expected
    assert arm.contact_error() < 1e-9
    statuses = listener.compensation[seen:]
    assert status_counts(statuses) == (304, 26)
    warned = [k for k, s in enumerate(statuses) if s.level == b"\x01"]
    assert warned, [s.message for s in statuses]
    source = re.escape(str(path))
    for k in warned:
        left = status_counts([statuses[k]])[1]
        assert left > 0 and re.fullmatch(
            rf"\d+ samples compensated with the payload file {source}; {left} left out: "
            r"joint states older than 0\.05 s at their stamps",
            statuses[k].message,
        ), statuses[k].message
    resumed = [s for s in statuses[warned[-1] + 1 :] if status_counts([s])[0] > 0]
    assert resumed, [s.message for s in statuses]
    assert all(s.level == b"\x00" for s in resumed), [s.message for s in resumed]


def test_save_payload_writes_the_payload_files_or_answers_why_not(start_node, listener, tmp_path):
    """~/save_payload of the payload file's payload: with payload_save_dir unset, or set
    under a regular file (unwritable, even for root), it answers false with the reason and
    the path; set to a new directory, it writes payload.yaml, gravity_compensation.yaml and
    payload.urdf there, the same text as the files loaded, and payload.yaml reads back to
    the same mass and COM, bit for bit."""
    payload = panda_payload()
    loaded = write_payload_files(tmp_path / "payload", payload)
    start_node("estimator_node", PACKAGE, params={"payload_file": str(loaded[0])})
    listener.wait_for_node()

    answer = save_payload(listener)
    assert not answer.success and answer.message == "payload_save_dir is not set"
    (tmp_path / "file").write_text("not a directory")
    unwritable = tmp_path / "file" / "sub"
    set_parameter(listener, "payload_save_dir", str(unwritable))
    answer = save_payload(listener)
    assert not answer.success and answer.message.startswith("not written: "), answer.message
    assert f"cannot write the payload files: {unwritable}: Not a directory" in answer.message
    assert not unwritable.exists()

    directory = tmp_path / "saved"
    set_parameter(listener, "payload_save_dir", str(directory))
    answer = save_payload(listener)
    names = (PAYLOAD_FILE, GRAVITY_COMPENSATION_FILE, URDF_FILE)
    assert answer.success, answer.message
    assert answer.message == ", ".join(str(directory / n) for n in names)
    assert sorted(p.name for p in directory.iterdir()) == sorted(names)
    for name, source in zip(names, loaded, strict=True):
        assert (directory / name).read_text() == source.read_text(), name
    saved = read_payload(directory / PAYLOAD_FILE)
    assert saved.mass == payload.mass
    assert saved.com.tolist() == payload.com.tolist()


def test_the_robot_model_received_again_keeps_the_joint_states_and_the_counts(
    start_node, listener, tmp_path
):
    """/robot_description received again mid-stream (a restarted robot_state_publisher; a
    new estimate takes the same path): the compensation goes on with the joint states it
    had, so the 3 wrenches after it, before the next joint state (15 to 35 ms past the
    latest, within max_joint_state_age), are compensated too, and the statuses count every
    sample, none left out. The node logs the model and the compensation's start twice."""
    arm, _, node = compensating(start_node, listener, tmp_path)
    seen = len(listener.compensation)
    arm.run((50, True, True), (3, False, True, True), (47, True, True))
    arm.run_to_end(listener)

    log = Path(node.log_path).read_text()
    assert log.count("robot model 'panda': panda_hand") == 2, log
    assert log.count(f"publishing {COMPENSATED_TOPIC}: ") == 2, log
    assert [stamp_ns(m.header) for m in arm.compensated] == arm.wrench_stamps
    assert len(arm.wrench_stamps) == 100
    assert arm.contact_error() < 1e-9
    statuses = listener.compensation[seen:]
    assert status_counts(statuses) == (100, 0), [s.message for s in statuses]


def test_a_run_is_solved_once_the_arms_joint_states_pass_its_done(start_node, listener):
    """A run's ``done`` waits for its input: with the kinematic information, for the
    joint states of the arm as for the wrenches (each publisher's stream comes on its own,
    and under load a reliable one's lost sample comes again seconds later). The wrenches
    pass ``done`` at once while the arm's joint states stop 0.1 s before it for 0.5 s; the
    run is solved only once they pass it, not at the wrenches, and not at solve_timeout."""
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from std_msgs.msg import Header

    from com_core.contract import DONE, POSE_TOPIC

    arm = Arm(listener.node, panda_payload())
    start_node("estimator_node", PACKAGE)
    listener.wait_for_node()
    arm.wait_for_estimator()
    labels = listener.node.create_publisher(
        Header, POSE_TOPIC, QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    )
    first = arm.tick  # the ticks of the run: joint states and wrenches, then wrenches alone
    for label, tick in (("tare/home", first + 10), (DONE, first + 60)):
        msg = Header(frame_id=label)
        msg.stamp.sec, msg.stamp.nanosec = divmod(SENSOR_START + tick * PERIOD, 1_000_000_000)
        labels.publish(msg)
    seen = len(listener.diagnostics)
    arm.run((50, True, True), (50, False, True))
    assert spin_until(listener.node, lambda: arm.idle, 5.0), "the phases did not end"
    assert len(listener.diagnostics) == seen, "solved before the arm's joint states passed done"
    resumed = time.monotonic()  # the arm's joint states from the next tick on
    status, _ = listener.next_status(seen, timeout=3.0)
    assert time.monotonic() - resumed < 2.0  # at them, not at solve_timeout (4 s)
    assert status.message.startswith("no object windows"), status.message
