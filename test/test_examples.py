"""Each script of examples/ runs as a user runs it and prints what its docstring says."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import WORKSPACE

EXAMPLES = WORKSPACE / "examples"


def run(name: str) -> str:
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def triple(text: str, after: str) -> np.ndarray:
    """The (x, y, z) after ``after`` in ``text``."""
    m = re.search(re.escape(after) + r" \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", text)
    assert m, text
    return np.array([float(v) for v in m.groups()])


def test_fit_windows_finds_the_object_within_its_error_bars():
    out = run("fit_windows.py")
    mass, sigma_mass = map(float, re.search(r"mass ([\d.]+) \+- ([\d.]+) g", out).groups())
    assert abs(mass - 250.0) < 4 * sigma_mass, out
    com, sigma = triple(out, "COM"), triple(out, "+-")
    assert np.all(np.abs(com - [12.0, -6.0, 110.0]) < 4 * sigma), out
    assert np.all(sigma < 0.5), out  # mm: 500 samples per window of 0.1 N noise


def test_plan_accuracy_meets_the_target_or_says_what_would():
    out = run("plan_accuracy.py")
    line = next(x for x in out.splitlines() if x.startswith("for 0.2 mm"))
    assert max(triple(line, "COM")) <= 0.2 + 1e-9, line
    small = next(x for x in out.splitlines() if x.startswith("tilt 0.05"))
    assert "infeasible" in small and "feasible with tilt >=" in small, small


def test_replay_bag_gives_the_nodes_estimate():
    out = run("replay_bag.py")
    replayed = next(x for x in out.splitlines() if x.startswith("replayed: [OK]"))
    node = next(x for x in out.splitlines() if x.startswith("the node: "))
    # the sample run was recorded on another machine: equal to its last digit or so
    for name in ("COM", "+-"):
        np.testing.assert_allclose(triple(replayed, name), triple(node, name), atol=0.011)


def test_compensate_leaves_the_push_alone():
    out = run("compensate.py")
    contacts = re.findall(r"contact f \[([-\d. ]+)\] N, tau \[([-\d. ]+)\]", out)
    assert len(contacts) == 3, out
    for f, tau in contacts:
        np.testing.assert_allclose([float(v) for v in f.split()], [2.0, 0.0, 0.0], atol=1e-6)
        np.testing.assert_allclose([float(v) for v in tau.split()], 0.0, atol=1e-6)


@pytest.mark.system
def test_the_action_client_without_the_nodes_says_what_it_waits_for_and_gives_up(ros_env):
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / "explore_action.py"), "--wait", "1"],
        env=ros_env,  # a domain of its own: no sequencer on it
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1, done.stdout + done.stderr
    action = "the action server /exploration_sequencer/explore"
    assert done.stdout == f"waiting up to 1 s for {action}\n", done.stdout
    assert done.stderr.startswith("no action server /exploration_sequencer/explore after 1 s: ")
