"""/joint_states from two publishers, as a real set-up has them: the sim publishes the arm's
joints and, from a publisher of its own at 30 Hz, the gripper's, and the three nodes run on
them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import PANDA, replay_json
from test_sequencer_node import (  # noqa: F401 - client: the fixture
    assert_replays_to_node,
    client,
    start_system,
)

from com_core.bags.reader import read_raw
from com_core.contract import JOINT_STATES_TOPIC
from com_core.estimation.runs.cutting import window_sample_counts
from com_core.estimation.runs.solution import window_counts
from com_core.report.run import read_run

pytestmark = pytest.mark.system

GRIPPER_RATE = PANDA.gripper_joint_state_rate
"""Hz (sim time): the sim's gripper publisher, as a gripper's own driver (30 Hz)."""


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
    tmp_path,
    ros_env,
):
    """The sequencer and the estimator merge the joint states per joint: the run is OK,
    its mass within 3 sigma of the truth; the bag holds the gripper's messages at 30 Hz
    (sim time), and its replay gives the node's estimate to the bit (when the bag holds
    every wrench the node used)."""
    start_system(start_node, tmp_path, {"object": "box", "seed": 6})
    result = client.wait(client.call())
    assert result.success and result.message.startswith("[OK]"), result.message

    mass = float(re.search(r"mass ([\d.]+)", result.message).group(1)) * 1e-3
    sigma_mass = float(re.search(r"mass [\d.]+ \+- ([\d.]+)", result.message).group(1)) * 1e-3
    truth = client.held()[0]
    assert abs(mass - truth) < 3 * sigma_mass + 1e-5, (mass, truth, sigma_mass)

    bag = Path(re.search(r"; bag (\S+)", result.message).group(1))
    messages = joint_state_messages(bag)
    gripper = sorted(stamp for stamp, names in messages if names == PANDA.gripper_joints)
    assert len(gripper) > 100 and len(gripper) < len(messages) / 2, len(gripper)
    assert all(names in (PANDA.arm_joints, PANDA.gripper_joints) for _, names in messages)
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
