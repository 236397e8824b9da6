"""The nodes under every input (``fuzz_inputs``), as processes: each parameter set to
each of its values while the node runs, a refused value given at start, and an Explore
goal with each refused option. A value is taken, or refused with a reason that names it;
the node never dies, hangs or logs a traceback or an internal error (``start_node``
fails a test whose node logged one)."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import pytest
from conftest import spin_until
from fuzz_inputs import values_of

from com_core.inputs import Input

pytestmark = [pytest.mark.system, pytest.mark.slow]

rclpy = pytest.importorskip("rclpy")

from com_estimator.estimator_node import PARAMETERS as ESTIMATOR  # noqa: E402
from exploration_sequencer.parameters import PARAMETERS as SEQUENCER  # noqa: E402
from wrench_sim.parameters import PARAMETERS as SIM  # noqa: E402
from wrench_sim.parameters import check_parameter  # noqa: E402

NODES = {
    "sim_node": ("wrench_sim", "wrench_sim", SIM, {"real_time_factor": 1.0}),
    "estimator_node": ("com_estimator", "com_estimator", ESTIMATOR, {}),
    "sequencer_node": ("exploration_sequencer", "exploration_sequencer", SEQUENCER, {}),
}
"""script: (package, node name, its table, parameters it runs with here)."""
UP = {
    "sim_node": "]: ready: ",
    "estimator_node": "]: estimating with ",
    "sequencer_node": "]: ready: ",
}
"""script: what its log says once it took its parameters and runs."""


def parameter(name: str, value: Any):
    """The rclpy Parameter of ``value``, or None when no client could send it (a list of
    mixed types, None, an integer beyond 64 bits)."""
    from rclpy.parameter import Parameter

    if isinstance(value, int) and not -(2**63) <= value < 2**63:
        return None  # beyond int64: no parameter message holds it
    try:
        return Parameter(name, value=value)
    except (TypeError, ValueError, AssertionError):
        return None


def expected_refusal(script: str, row: Input, value: Any) -> bool:
    """The node refuses ``value``: its row does, or the node's checks between values
    (the sim's: a COM offset against the object, a slip against the grasp mode)."""
    if script == "sim_node":
        return bool(check_parameter(row.name, value, {"object": "box", "grasp_mode": "rigid"}))
    return bool(row.problem(value))


@pytest.mark.parametrize("script", NODES)
def test_each_parameter_set_to_each_value_is_taken_or_refused_by_name(
    script, start_node, rclpy_context
):
    from rcl_interfaces.srv import SetParameters

    package, node_name, table, params = NODES[script]
    process = start_node(script, package, params)
    node = rclpy.create_node("fuzz_client", context=rclpy_context)
    client = node.create_client(SetParameters, f"/{node_name}/set_parameters")
    try:
        assert client.wait_for_service(timeout_sec=30.0), f"{node_name} did not come up"
        for name, row in table.items():
            for value in values_of(row, seed=6):
                msg = parameter(name, value)
                if msg is None:
                    continue
                future = client.call_async(
                    SetParameters.Request(parameters=[msg.to_parameter_msg()])
                )
                assert spin_until(node, future.done, 10.0), f"{name}={value!r}: no answer"
                result = future.result().results[0]
                if result.successful:
                    assert not expected_refusal(script, row, value), (name, value)
                    continue
                named = f"{name}={value!r} refused: " in result.reason
                read_only = row.read_only and "read-only" in result.reason
                sensor = "refused: " in result.reason and script == "sim_node"  # the parts
                assert named or read_only or sensor, (name, value, result.reason)
        assert process.poll() is None, f"{node_name} died"
    finally:
        node.destroy_node()


def refused_values(table: dict[str, Input], rng: np.random.Generator, count: int) -> list:
    """``count`` (name, value) a node refuses at start, drawn from every row's values."""
    pool = [
        (name, value)
        for name, row in table.items()
        for value in values_of(row, seed=7)
        if row.problem(value) and parameter(name, value) is not None
    ]
    return [pool[i] for i in rng.choice(len(pool), count, replace=False)]


@pytest.mark.parametrize("script", NODES)
def test_a_value_refused_at_start_ends_the_node_with_its_refusal(script, start_node):
    package, _, table, params = NODES[script]
    for name, value in refused_values(table, np.random.default_rng(8), 3):
        process = start_node(script, package, params | {name: value})
        assert process.wait(timeout=30) == 1, (name, value)
        log = process.log_path.read_text()
        assert f"cannot start: {name}=" in log and " refused: " in log, log


@pytest.mark.parametrize("script", NODES)
def test_values_taken_at_start_run_the_node(script, start_node):
    """Drawn values a node's rows take, several at once: the node runs (its checks
    between values may still refuse them, by name), and ends cleanly on SIGINT."""
    package, _, table, params = NODES[script]
    rng = np.random.default_rng(9)
    started = []
    for _ in range(2):  # side by side
        pool = sorted(set(table) - {"vibration_hz", "vibration_damping"})  # a pair: per mode
        names = [str(n) for n in rng.choice(pool, 6, replace=False)]
        values = {n: values_of(table[n], seed=int(rng.integers(1000)))[-1] for n in names}
        taken = {n: v for n, v in values.items() if not expected_refusal(script, table[n], v)}
        started.append((taken, start_node(script, package, params | taken)))
    for taken, process in started:
        deadline = time.monotonic() + 30.0
        while process.poll() is None and UP[script] not in process.log_path.read_text():
            assert time.monotonic() < deadline, f"{script} neither ran nor ended: {taken}"
            time.sleep(0.1)
        if process.poll() is None:
            continue  # running: stopped (SIGINT, exit 0) at teardown
        log = process.log_path.read_text()
        assert process.returncode == 1, (taken, log)
        assert "cannot start: " in log and " refused: " in log, (taken, log)


GOALS = [
    {"tilt": 3.0},
    {"tilt": math.nan},
    {"max_tilt": -1.0},
    {"dwell": 1e9},
    {"dwell": math.inf},
    {"target_com_sigma": -1e-3},
    {"raise_tilt": 5},
    {"fewer_poses": -128},
    {"information": "everything"},
]


def test_a_goal_with_a_refused_option_is_answered_by_name_at_once(start_node, rclpy_context):
    """Against the sequencer alone: a goal with a refused option is rejected in the goal
    callback at once, the log naming the option and its value."""
    from rclpy.action import ActionClient

    from com_core.contract import EXPLORE_SERVICE
    from com_interfaces.action import Explore

    process = start_node("sequencer_node", "exploration_sequencer")
    node = rclpy.create_node("fuzz_goals", context=rclpy_context)
    client = ActionClient(node, Explore, EXPLORE_SERVICE)
    try:
        assert client.wait_for_server(timeout_sec=30.0), "no ~/explore action"
        for options in GOALS:
            began = time.monotonic()
            sent = client.send_goal_async(Explore.Goal(**options))
            assert spin_until(node, sent.done, 10.0) and not sent.result().accepted, options
            ((name, value),) = options.items()
            said = f"rejected Explore goal: {name}={value!r} refused: "
            assert spin_until(node, lambda s=said: s in process.log_path.read_text(), 5.0)
            assert time.monotonic() - began < 10.0
        assert process.poll() is None
    finally:
        client.destroy()
        node.destroy_node()
