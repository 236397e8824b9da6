"""The sequencer's labelled runs, live in the node or replayed from their bags: the
samples and labels (``inbox``), the windows the labels cut (``cutting``), which fit an
information model takes (``fit_setup``), the solution of a static run (``solution``) and of
one in motion (``motion_solution``, with the empty hand's motion cached by
``hand_motion``), the exploration session (``exploration``), the estimator's settings
(``settings``), the tare cache (``tare_cache``) and the feed of a bag (``feed``). Every
number comes from ``estimation.fits``.
"""

from com_core.estimation.runs.cutting import (
    JOINT_MOTION,
    JOINT_STATE_GAP,
    Segments,
    noise_model,
    reduced_windows,
    segments,
    spans,
    window_rotation,
    window_time,
)
from com_core.estimation.runs.exploration import (
    Exploration,
)
from com_core.estimation.runs.feed import (
    feed_bag,
)
from com_core.estimation.runs.fit_setup import (
    INFORMATION,
    KINEMATICS,
    KINEMATICS_MOUNT,
    LOAD_SIGMAS,
    MAX_DRIFT_F,
    MAX_DRIFT_TAU,
    METHODS,
    WRENCHES,
    FitSetup,
    check_load_direction,
)
from com_core.estimation.runs.inbox import (
    IDLE_KEEP,
    MAX_LABEL_GAP,
    MAX_LABEL_LENGTH,
    TIME_RESET_NS,
    Inbox,
    shorten,
)
from com_core.estimation.runs.settings import (
    SETTINGS,
    defaults,
    exploration_from,
    load_cached_tares,
    robot_from,
    use_cached_tares,
)
from com_core.estimation.runs.solution import (
    ERROR,
    OK,
    WARN,
    Solution,
    Verification,
    format_solution,
    noise_line,
    solve,
    vector_value,
    verification_lines,
    verify,
)
from com_core.estimation.runs.tare_cache import (
    BAG_TARE_FILE,
    DRIFT_ALPHA,
    TareCache,
    drift,
    drift_accepted,
    latest_hand_model,
    load_tares,
    reusable,
    save_tares,
    tare_signature,
    use_tares,
)

__all__ = [
    "BAG_TARE_FILE",
    "DRIFT_ALPHA",
    "ERROR",
    "IDLE_KEEP",
    "INFORMATION",
    "JOINT_MOTION",
    "JOINT_STATE_GAP",
    "KINEMATICS",
    "KINEMATICS_MOUNT",
    "LOAD_SIGMAS",
    "MAX_DRIFT_F",
    "MAX_DRIFT_TAU",
    "MAX_LABEL_GAP",
    "MAX_LABEL_LENGTH",
    "METHODS",
    "OK",
    "SETTINGS",
    "TIME_RESET_NS",
    "WARN",
    "WRENCHES",
    "Exploration",
    "FitSetup",
    "Inbox",
    "Segments",
    "Solution",
    "TareCache",
    "Verification",
    "check_load_direction",
    "defaults",
    "drift",
    "drift_accepted",
    "exploration_from",
    "feed_bag",
    "format_solution",
    "latest_hand_model",
    "load_cached_tares",
    "load_tares",
    "noise_line",
    "noise_model",
    "reduced_windows",
    "reusable",
    "robot_from",
    "save_tares",
    "segments",
    "shorten",
    "solve",
    "spans",
    "tare_signature",
    "use_cached_tares",
    "use_tares",
    "vector_value",
    "verification_lines",
    "verify",
    "window_rotation",
    "window_time",
]
