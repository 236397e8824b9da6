"""A demo ended by a signal leaves no node running: SIGTERM and SIGHUP end it as Ctrl-C
does (the run cancelled, the nodes stopped, the sequencer first); after SIGKILL its nodes
stop on their own, as on Ctrl-C, the sequencer before the others
(``com_core.runtime.lifeline``). The lifeline is tested first, without ROS."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from conftest import defect_logged, log_tail

from com_core.runtime.lifeline import Lifeline

GONE_WITHIN = 10.0  # s after the signal by which no node of the demo may run
NODES = ("sim_node", "estimator_node", "sequencer_node")
PACKAGES = ("wrench_sim", "com_estimator", "exploration_sequencer")

WATCHER = """
import signal, sys, time
from com_core.runtime.lifeline import stop_with_parent
stopped = []
signal.signal(signal.SIGINT, lambda *_: stopped.append(True))
if stop_with_parent(lambda line: print(line, flush=True)) is None:
    print("not watching", flush=True)
    sys.exit(0)
print("watching", flush=True)
while not stopped:
    time.sleep(0.02)
print("stopped", flush=True)
time.sleep(float(sys.argv[1]))  # the way back of a cancelled run
"""
"""A node in miniature: stops (after argv[1] s) on SIGINT, which its lifeline sends."""


def watcher(linger: float, **popen: object) -> subprocess.Popen:
    """WATCHER as a process, its output on a pipe; ``popen``: a lifeline's kwargs."""
    return subprocess.Popen(
        [sys.executable, "-c", WATCHER, str(linger)],
        stdout=subprocess.PIPE,
        text=True,
        **popen,  # type: ignore[arg-type]
    )


BY_HAND = """
import os, sys
from com_core.runtime.lifeline import LIFELINE_ENV, stop_with_parent
for value in sys.argv[1:]:  # '-': none
    os.environ.pop(LIFELINE_ENV, None)
    if value != "-":
        os.environ[LIFELINE_ENV] = value
    print(stop_with_parent(print) is None, LIFELINE_ENV in os.environ)
"""


def test_a_process_started_without_a_lifeline_watches_none():
    """No variable, or one that names no pipe (not a number, stdin, a closed descriptor):
    nothing watched, and the variable is not passed on."""
    done = subprocess.run(
        [sys.executable, "-c", BY_HAND, "-", "x", "0", "987"],
        stdin=subprocess.DEVNULL,  # fd 0 is no pipe
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.stdout == "True False\n" * 4, done.stdout + done.stderr


def test_a_node_stops_once_its_starter_and_the_node_that_holds_its_lifeline_ended():
    """The sequencer's place holds the simulator's lifeline: when the starter ends, the
    sequencer stops at once; the simulator only once the sequencer has ended too."""
    first, last = Lifeline(), Lifeline()
    sim = watcher(0.0, **first.popen_kwargs())
    sequencer = watcher(1.0, **last.popen_kwargs(holding=first))
    try:
        assert sim.stdout.readline() == "watching\n"
        assert sequencer.stdout.readline() == "watching\n"
        first.close()
        last.close()  # as the starter's end does
        said = sequencer.stdout.readline()
        assert said.startswith(f"the process that started this one (pid {os.getpid()}) ended")
        assert sequencer.stdout.readline() == "stopped\n"
        assert sim.poll() is None  # its lifeline held by the sequencer, still lingering
        assert sequencer.wait(timeout=10.0) == 0
        out, _ = sim.communicate(timeout=5.0)
        assert sim.returncode == 0 and out.endswith("ended: stopping\nstopped\n"), out
    finally:
        for process in (sim, sequencer):
            if process.poll() is None:
                process.kill()
            process.communicate()
        first.close()
        last.close()


def start_time(pid: int) -> str | None:
    """The start time of process ``pid`` (/proc/<pid>/stat, field 22), None when it is
    gone or a zombie (it has ended, not yet reaped)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return None if fields[0] in ("Z", "X") else fields[19]


def node_processes(demo: subprocess.Popen, timeout: float) -> dict[str, tuple[int, str]]:
    """The demo's node processes by script, once all of NODES run: their pid and start
    time (a pid the system gives another process later is not taken for a node)."""
    found: dict[str, tuple[int, str]] = {}
    deadline = time.monotonic() + timeout
    while len(found) < len(NODES) and time.monotonic() < deadline and demo.poll() is None:
        for pid in Path(f"/proc/{demo.pid}/task/{demo.pid}/children").read_text().split():
            try:
                command = Path(f"/proc/{pid}/cmdline").read_text()
            except OSError:
                continue
            for script in NODES:
                if f"/{script}\0" in command and (started := start_time(int(pid))):
                    found[script] = (int(pid), started)
        time.sleep(0.1)
    return found


def running(nodes: dict[str, tuple[int, str]]) -> list[str]:
    """The scripts of ``nodes`` whose process still runs."""
    return [s for s, (pid, started) in nodes.items() if start_time(pid) == started]


def wait_until(predicate: Callable[[], bool], timeout: float) -> bool:
    """Whether ``predicate()`` became true within ``timeout`` s (checked every 0.1 s)."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


@pytest.mark.system
@pytest.mark.parametrize(
    "sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGKILL], ids=lambda s: s.name
)
def test_a_demo_ended_by_a_signal_mid_run_leaves_no_node_running(sig, ros_env, tmp_path):
    bags = tmp_path / "bags"
    output = tmp_path / "demo.out"
    with open(output, "w") as out:
        demo = subprocess.Popen(
            [sys.executable, "-m", "exploration_sequencer.demo", "--bag-dir", bags],
            env=ros_env,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    nodes: dict[str, tuple[int, str]] = {}
    try:
        nodes = node_processes(demo, 60.0)
        assert set(nodes) == set(NODES), output.read_text()
        # the run under way, the arm away from home: the tare pass's first tilt
        tilted = "window tare/tilt"
        wait_until(lambda: tilted in output.read_text() or demo.poll() is not None, 90.0)
        assert tilted in output.read_text() and demo.poll() is None, output.read_text()
        demo.send_signal(sig)
        signalled = time.monotonic()
        wait_until(lambda: not running(nodes), GONE_WITHIN)
        left = running(nodes)
        assert not left, f"{left} still ran {time.monotonic() - signalled:.1f} s after {sig.name}"
        code = demo.wait(timeout=10.0)
    except BaseException:
        print(output.read_text())
        for package in PACKAGES:
            print(f"----- {package}.log -----\n{log_tail(bags / 'logs' / f'{package}.log')}")
        raise
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.wait()
        for script in running(nodes):
            os.kill(nodes[script][0], signal.SIGKILL)
    said = output.read_text()
    logs = {p: (bags / "logs" / f"{p}.log").read_text(errors="replace") for p in PACKAGES}
    assert not [f"{p}: {why}" for p, log in logs.items() if (why := defect_logged(log))]
    # the run cancelled, the arm home (the simulator still ran), the bag closed
    sequencer = logs["exploration_sequencer"]
    assert "cancelled while" in sequencer and "recorded " in sequencer, sequencer
    assert "moving it home after the cancel" in sequencer, sequencer
    assert "not back home after the cancel" not in sequencer, sequencer
    if sig == signal.SIGKILL:
        assert code == -sig
        for package, log in logs.items():
            assert "ended: stopping" in log, f"{package}:\n{log}"
    else:
        assert code == 128 + sig, said
        assert f"demo: {sig.name}: cancelling the run" in said, said
        assert "explore: [CANCELLED] " in said, said
