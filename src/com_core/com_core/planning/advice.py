"""What the planner answers for a target COM sigma, and, for a plan that cannot reach
it, why and what would.

An ``Advice`` carries the plan to run, its prediction and every change made to the
user's plan, in words. When the target is out of reach within the limits its reason
says what fails (the tare's own noise, or the time the dwell needs), the remedies that
would meet the target (the least tilt, within ``max_tilt`` or above it; the time limit;
the tare and dwell), each rounded up so that the figure quoted suffices, and the sigma
the limits do reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from com_core.planning.planner import Plan
from com_core.planning.prediction import Prediction, predict
from com_core.planning.search import _least_tilt, _Need

__all__ = ["Advice"]

_TILT_CEILING = 1.5
"""rad; the largest tilt the planner ever suggests as a remedy (Plan needs < pi/2)."""


@dataclass(frozen=True)
class Advice:
    """Answer to "what dwell meets this COM sigma?" (``dwell_for_target``).

    Attributes
    ----------
    feasible : the target is met within the limits by ``plan``.
    plan : the plan to run; when infeasible, the best plan within the limits (the
        longest dwell the time limit allows, else the input plan with the tilt rule
        applied).
    prediction : ``predict(plan, method, information)`` of that plan; ``prediction.method`` names
        the estimator it is for.
    reason : empty when feasible; else what fails, what would make it feasible (the
        tilt, the time limit or the tare that would) and what the limits reach.
    changes : one human-readable line per field of the input plan that ``plan``
        changes, with the reason, e.g. "tilt 0.05 -> 0.524 rad (raise_tilt: more tilt,
        less dwell)", "dwell 0.9 -> 12.3 s per pose (...)"; empty when unchanged.
        Log them before moving: nothing is changed silently.
    """

    feasible: bool
    plan: Plan
    prediction: Prediction
    reason: str = ""
    changes: tuple[str, ...] = ()

    def __str__(self) -> str:
        if not self.feasible:
            return f"infeasible: {self.reason}"
        changed = "; ".join(self.changes) if self.changes else "plan unchanged"
        return f"{changed}; predicted {self.prediction}"


def _up(x: float) -> float:
    """``x`` rounded up to 3 significant digits (a remedy quoted must suffice)."""
    if not math.isfinite(x) or x <= 0:
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.ceil(x / scale * (1 - 1e-12)) * scale


def _with_dwell(base: Plan, dwell: float, why: str) -> tuple[Plan, tuple[str, ...]]:
    """``base`` at ``dwell`` s per pose, and the change said in words with ``why`` (none
    when the dwell is ``base``'s); with tare_dwell None the tare windows follow it."""
    if dwell == base.dwell:
        return replace(base, dwell=dwell), ()
    tare = " and per tare pose (tare_dwell None)" if base.tare_dwell is None else ""
    change = (
        f"dwell {base.dwell:.3g} -> {dwell:.3g} s per pose{tare} ({why}; object pass "
        f"{replace(base, dwell=base.dwell).duration():.3g} -> "
        f"{replace(base, dwell=dwell).duration():.3g} s)"
    )
    return replace(base, dwell=dwell), (change,)


def _fails(base: Plan, need: _Need, target: float, method: str, max_time: float) -> str:
    """What keeps ``base`` from ``target`` (m): the tare's own noise, or the time."""
    target_mm = target * 1e3
    if need.dwell is None:
        floor = need.floor * 1e3
        return (
            f"the tare ({base.tare_dwell:g} s per pose) alone gives {method} COM sigma "
            f"{floor:.3g} mm > target {target_mm:.3g} mm; take a longer tare"
        )
    return (
        f"{method} COM sigma {target_mm:.3g} mm at tilt {base.tilt:.3g} rad needs "
        f"{need.dwell:.3g} s per pose ({need.duration:.3g} s in all) > limit {max_time:g} s"
    )


def _tilt_remedy(
    base: Plan,
    target: float,
    method: str,
    information: str,
    max_tilt: float | None,
    max_time: float,
) -> str | None:
    """The least tilt that meets ``target`` within ``max_time``: at most ``max_tilt``,
    else above it (up to ``_TILT_CEILING``); None when no tilt does."""
    within = None if max_tilt is None or base.tilt >= max_tilt else max_tilt
    least = _least_tilt(base, target, method, information, max_time, within) if within else None
    if least is not None:
        return (
            f"tilt >= {least:.3f} rad (max_tilt {max_tilt:.3g} allows it: set the tilt, "
            "or raise_tilt)"
        )
    least = _least_tilt(base, target, method, information, max_time, _TILT_CEILING)
    if least is not None:
        above = f", above max_tilt {max_tilt:.3g} rad" if max_tilt is not None else ""
        return f"tilt >= {least:.3f} rad{above}"
    return None


def _time_or_tare_remedy(base: Plan, need: _Need, max_time: float) -> str:
    """The time limit the dwell needs; without a dwell that meets the target (the tare
    alone exceeds it), the tare that leaves room for a dwell within ``max_time``, else
    the tare and dwell that meet it, with the time they take."""
    if need.dwell is not None:
        return f"max_time >= {_up(need.duration):.3g} s"
    if math.isnan(need.c_needed):
        return "a longer tare_dwell or bias_dwell (the kinematic fit's hand and bias)"
    rate = base.sensor.rate_hz
    n_obj = 0
    if math.isfinite(max_time):
        n = len(base.poses())
        n_obj = max(0, math.floor((max_time / n - base.move_time - base.settle) * rate))
    room = need.c_needed - 1.0 / max(1, n_obj)
    if n_obj >= 1 and room > 0:
        return (
            f"tare_dwell >= {_up(math.ceil(1.0 / room) / rate):.3g} s per pose "
            f"(with dwell {n_obj / rate:.3g} s)"
        )
    both = _up(math.ceil(2.0 / need.c_needed) / rate)
    time = f" and max_time >= {_up(replace(base, dwell=both).duration()):.3g} s"
    return f"tare_dwell >= {both:.3g} s and dwell >= {both:.3g} s per pose" + (
        time if math.isfinite(max_time) else ""
    )


def _remedies(
    base: Plan,
    need: _Need,
    target: float,
    method: str,
    information: str,
    max_tilt: float | None,
    max_time: float,
) -> list[str]:
    """What would make ``base`` meet ``target``: the tilt (``_tilt_remedy``), then the
    time limit or the tare (``_time_or_tare_remedy``)."""
    tilt = _tilt_remedy(base, target, method, information, max_tilt, max_time)
    return [*([tilt] if tilt is not None else []), _time_or_tare_remedy(base, need, max_time)]


def _infeasible(
    base: Plan,
    need: _Need,
    changes: tuple[str, ...],
    target: float,
    method: str,
    information: str,
    max_tilt: float | None,
    max_time: float,
) -> Advice:
    """The advice when ``base`` (the plan after the tilt rules, ``changes`` made so far)
    cannot meet ``target`` (m) within the limits: what fails, the remedies, and the best
    plan within the limits (the longest dwell ``max_time`` allows, else ``base``) with
    what it reaches."""
    remedies = _remedies(base, need, target, method, information, max_tilt, max_time)
    remedy = f"; feasible with {', or '.join(remedies)}"
    n = len(base.poses())
    dwell_max = max_time / n - base.move_time - base.settle
    if math.isfinite(max_time) and dwell_max <= 0:
        reason = f"{n} poses cannot even be visited in {max_time:g} s{remedy}"
        return Advice(False, base, predict(base, method, information), reason, changes)
    if math.isfinite(max_time):
        why = f"the longest within {max_time:g} s; target not met"
        best_plan, changed = _with_dwell(base, dwell_max, why)
        changes = (*changes, *changed)
    else:
        best_plan = base
    best = predict(best_plan, method, information)
    reason = f"{_fails(base, need, target, method, max_time)}{remedy}; within the limits: {best}"
    return Advice(False, best_plan, best, reason, changes)
