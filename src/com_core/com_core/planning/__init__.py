"""Before the arm moves: the accuracy a plan will give, and the plan a target asks for."""

from com_core.planning.advice import (
    Advice,
)
from com_core.planning.decisions import (
    BIAS_AFTER_SUFFIX,
    BIAS_WINDOW_SUFFIX,
    GRIPPER_HOLDING,
    GRIPPER_TIME,
    PlanInfeasible,
    PlannedRun,
    Poses,
    RunSettings,
    TareDecision,
    TareReuse,
    cached_tare,
    complete_tare_pass,
    estimator_calibration,
    grasp_holds,
    held_mass,
    may_hold_object,
    newest_hand_model,
    plan_for_target,
    plan_within_reach,
    planned_run_time,
    planning_noise,
    reachable_tilt,
    requested_plan,
    tare_cache_path,
    tare_decision,
    tare_reuse,
    timed_plan,
)
from com_core.planning.dwell import (
    dwell_for_target,
)
from com_core.planning.planner import (
    HOME,
    Plan,
)
from com_core.planning.prediction import (
    METHODS,
    Prediction,
    plan_observations,
    predict,
)
from com_core.planning.search import (
    within_max_tilt,
)

__all__ = [
    "BIAS_AFTER_SUFFIX",
    "BIAS_WINDOW_SUFFIX",
    "GRIPPER_HOLDING",
    "GRIPPER_TIME",
    "HOME",
    "METHODS",
    "Advice",
    "Plan",
    "PlanInfeasible",
    "PlannedRun",
    "Poses",
    "Prediction",
    "RunSettings",
    "TareDecision",
    "TareReuse",
    "cached_tare",
    "complete_tare_pass",
    "dwell_for_target",
    "estimator_calibration",
    "grasp_holds",
    "held_mass",
    "may_hold_object",
    "newest_hand_model",
    "plan_for_target",
    "plan_observations",
    "plan_within_reach",
    "planned_run_time",
    "planning_noise",
    "predict",
    "reachable_tilt",
    "requested_plan",
    "tare_cache_path",
    "tare_decision",
    "tare_reuse",
    "timed_plan",
    "within_max_tilt",
]
