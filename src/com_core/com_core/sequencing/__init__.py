"""The exploration's sequence over ports (no ROS): what the sequencer node drives through
adapters of its own, each port a file (``ports``), the arm's and the gripper's motion on them
(``motion``), and the errors that end a run (``errors``)."""

from com_core.sequencing.errors import (
    CancelledRunError,
    RecordingError,
    RunError,
    TimeoutRunError,
)
from com_core.sequencing.motion import ArmMotion, excitation_path, move_path, resting
from com_core.sequencing.ports import (
    ArmPort,
    GripperOutcome,
    GripperPort,
    JointFeed,
    JointPath,
    RunClock,
)

__all__ = [
    "ArmMotion",
    "ArmPort",
    "CancelledRunError",
    "GripperOutcome",
    "GripperPort",
    "JointFeed",
    "JointPath",
    "RecordingError",
    "RunClock",
    "RunError",
    "TimeoutRunError",
    "excitation_path",
    "move_path",
    "resting",
]
