"""The DDS environment every process of this project starts with."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from com_core.runtime.rosenv import FASTDDS_PROFILES, topic_remaps

SERVE_ONCE = """
from com_core.runtime.rosenv import keep_dds_local
keep_dds_local(own_domain=True)
import os, rclpy
from std_srvs.srv import Trigger
rclpy.init()
node = rclpy.create_node("profiles_check")
node.create_service(Trigger, "check", lambda request, response: response)
print(os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"])
node.destroy_node()
rclpy.shutdown()
"""


@pytest.mark.system
def test_every_process_loads_the_projects_fast_dds_profiles_without_a_parse_error() -> None:
    env = {k: v for k, v in os.environ.items() if k != "FASTRTPS_DEFAULT_PROFILES_FILE"}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    done = subprocess.run(
        [sys.executable, "-c", SERVE_ONCE], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(FASTDDS_PROFILES)
    assert "XMLPARSER" not in done.stderr, done.stderr  # Fast DDS's refusal of a profile


def test_a_users_own_profiles_file_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    from com_core.runtime.rosenv import keep_dds_local

    monkeypatch.setenv("FASTRTPS_DEFAULT_PROFILES_FILE", "/etc/theirs.xml")
    keep_dds_local()
    assert os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] == "/etc/theirs.xml"


def test_a_node_says_which_discovery_it_uses_and_how_to_widen_it(monkeypatch) -> None:
    from com_core.runtime.rosenv import discovery_line

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", "7")
    line = discovery_line()
    assert line.startswith("DDS discovery: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ")
    assert "ROS_DOMAIN_ID=7" in line and "ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET" in line
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    wide = "DDS discovery: ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET, ROS_DOMAIN_ID=7"
    assert discovery_line() == wide


def test_the_topic_remaps_of_a_command_line_are_what_a_helper_process_takes():
    argv = ["sequencer_node", "--ros-args", "-r", "/ft_sensor/wrench:=/fts/wrench",
            "--params-file", "ur5e.yaml", "--remap", "joint_states:=/merged",
            "-r", "__node:=other", "-r", "estimator:/a:=/b", "--", "-r", "x:=y",
            "--ros-args", "-p", "a:=1", "-r", "/clock:=/sim/clock"]  # fmt: skip
    assert topic_remaps(argv) == [
        "/ft_sensor/wrench:=/fts/wrench",
        "joint_states:=/merged",
        "/clock:=/sim/clock",
    ]
    assert topic_remaps(["node"]) == []
