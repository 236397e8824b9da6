"""Processes and the DDS environment every process of this project starts with."""

from com_core.runtime.lifeline import LIFELINE_ENV, Lifeline, stop_with_parent
from com_core.runtime.processes import (
    STOP_SEQUENCE,
    executable,
    last_error_line,
    parameter_text,
    ros_args,
    stop,
)
from com_core.runtime.rosenv import (
    keep_dds_local,
    start_refusal,
    stop_on_signals,
)

__all__ = [
    "LIFELINE_ENV",
    "STOP_SEQUENCE",
    "Lifeline",
    "executable",
    "keep_dds_local",
    "last_error_line",
    "parameter_text",
    "ros_args",
    "start_refusal",
    "stop",
    "stop_on_signals",
    "stop_with_parent",
]
