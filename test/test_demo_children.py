"""The demo reports a node that ended on its own: it stops waiting at once, names the node,
its exit code and its last error line (``last_error_line`` of its log), and exits with 1."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

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


@pytest.mark.parametrize(
    ("flags", "refusal"),
    [
        (["--tilt", "3.0"], "--tilt=3.0 refused: must be in [0.01, pi/2) rad; "),
        (["--mass", "-1"], "--mass=-1.0 refused: must be in [0.001, 5] kg; "),
        (["--mass", "nan"], "--mass=nan refused: must be a finite number [0.001, 5] kg; "),
        (["--sigma-f", "0"], "--sigma-f=0.0 refused: below half the resolution_f 0.0625 N"),
        (["--axes", "y,z"], "--axes=['y', 'z'] refused: must be one of ['y', 'x']"),
        (["--slip-sigma", "1e-3", "--grasp-mode", "friction"], "--slip-sigma=0.001 refused"),
    ],
)
def test_a_flag_without_meaning_is_refused_by_name_before_any_node_starts(
    flags, refusal, tmp_path
):
    bags = tmp_path / "bags"
    done = subprocess.run(
        [sys.executable, "-m", "exploration_sequencer.demo", *flags, "--bag-dir", bags],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    assert f"demo: {refusal}" in done.stderr, done.stderr
    assert "started" not in done.stdout and not bags.exists()


def demo_child(demo: subprocess.Popen, script: str, timeout: float) -> int | None:
    """The PID of the demo's child process that runs ``script``, once it runs."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and demo.poll() is None:
        children = Path(f"/proc/{demo.pid}/task/{demo.pid}/children").read_text().split()
        for pid in children:
            try:
                if script in Path(f"/proc/{pid}/cmdline").read_text():
                    return int(pid)
            except OSError:
                continue
        time.sleep(0.1)
    return None


@pytest.mark.system
def test_the_demo_reports_a_simulator_that_died_at_once(ros_env, tmp_path):
    """The simulator killed while the demo waits for its run: the demo ends within
    seconds, naming it, its exit code and its last line, and exits with 1."""
    bags = tmp_path / "bags"
    demo = subprocess.Popen(
        [sys.executable, "-m", "exploration_sequencer.demo", "--bag-dir", bags],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        sim = demo_child(demo, "sim_node", 30.0)
        assert sim is not None, "the demo did not start the simulator"
        time.sleep(2.0)  # under way
        os.kill(sim, signal.SIGKILL)
        began = time.monotonic()
        out, _ = demo.communicate(timeout=DEMO_DEADLINE)
    except subprocess.TimeoutExpired:
        stop(demo)  # SIGINT: the demo stops its nodes before it ends
        out, _ = demo.communicate()
        pytest.fail(f"the demo still ran {DEMO_DEADLINE:g} s after the simulator died:\n{out}")
    finally:
        if demo.poll() is None:
            stop(demo)
    assert demo.returncode == 1, out
    assert time.monotonic() - began < DEMO_DEADLINE, out
    summary = out.split("=== summary ===", 1)[1].splitlines()
    died = [line for line in summary if line.startswith("exited:   wrench_sim, ")]
    assert died and died[0].startswith("exited:   wrench_sim, exit code -9 (Killed): "), out
    assert died[0].endswith(last_error_line((bags / "logs" / "wrench_sim.log").read_text()))
    assert "is wrench_sim running?" not in out and "no answer within" not in out, out
    assert (bags / "logs" / "exploration_sequencer.log").is_file()
