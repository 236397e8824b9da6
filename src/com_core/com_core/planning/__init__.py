"""Before the arm moves: the accuracy a plan will give, and the plan a target asks for."""

from com_core.planning.planner import (
    HOME,
    METHODS,
    Advice,
    Plan,
    Prediction,
    dwell_for_target,
    plan_observations,
    predict,
    within_max_tilt,
)

__all__ = [
    "HOME",
    "METHODS",
    "Advice",
    "Plan",
    "Prediction",
    "dwell_for_target",
    "plan_observations",
    "predict",
    "within_max_tilt",
]
