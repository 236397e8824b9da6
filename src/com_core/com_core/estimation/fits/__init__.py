"""One fit per model, whichever path its windows come from: the window and its
reduction (``windows``), the wrenches alone (``estimators``: ``two_pose``, ``ml``, the
CRLB, the consistency test), the robot's kinematics with the hand and the bias as a model
(``known_gravity``, the ft_calib model), the 10 inertial parameters in motion (``motion``,
physically consistent by ``inertial``), their statistics (``stats``) and errors
(``errors``). Nothing here knows of labels, runs or bags.
"""

from com_core.estimation.fits.errors import (
    EstimationError,
    IllConditionedError,
    MissingTareError,
    MotionError,
    NonFiniteError,
    NonPositiveMassError,
    SaturationError,
    TooFewPosesError,
    WindowError,
)
from com_core.estimation.fits.estimators import (
    DEFAULT_ALPHA,
    MIN_TILT_SIGMAS,
    Consistency,
    Estimate,
    check_consistency,
    check_windows,
    crlb,
    ml,
    two_pose,
)
from com_core.estimation.fits.inertial import (
    InertialFit,
    fit_inertial,
    log_cholesky,
    pseudo_inertia,
)
from com_core.estimation.fits.known_gravity import (
    BIAS_DRIFT_RATE,
    KinematicFit,
    Observation,
    Reference,
    gravity_designs,
    kinematic_ml,
    locate_move,
    mount_rpy,
)
from com_core.estimation.fits.stats import (
    chi2_isf,
    chi2_sf,
)
from com_core.estimation.fits.windows import (
    MIN_SAMPLES_FOR_COVARIANCE,
    Window,
    reduce_window,
    settled_start,
    subtract_tare,
    window_from_mean,
)

__all__ = [
    "BIAS_DRIFT_RATE",
    "DEFAULT_ALPHA",
    "MIN_SAMPLES_FOR_COVARIANCE",
    "MIN_TILT_SIGMAS",
    "Consistency",
    "Estimate",
    "EstimationError",
    "IllConditionedError",
    "InertialFit",
    "KinematicFit",
    "MissingTareError",
    "MotionError",
    "NonFiniteError",
    "NonPositiveMassError",
    "Observation",
    "Reference",
    "SaturationError",
    "TooFewPosesError",
    "Window",
    "WindowError",
    "check_consistency",
    "check_windows",
    "chi2_isf",
    "chi2_sf",
    "crlb",
    "fit_inertial",
    "gravity_designs",
    "kinematic_ml",
    "locate_move",
    "log_cholesky",
    "ml",
    "mount_rpy",
    "pseudo_inertia",
    "reduce_window",
    "settled_start",
    "subtract_tare",
    "two_pose",
    "window_from_mean",
]
