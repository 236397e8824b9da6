"""One run read back from its bag, and its PNG report; the report of a recording's fit."""

from com_core.report.figure import (
    write_report,
)
from com_core.report.recording import (
    write_recording_report,
)
from com_core.report.run import (
    RUN_BAG_TOPICS,
    Inertia,
    RunData,
    read_run,
)

__all__ = [
    "RUN_BAG_TOPICS",
    "Inertia",
    "RunData",
    "read_run",
    "write_recording_report",
    "write_report",
]
