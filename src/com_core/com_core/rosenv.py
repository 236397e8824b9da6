"""Environment defaults every process of this project applies before starting DDS."""

from __future__ import annotations

import os

__all__ = ["keep_dds_local"]


def keep_dds_local(own_domain: bool = False) -> None:
    """Default DDS discovery to this machine unless the user chose otherwise.

    Call before ``rclpy.init``; child processes inherit the result. A deployment across
    machines sets ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET explicitly; nothing multicasts
    off the machine by accident. ``own_domain`` (benchmarks and tools that start their
    own nodes) also picks a ROS_DOMAIN_ID from the process id when none is set, so
    parallel runs do not cross-talk.
    """
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if own_domain:
        os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 1))
