"""Node processes started from their console scripts, as ``ros2 run`` would, and stopped.

The demo, the benchmarks and the system tests start the nodes as processes (there are no
launch files); these are the one way they do it. ``ros_args`` writes parameters as
``--ros-args -p name:=value`` (after a ``--params-file``, such as a robot configuration);
``stop`` ends a process the way a terminal's Ctrl-C would, then harder; ``last_error_line``
finds what a process that ended said last about why.
"""

from __future__ import annotations

import signal
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "STOP_SEQUENCE",
    "executable",
    "last_error_line",
    "parameter_text",
    "ros_args",
    "stop",
]

STOP_SEQUENCE = ((signal.SIGINT, 10.0), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0))
"""(signal, s to wait for the process after it): SIGINT lets a node leave DDS cleanly."""


def executable(package: str, name: str) -> Path:
    """<prefix>/lib/<package>/<name> of a built package, as ``ros2 run`` resolves it
    through the ament index (FileNotFoundError with the fix when it is not built)."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        path = Path(get_package_prefix(package)) / "lib" / package / name
    except PackageNotFoundError as error:
        raise FileNotFoundError(f"{package}: not built (make setup)") from error
    if not path.is_file():
        raise FileNotFoundError(f"{path}: build the workspace (make setup)")
    return path


def parameter_text(value: Any) -> str:
    """A parameter value as ``--ros-args -p name:=<text>`` reads it (YAML)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(parameter_text(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):  # quoted: YAML reads a bare y, no or on as a bool
        return "'" + value.replace("'", "''") + "'"
    return str(value)


def ros_args(
    params: Mapping[str, Any],
    remaps: Mapping[str, str] | None = None,
    params_file: Path | None = None,
) -> list[str]:
    """``--ros-args`` with ``--params-file`` if given, ``-r from:=to`` per remap and
    ``-p name:=value`` per parameter (which wins over the file's value)."""
    out = ["--ros-args"]
    if params_file is not None:
        out += ["--params-file", str(params_file)]
    for source, target in (remaps or {}).items():
        out += ["-r", f"{source}:={target}"]
    for key, value in params.items():
        out += ["-p", f"{key}:={parameter_text(value)}"]
    return out


def stop(
    process: subprocess.Popen, sequence: Sequence[tuple[signal.Signals, float]] = STOP_SEQUENCE
) -> signal.Signals | None:
    """End ``process``: each signal of ``sequence`` in turn (SIGINT, then SIGTERM, then
    SIGKILL), waiting its seconds for the process; returns the signal that ended it
    (None: it had ended before)."""
    for sig, wait in sequence:
        if process.poll() is not None:
            return None
        process.send_signal(sig)
        try:
            process.wait(timeout=wait)
            return sig
        except subprocess.TimeoutExpired:
            continue
    return None


def last_error_line(output: str) -> str:
    """The last line of a process's ``output`` that holds ``[ERROR]`` or ``[FATAL]`` (a ROS
    log line of either severity), else its last non-empty line ('' if none), stripped."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    errors = [line for line in lines if "[ERROR]" in line or "[FATAL]" in line]
    return (errors or lines or [""])[-1]
