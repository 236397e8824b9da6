"""Before the arm moves: the accuracy a plan will give, the plan a target asks for, and
the excitation in motion for the inertial parameters."""

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
    hysteresis_hides,
    may_hold_object,
    newest_hand_model,
    plan_for_target,
    plan_within_reach,
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
from com_core.planning.excitation import (
    HARMONICS,
    SIGMA,
    Excitation,
    design_excitation,
    excitation_information,
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
from com_core.planning.run_time import (
    PhaseTime,
    motion_run_phases,
    static_run_phases,
    time_left,
)
from com_core.planning.search import (
    within_max_tilt,
)

__all__ = [
    "BIAS_AFTER_SUFFIX",
    "BIAS_WINDOW_SUFFIX",
    "GRIPPER_HOLDING",
    "GRIPPER_TIME",
    "HARMONICS",
    "HOME",
    "METHODS",
    "SIGMA",
    "Advice",
    "Excitation",
    "PhaseTime",
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
    "design_excitation",
    "dwell_for_target",
    "estimator_calibration",
    "excitation_information",
    "grasp_holds",
    "held_mass",
    "hysteresis_hides",
    "may_hold_object",
    "motion_run_phases",
    "newest_hand_model",
    "plan_for_target",
    "plan_observations",
    "plan_within_reach",
    "planning_noise",
    "predict",
    "reachable_tilt",
    "requested_plan",
    "static_run_phases",
    "tare_cache_path",
    "tare_decision",
    "tare_reuse",
    "time_left",
    "timed_plan",
    "within_max_tilt",
]
