"""Recordings this project did not make, without pose labels: wrenches with joint states or
the sensor's orientations (``recording``), fitted whatever the bias (``recording_fit``),
and the wrenches alone cut into static windows sorted by load level
(``static_windows``). Their fits are ``estimation.fits``'; a bag is read through
``estimation.runs``' feed.
"""

from com_core.estimation.recordings.recording import (
    CSV_COLUMNS,
    Recording,
    read_recording_file,
    recording_from_bag,
    recording_from_inbox,
    recording_from_joint_states,
    recording_from_orientations,
)
from com_core.estimation.recordings.recording_fit import (
    LoadChange,
    RecordingFit,
    SelfCheck,
    fit_recording,
)

__all__ = [
    "CSV_COLUMNS",
    "LoadChange",
    "LoadLevels",
    "Recording",
    "RecordingFit",
    "SelfCheck",
    "StaticWindow",
    "find_static_windows",
    "fit_recording",
    "label_static_windows",
    "read_recording_file",
    "recording_from_bag",
    "recording_from_inbox",
    "recording_from_joint_states",
    "recording_from_orientations",
    "split_load_levels",
]
