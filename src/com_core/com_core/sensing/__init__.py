"""What the wrist F/T sensor reads: the paper's gravity wrench model and the sensor's
noise, calibration and simulated profiles.
"""

from com_core.sensing.calibration import (
    Calibration,
)
from com_core.sensing.noise import (
    COV_FLOOR,
    MAX_ORDER,
    MIN_LEARN_SAMPLES,
    NoiseModel,
    ar1_noise,
    learn_noise,
    white_noise,
)
from com_core.sensing.sensor_profiles import (
    DEFAULT_PROFILE,
    PROFILES,
    SensorProfile,
)
from com_core.sensing.wrench_model import (
    AXES,
    STANDARD_GRAVITY,
    SensorModel,
    as_vector,
    calibration_matrix,
    gravity_in_sensor,
    gravity_wrench,
    rotation_about,
    skew,
)

__all__ = [
    "AXES",
    "COV_FLOOR",
    "DEFAULT_PROFILE",
    "MAX_ORDER",
    "MIN_LEARN_SAMPLES",
    "PROFILES",
    "STANDARD_GRAVITY",
    "Calibration",
    "NoiseModel",
    "SensorModel",
    "SensorProfile",
    "ar1_noise",
    "as_vector",
    "calibration_matrix",
    "gravity_in_sensor",
    "gravity_wrench",
    "learn_noise",
    "rotation_about",
    "skew",
    "white_noise",
]
