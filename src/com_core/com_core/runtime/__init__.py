"""Processes and the DDS environment every process of this project starts with."""

from com_core.runtime.processes import (
    STOP_SEQUENCE,
    executable,
    parameter_text,
    ros_args,
    stop,
)
from com_core.runtime.rosenv import (
    keep_dds_local,
    stop_on_signals,
)

__all__ = [
    "STOP_SEQUENCE",
    "executable",
    "keep_dds_local",
    "parameter_text",
    "ros_args",
    "stop",
    "stop_on_signals",
]
