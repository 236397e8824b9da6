"""Environment defaults every process of this project applies before starting DDS."""

from __future__ import annotations

import os
import re
import signal
import threading
from pathlib import Path

__all__ = [
    "FASTDDS_PROFILES",
    "discovery_line",
    "keep_dds_local",
    "start_refusal",
    "stop_on_signals",
    "topic_remaps",
]

FASTDDS_PROFILES = Path(__file__).with_name("fastdds_profiles.xml")
"""The Fast DDS profiles this project's processes load: a service waits up to 2 s, not
100 ms, for a new client's response reader before it answers (the file says why)."""


def keep_dds_local(own_domain: bool = False) -> None:
    """Default DDS discovery to this machine unless the user chose otherwise.

    Call before ``rclpy.init``; child processes inherit the result. A deployment across
    machines sets ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET explicitly; nothing multicasts
    off the machine by accident. ``own_domain`` (benchmarks and tools that start their
    own nodes) also picks a ROS_DOMAIN_ID from the process id when none is set, so
    parallel runs do not cross-talk. Fast DDS loads ``FASTDDS_PROFILES`` unless the user
    names a profiles file of their own.
    """
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(FASTDDS_PROFILES))
    if own_domain:
        os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 1))


def discovery_line() -> str:
    """The DDS discovery this process uses and how to widen it: each node logs it at
    start, so that a driver on another computer that is not seen says why."""
    scope = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "") or "(unset)"
    domain = os.environ.get("ROS_DOMAIN_ID", "") or "0 (unset)"
    line = f"DDS discovery: ROS_AUTOMATIC_DISCOVERY_RANGE={scope}, ROS_DOMAIN_ID={domain}"
    if scope == "LOCALHOST":
        line += (
            ": only nodes on this computer are seen (this project's default when the "
            "variable is unset); a driver on another computer (a robot's controller PC) "
            "needs ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET, or ROS_STATIC_PEERS naming it, set "
            "before every node starts"
        )
    return line


def stop_on_signals(
    signals: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM),
) -> threading.Event:
    """An event set when one of ``signals`` arrives; the handler does nothing else.

    Install it (from the main thread) instead of rclpy's handler (``rclpy.init(...,
    signal_handler_options=SignalHandlerOptions.NO)``) in a node whose main thread spins
    an executor: a KeyboardInterrupt raised inside a callback that C++ called (the
    EventsExecutor) escapes as another error, and the process would end with a traceback
    instead of tearing down. The main loop checks the event between spins.
    """
    stopping = threading.Event()
    for sig in signals:
        signal.signal(sig, lambda _signum, _frame: stopping.set())
    return stopping


_REFUSED_AT_START = re.compile(
    r"Invalid parameter value \(.*\) for parameter\. Reason: (.*): \S+", re.S
)


def start_refusal(error: Exception) -> str:
    """The line a node that cannot start logs for ``error``: for a parameter its check
    refused when declared (rclpy's InvalidParameterValueException), that check's own
    refusal (``com_core.inputs``); else the error's text."""
    text = str(error)
    match = _REFUSED_AT_START.fullmatch(text)
    return match.group(1) if match else text


def topic_remaps(argv: list[str]) -> list[str]:
    """The topic remapping rules (``from:=to``) of ``argv``'s ``--ros-args`` sections, as a
    node's command line gives them (``-r`` / ``--remap``): what a helper process of the node
    takes to hear the same topics. Rules of the node's name or namespace (``__node``,
    ``__ns``) and rules for another node (``node:from:=to``) are left out."""
    rules, in_ros_args, take = [], False, False
    for arg in argv:
        if take:
            source = arg.split(":=", 1)[0]
            if ":=" in arg and not source.startswith("__") and ":" not in source:
                rules.append(arg)
            take = False
        elif arg == "--ros-args":
            in_ros_args = True
        elif arg == "--":
            in_ros_args = False
        elif in_ros_args and arg in ("-r", "--remap"):
            take = True
    return rules
