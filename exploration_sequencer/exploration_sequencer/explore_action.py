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

from com_core.estimation.runs.settings import SETTINGS
from com_core.estimation.runs.solution import verification_lines
from com_core.inputs import problems, refusal
from com_core.robot.dynamics import INERTIA_ELEMENTS
from com_interfaces.action import Explore
from exploration_sequencer.parameters import PARAMETERS

__all__ = ["ESTIMATOR_OPTIONS", "estimator_options", "feedback_of", "goal_options", "result_of"]

ESTIMATOR_OPTIONS = ("information", "reference_mass")
"""The goal's options that are the estimator's settings for the run, not the sequencer's."""


def estimator_options(options: dict[str, object]) -> dict[str, object]:
    """Of a goal's ``options`` (``goal_options``), those the estimator takes for the run."""
    return {name: options[name] for name in ESTIMATOR_OPTIONS if name in options}


def goal_options(goal: Explore.Goal) -> tuple[dict[str, object], list[str]]:
    """(the parameters an Explore goal sets for its run, the refusals of its values): a
    field left at its default (0, ``Explore.Goal.PARAMETER``, '') keeps the parameter;
    each value set is checked by the parameter's row (``PARAMETERS``; ``information``:
    the estimator's setting)."""
    options: dict[str, object] = {}
    for name in ("target_com_sigma", "tilt", "max_tilt", "dwell", "motion_period",
                 "motion_cycles", "motion_acceleration", "target_inertia"):  # fmt: skip
        value = getattr(goal, name)
        if value != 0:
            options[name] = 0.0 if name == "target_com_sigma" and value == math.inf else value
    refused = []
    for name in ("raise_tilt", "fewer_poses"):
        value = getattr(goal, name)
        if value in (Explore.Goal.NO, Explore.Goal.YES):
            options[name] = value == Explore.Goal.YES
        elif value != Explore.Goal.PARAMETER:
            refused.append(refusal(name, value, "must be PARAMETER (-1), NO (0) or YES (1)"))
    refused += problems(PARAMETERS, options)
    if goal.information:
        options["information"] = goal.information
        refused += problems(SETTINGS, {"information": goal.information})
    if goal.reference_mass != 0.0:
        options["reference_mass"] = goal.reference_mass
        refused += problems(SETTINGS, {"reference_mass": goal.reference_mass})
    if goal.excitation:
        options["excitation"] = goal.excitation
        refused += problems(PARAMETERS, {"excitation": goal.excitation})
    return options, refused


def _fill_inertia(msg: InertiaStamped, values: Mapping[str, str]) -> None:
    """``msg``'s mass (kg), COM (m) and, when estimated, inertia about the COM (kg m^2)
    from a status's ``values``."""
    msg.inertia.m = float(values["mass"])
    com = msg.inertia.com
    com.x, com.y, com.z = (float(values[f"com_{a}"]) for a in "xyz")
    if "inertia" in values:
        for name, value in zip(INERTIA_ELEMENTS, values["inertia"].split(","), strict=True):
            setattr(msg.inertia, name, float(value))


def feedback_of(
    phase: str, elapsed: float, left: float, live: Mapping[str, str]
) -> Explore.Feedback:
    """The feedback of a run ``elapsed`` s (sim) in with ``left`` s (sim) left of its plan
    (inf: no plan yet): its progress is the time done over the time done and left, at most
    0.99 until the result; with the estimator's live status ``live`` (the estimate so far;
    {} before one)."""
    feedback = Explore.Feedback(phase=phase)
    if elapsed > 0 and math.isfinite(left):
        left = max(left, 0.0)
        feedback.progress = min(elapsed / (elapsed + left), 0.99)
        feedback.time_remaining = left
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
    result.inertia_covariance = [math.nan] * 36
    if "mass" in values and status != Explore.Result.CANCELLED:
        result.estimate.header.frame_id = frame
        _fill_inertia(result.estimate, values)
        result.covariance = [float(v) for v in values["cov"].split(",")]
        if "inertia" in values:  # published: the motion told it
            result.inertia_covariance = [float(v) for v in values["inertia_cov"].split(",")]
        result.verification = "; ".join(verification_lines(values))
    return result
