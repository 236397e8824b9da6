"""The demo reports a node that ended on its own: it stops waiting at once, names the node,
its exit code and its last error line (``last_error_line`` of its log), and exits with 1."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from com_core.runtime.processes import last_error_line, stop

DEMO_DEADLINE = 30.0  # s for the demo to see the simulator end, report it and stop the rest

ROS_LOG = """\
[INFO] [1.0] [wrench_sim]: loading the robot
[ERROR] [2.0] [wrench_sim]: the first error
[WARN] [3.0] [wrench_sim]: a warning
[ERROR] [4.0] [wrench_sim]: cannot start: object_mass out of range
[INFO] [5.0] [wrench_sim]: shutting down

"""


def test_last_error_line_is_the_last_error_line():
    assert (
        last_error_line(ROS_LOG)
        == "[ERROR] [4.0] [wrench_sim]: cannot start: object_mass out of range"
    )


def test_last_error_line_counts_a_fatal_line_as_an_error():
    log = ROS_LOG + "[FATAL] [6.0] [wrench_sim]: gave up\n[INFO] [7.0] [wrench_sim]: bye\n"
    assert last_error_line(log) == "[FATAL] [6.0] [wrench_sim]: gave up"


def test_last_error_line_without_errors_is_the_last_non_empty_line():
    traceback = (
        "[WARN] [1.0] [exploration_sequencer]: slow start\n"
        "Traceback (most recent call last):\n"
        '  File "node.py", line 1, in <module>\n'
        "ValueError: no such robot  \n"
        "\n  \n"
    )
    assert last_error_line(traceback) == "ValueError: no such robot"


def test_last_error_line_of_no_output_is_empty():
    assert last_error_line("") == ""
    assert last_error_line("\n \n") == ""


@pytest.mark.system
def test_the_demo_reports_a_simulator_that_refuses_its_mass(ros_env, tmp_path):
    bags = tmp_path / "bags"
    began = time.monotonic()
    demo = subprocess.Popen(
        [sys.executable, "-m", "exploration_sequencer.demo", "--mass", "-1", "--bag-dir", bags],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        out, _ = demo.communicate(timeout=DEMO_DEADLINE)
    except subprocess.TimeoutExpired:
        stop(demo)  # SIGINT: the demo stops its nodes before it ends
        out, _ = demo.communicate()
        pytest.fail(f"the demo still ran after {DEMO_DEADLINE:g} s:\n{out}")
    wall = time.monotonic() - began
    assert demo.returncode == 1, out
    assert wall < DEMO_DEADLINE, out
    assert "=== summary ===" in out, out
    summary = out.split("=== summary ===", 1)[1].splitlines()
    # the sequencer may refuse its mass_guess as well: one line per node that ended
    sim = [line for line in summary if line.startswith("exited:   wrench_sim, ")]
    assert len(sim) == 1, out
    assert sim[0].startswith("exited:   wrench_sim, exit code 1: [ERROR] "), out
    assert "cannot start" in sim[0] and "object_mass" in sim[0] and "-1" in sim[0], out
    assert sim[0].endswith(last_error_line((bags / "logs" / "wrench_sim.log").read_text()))
    # the run did not go on without the simulator
    assert "is wrench_sim running?" not in out and "no answer within" not in out, out
    assert (bags / "logs" / "exploration_sequencer.log").is_file()
