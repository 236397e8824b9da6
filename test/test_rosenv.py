"""The DDS environment every process of this project starts with."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from com_core.runtime.rosenv import FASTDDS_PROFILES

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
