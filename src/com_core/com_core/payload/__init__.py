"""What the estimate becomes for a controller: the payload model, its files, and the
compensated wrench stream.
"""

from com_core.payload.compensation import (
    MAX_JOINT_STATE_AGE,
    RATE_STEP,
    Compensator,
)
from com_core.payload.files import (
    FILTER_PLUGIN,
    GRAVITY_COMPENSATION_FILE,
    PAYLOAD_FILE,
    URDF_FILE,
    gravity_compensation_parameters,
    payload_yaml,
    read_payload,
    urdf_snippet,
    write_payload_files,
)
from com_core.payload.model import (
    Payload,
    PayloadError,
    compensate,
    payload_from_solution,
    payload_gravity,
    payload_wrench,
)

__all__ = [
    "FILTER_PLUGIN",
    "GRAVITY_COMPENSATION_FILE",
    "MAX_JOINT_STATE_AGE",
    "PAYLOAD_FILE",
    "RATE_STEP",
    "URDF_FILE",
    "Compensator",
    "Payload",
    "PayloadError",
    "compensate",
    "gravity_compensation_parameters",
    "payload_from_solution",
    "payload_gravity",
    "payload_wrench",
    "payload_yaml",
    "read_payload",
    "urdf_snippet",
    "write_payload_files",
]
