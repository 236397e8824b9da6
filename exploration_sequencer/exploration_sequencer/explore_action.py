"""The Explore action's messages (com_interfaces/action/Explore) to and from a run: the
goal's options as the run's parameters, the feedback of a run under way, the result.

Values come as the estimator's statuses carry them (``/diagnostics`` key-value text:
``mass`` kg, ``com_x`` m in the sensor frame, ``cov`` the 4x4 covariance of (mass, com)
row-major, ``sigma_*``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from geometry_msgs.msg import InertiaStamped

from com_core.estimation.fits import INFORMATION
from com_core.estimation.solution import verification_lines
from com_core.planning.decisions import parameter_problem
from com_interfaces.action import Explore

__all__ = ["feedback_of", "goal_options", "result_of"]


def goal_options(goal: Explore.Goal) -> tuple[dict[str, object], list[str]]:
    """(the parameters an Explore goal sets for its run, the problems of its values): a
    field left at its default (0, ``Explore.Goal.PARAMETER``, '') keeps the parameter;
    each value set is checked as the parameter would be (``parameter_problem``)."""
    options: dict[str, object] = {}
    for name in ("target_com_sigma", "tilt", "max_tilt", "dwell"):
        value = getattr(goal, name)
        if value != 0.0:
            options[name] = 0.0 if name == "target_com_sigma" and math.isinf(value) else value
    for name in ("raise_tilt", "fewer_poses"):
        value = getattr(goal, name)
        if value != Explore.Goal.PARAMETER:
            options[name] = value
    if goal.information:
        options["information"] = goal.information
    problems = []
    for name, value in options.items():
        if name == "information":
            if value not in INFORMATION:
                problems.append(f"information {value!r} is not one of {', '.join(INFORMATION)}")
        elif name in ("raise_tilt", "fewer_poses"):
            if value not in (Explore.Goal.NO, Explore.Goal.YES):
                problems.append(f"{name} {value} is not PARAMETER (-1), NO (0) or YES (1)")
            options[name] = value == Explore.Goal.YES
        elif not math.isfinite(value) or (bad := parameter_problem(name, value)):
            why = "must be finite" if not math.isfinite(value) else bad
            problems.append(f"{name} {value!r}: {why}")
    return options, problems


def _fill_inertia(msg: InertiaStamped, values: Mapping[str, str]) -> None:
    """``msg``'s mass (kg) and COM (m) from a status's ``values``."""
    msg.inertia.m = float(values["mass"])
    com = msg.inertia.com
    com.x, com.y, com.z = (float(values[f"com_{a}"]) for a in "xyz")


def feedback_of(
    phase: str, elapsed: float, planned: float, live: Mapping[str, str]
) -> Explore.Feedback:
    """The feedback of a run ``elapsed`` s (sim) into the ``planned`` s, with the
    estimator's live status ``live`` (the estimate so far; {} before one)."""
    feedback = Explore.Feedback(phase=phase)
    if elapsed > 0 and math.isfinite(planned):
        feedback.progress = min(elapsed / planned, 0.99)
        feedback.time_remaining = max(planned - elapsed, 0.0)
    if "mass" in live:
        _fill_inertia(feedback.estimate, live)
    feedback.sigma_mass = float(live.get("sigma_mass", "nan"))
    feedback.sigma_com = [float(live.get(f"sigma_com_{a}", "nan")) for a in "xyz"]
    return feedback


def result_of(
    status: str, message: str, bag: Path | None, values: Mapping[str, str], frame: str
) -> Explore.Result:
    """The result of a run: its status and summary, the bag, and from the estimator's
    answer ``values`` (frame ``frame``) the estimate, its covariance and the
    verification (none for a cancelled run)."""
    result = Explore.Result(status=status, message=message, bag=str(bag or ""))
    result.covariance = [math.nan] * 16
    if "mass" in values and status != Explore.Result.CANCELLED:
        result.estimate.header.frame_id = frame
        _fill_inertia(result.estimate, values)
        result.covariance = [float(v) for v in values["cov"].split(",")]
        result.verification = "; ".join(verification_lines(values))
    return result
