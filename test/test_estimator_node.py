"""The estimator node as a process over DDS: accuracy, online == offline, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import replay_json, spin_until

from com_core.contract import (
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    ESTIMATE_TOPIC,
    ESTIMATOR_PARAMETERS_SERVICE,
    ESTIMATOR_RESET_SERVICE,
    ESTIMATOR_SOLVE_SERVICE,
    INPUT_STATUS_NAME,
)
from com_core.planner import Plan, predict
from com_core.wrench_model import SensorModel

pytestmark = pytest.mark.system

PACKAGE = "com_estimator"
WRENCHES_ONLY = {"information": "wrenches"}  # a synthetic stream has no robot model
SET_PARAMETERS_SERVICE = ESTIMATOR_PARAMETERS_SERVICE.replace("/get_", "/set_")
TRUTH_MASS, TRUTH_COM = 0.1, (0.01, -0.02, 0.10)


def run_publisher(start_node, *args: str, timeout: float = 60.0) -> None:
    proc = start_node("synthetic_exploration", PACKAGE, args=list(args))
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
        self.node.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self.on_diagnostics, 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(
            InertiaStamped, ESTIMATE_TOPIC, self.estimates.append, latched
        )

    def on_diagnostics(self, msg) -> None:
        self.diagnostics += [s for s in msg.status if s.name == DIAGNOSTIC_NAME]
        self.inputs += [s for s in msg.status if s.name == INPUT_STATUS_NAME]

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
    start_node("estimator_node", PACKAGE, params=WRENCHES_ONLY)
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

    offline = replay_json(bag, ros_env, "--information", "wrenches")
    assert offline["status"] == "OK" and offline["messages"] == 8050  # 1 s lead-in + run
    node_windows = {
        k.split(" ", 1)[1]: int(v) for k, v in values.items() if k.startswith("samples ")
    }
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


def test_every_bad_input_gives_its_status_and_the_node_keeps_serving(start_node, listener):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from std_srvs.srv import Trigger

    start_node("estimator_node", PACKAGE, params=WRENCHES_ONLY)
    listener.wait_for_node()
    # the object moved in the grasp: WARN in the diagnostics, and no estimate on ~/estimate
    run_publisher(start_node, "--shift-sigma", "0.01", "--dwell", "0.4", "--speed", "4000")
    status, values = listener.next_status(0)
    assert status.level == b"\x01" and "moved in the grasp" in status.message, status.message
    assert "mass" in values  # its numbers, for diagnosis
    spin_until(listener.node, lambda: bool(listener.estimates), 1.0)
    assert not listener.estimates, "an inconsistent fit was published on ~/estimate"
    seen = 1
    for fault, level, text in BAD_INPUTS:
        run_publisher(start_node, "--fault", fault, "--dwell", "0.4", "--speed", "4000")
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
    run_publisher(start_node, "--dwell", "0.4", "--speed", "4000", "--seed", "9")
    status, values = listener.next_status(seen)
    assert status.level == b"\x00", status.message
    assert math.isclose(float(values["mass"]), TRUTH_MASS, rel_tol=0.02)
    solve = listener.call(Trigger, ESTIMATOR_SOLVE_SERVICE, Trigger.Request())
    assert not solve.success and "no windows" in solve.message
    reset = listener.call(Trigger, ESTIMATOR_RESET_SERVICE, Trigger.Request())
    assert reset.success
