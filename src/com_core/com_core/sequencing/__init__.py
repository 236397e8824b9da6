"""The exploration's sequence over ports (no ROS): what the sequencer node drives through
adapters of its own (``ports``), the arm's and the gripper's motion on them (``motion``), the
run itself (``run``), its progress against its plan (``progress``), and the errors that end
a run (``errors``)."""

from com_core.sequencing.errors import (
    CancelledRunError,
    RecordingError,
    RunError,
    TimeoutRunError,
)
from com_core.sequencing.motion import ArmMotion, excitation_path, move_path, resting
from com_core.sequencing.ports import (
    ArmPort,
    EstimatorAnswer,
    EstimatorPort,
    GripperOutcome,
    GripperPort,
    JointFeed,
    JointPath,
    LabelSink,
    RunClock,
    RunLog,
    RunRecorder,
)
from com_core.sequencing.progress import RunProgress
from com_core.sequencing.run import ExplorationRun, RunOutcome, RunPorts

__all__ = [
    "ArmMotion",
    "ArmPort",
    "CancelledRunError",
    "EstimatorAnswer",
    "EstimatorPort",
    "ExplorationRun",
    "GripperOutcome",
    "GripperPort",
    "JointFeed",
    "JointPath",
    "LabelSink",
    "RecordingError",
    "RunClock",
    "RunError",
    "RunLog",
    "RunOutcome",
    "RunPorts",
    "RunProgress",
    "RunRecorder",
    "TimeoutRunError",
    "excitation_path",
    "move_path",
    "resting",
]
