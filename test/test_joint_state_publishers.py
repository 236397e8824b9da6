"""/joint_states from two publishers, as a real set-up has them: the three nodes with a
gripper's own publisher of its joints at 30 Hz beside the sim's (gripper_joint_states.py)."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from conftest import PANDA, defect_logged, log_tail, replay_json, unclean_exit
from test_sequencer_node import (  # noqa: F401 - client: the fixture
    assert_replays_to_node,
    client,
    start_system,
)

from com_core.bags.reader import read_raw
from com_core.contract import JOINT_STATES_TOPIC
from com_core.estimation.cutting import window_sample_counts
from com_core.estimation.solution import window_counts
from com_core.report.run import read_run
from com_core.runtime.processes import stop

pytestmark = pytest.mark.system

HELPER = Path(__file__).with_name("gripper_joint_states.py")
GRIPPER_RATE = 30.0
"""Hz (sim time): a gripper's own joint state publisher (franka_ros2 merges at 30 Hz)."""


@pytest.fixture
def gripper_publisher(
    ros_env: dict[str, str], tmp_path: Path, request: pytest.FixtureRequest
) -> Iterator[Callable[[tuple[str, ...], float], subprocess.Popen]]:
    """Starts gripper_joint_states.py (joint names, rate Hz) as a process; stopped at
    teardown however the test ended (``stop``: SIGINT, then SIGTERM, then SIGKILL); it
    must run until then and end on SIGINT cleanly, or the test errors."""
    started: list[tuple[subprocess.Popen, Path]] = []

    def start(names: tuple[str, ...], rate: float) -> subprocess.Popen:
        log_path = tmp_path / f"gripper_joint_states-{len(started)}.log"
        with open(log_path, "w") as log:
            process = subprocess.Popen(
                [sys.executable, str(HELPER), repr(rate), *names],
                env=ros_env,
                stdout=log,
                stderr=subprocess.STDOUT,
                cwd=tmp_path,
            )
        started.append((process, log_path))
        return process

    yield start
    unclean = []
    for process, log_path in started:
        sig = stop(process)
        log = log_path.read_text(errors="replace")
        why = unclean_exit(process, sig, log) or defect_logged(log)
        if sig is None:
            why = why or f"ended before the test did, exit code {process.returncode}"
        if why:
            unclean.append(f"{log_path.name}: {why}")
            print(f"\n----- {log_path.name} -----\n{log_tail(log_path)}")
    failed = getattr(getattr(request.node, "rep_call", None), "failed", False)
    if unclean and not failed:
        pytest.fail("the gripper's publisher did not stop cleanly: " + "; ".join(unclean))


def joint_state_messages(bag: Path) -> list[tuple[int, tuple[str, ...]]]:
    """(stamp ns, names) of every /joint_states message the bag holds, in recorded order."""
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    out = []
    for _, msgtype, _, raw in read_raw(bag, (JOINT_STATES_TOPIC,)):
        msg = typestore.deserialize_cdr(raw, msgtype)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        out.append((stamp, tuple(msg.name)))
    return out


def test_a_grippers_own_joint_state_publisher_beside_the_arms(
    start_node,
    client,  # noqa: F811
    gripper_publisher,
    tmp_path,
    ros_env,
):
    """The sequencer and the estimator merge the joint states per joint: the run is OK,
    its mass within 3 sigma of the truth; the bag holds the gripper's messages at 30 Hz
    (sim time), and its replay gives the node's estimate to the bit (when the bag holds
    every wrench the node used)."""
    start_system(start_node, tmp_path, {"object": "box", "seed": 6})
    gripper_publisher(PANDA.gripper_joints, GRIPPER_RATE)
    result = client.wait(client.call())
    assert result.success and result.message.startswith("[OK]"), result.message

    mass = float(re.search(r"mass ([\d.]+)", result.message).group(1)) * 1e-3
    sigma_mass = float(re.search(r"mass [\d.]+ \+- ([\d.]+)", result.message).group(1)) * 1e-3
    truth = [t for t in client.truths if abs(t.inertia.com.z) < 0.2][-1].inertia  # held
    assert abs(mass - truth.m) < 3 * sigma_mass + 1e-5, (mass, truth.m, sigma_mass)

    bag = Path(re.search(r"; bag (\S+)", result.message).group(1))
    messages = joint_state_messages(bag)
    gripper = sorted(stamp for stamp, names in messages if names == PANDA.gripper_joints)
    assert len(gripper) > 100 and len(gripper) < len(messages) / 2, len(gripper)
    rate = (len(gripper) - 1) / ((gripper[-1] - gripper[0]) * 1e-9)
    assert 0.8 * GRIPPER_RATE < rate < 1.05 * GRIPPER_RATE, rate

    run = read_run(bag)
    values = run.diagnostic["values"]
    offline = replay_json(bag, ros_env)
    assert offline["status"] == "OK" and offline["information"] == "kinematics+mount", offline
    if window_sample_counts(run.stamps, run.labels, run.done_ns) != window_counts(values):
        # a recording that lost wrenches the node used (its start) replays within what
        # those carry; the joint states, reliable, are whole either way
        assert_replays_to_node(bag, offline)
        return
    assert offline["mass"] == float(values["mass"])
    assert offline["com"] == [float(values[f"com_{axis}"]) for axis in "xyz"]
