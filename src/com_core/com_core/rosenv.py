"""Environment defaults every process of this project applies before starting DDS."""

from __future__ import annotations

import os

__all__ = ["keep_dds_local"]


def keep_dds_local() -> None:
    """Default DDS discovery to this machine unless the user chose otherwise.

    Call before ``rclpy.init``. A deployment across machines sets
    ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET explicitly; nothing multicasts off the machine
    by accident.
    """
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
