"""The search for the shortest plan that meets a target COM sigma.

At a plan's tilt, the shortest dwell whose predicted worst COM-axis sigma meets the
target (``_need``): in closed form for the wrenches' covariances, linear in the window
variance factor c = 1/N + 1/N_tare (``prediction``), by bisection on samples for the
kinematic fit's. Over tilts, the least tilt at which the target fits a time limit
(``_least_tilt``); over poses, the plan with fewer of them (``_fewer_poses``). The tilt
rules: a plan's tilt is lowered to ``max_tilt`` and raised to it only when allowed
(``_tilt_rules``, ``within_max_tilt``).

Information about the COM component along gravity grows with sin^2(tilt): at 0.05 rad
a plan needs ~100x the dwell of pi/6 for the same sigma.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from com_core.planning.planner import Plan
from com_core.planning.prediction import predict

__all__ = ["within_max_tilt"]


@dataclass(frozen=True)
class _Need:
    """What a plan (at its tilt) needs for a target; see ``_need``."""

    floor: float  # m; the worst COM-axis sigma with an unlimited dwell (the tare's)
    c_needed: float  # the largest variance factor that meets the target (nan: kinematic)
    dwell: float | None  # s per pose; None when the tare alone exceeds the target
    duration: float  # s of the object pass at that dwell (inf when dwell is None)


def _need(plan: Plan, target: float, method: str, information: str) -> _Need:
    """Shortest dwell at ``plan``'s tilt whose predicted worst COM sigma is <= target.

    sigma^2 = c * worst_unit^2 with c = 1/N + 1/N_tare (``prediction``): c_needed =
    (target / worst_unit)^2; a fixed tare leaves 1/N = c_needed - 1/N_tare, a tare of
    the same dwell (tare_dwell None) 2/N = c_needed. The kinematic fit's tare and bias
    windows are observations of their own, not a term of c: its dwell is bisected.
    """
    if information != "wrenches" and method == "ml":
        return _kinematic_need(plan, target, information)
    c_now = plan._variance_factor(plan.dwell)
    worst_unit = float(predict(plan, method, information).sigma_com.max()) / math.sqrt(c_now)
    c_needed = (target / worst_unit) ** 2
    rate = plan.sensor.rate_hz
    fixed_tare = plan.tare_dwell is not None
    tare_term = 0.0
    if fixed_tare and not math.isinf(plan.tare_dwell):
        tare_term = 1.0 / max(1.0, round(plan.tare_dwell * rate))
    floor = worst_unit * math.sqrt(tare_term)
    if fixed_tare and c_needed <= tare_term:
        return _Need(floor, c_needed, None, math.inf)
    per_window = (1.0 if fixed_tare else 2.0) / (c_needed - tare_term)
    dwell = math.ceil(per_window) / rate
    return _Need(floor, c_needed, dwell, replace(plan, dwell=dwell).duration())


def _kinematic_need(plan: Plan, target: float, information: str) -> _Need:
    """``_need`` for the kinematic fit: the fewest samples per window that meet the
    target, by bisection (the sigma falls as the dwell grows, to the tare's floor)."""
    rate = plan.sensor.rate_hz

    def worst(samples: int) -> float:
        return float(
            predict(replace(plan, dwell=samples / rate), "ml", information).sigma_com.max()
        )

    floor = worst(10**7)  # 10^4 s per window: the tare's and the bias window's floor
    if floor > target:
        return _Need(floor, math.nan, None, math.inf)
    lo, hi = 0, 1
    while worst(hi) > target:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if worst(mid) <= target else (mid, hi)
    dwell = hi / rate
    return _Need(floor, math.nan, dwell, replace(plan, dwell=dwell).duration())


def _least_tilt(
    plan: Plan, target: float, method: str, information: str, max_time: float, hi: float
) -> float | None:
    """Smallest tilt in (plan.tilt, hi] rad at which the target fits in ``max_time``.

    Bisection (the COM information grows with the tilt); None when even ``hi`` fails.
    The answer is rounded up to 1 mrad.
    """

    def fits(tilt: float) -> bool:
        need = _need(replace(plan, tilt=tilt), target, method, information)
        return need.dwell is not None and need.duration <= max_time

    lo = plan.tilt
    if hi <= lo or not fits(hi):
        return None
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if fits(mid) else (mid, hi)
        if hi - lo < 1e-5:
            break
    tilt = math.ceil(hi * 1e3) / 1e3
    return tilt if tilt < math.pi / 2 and fits(tilt) else hi


def _fewer_poses(plan: Plan, method: str, information: str) -> list[tuple[Plan, str]]:
    """The plan with fewer poses, each with the change in words: one tilt direction per
    axis, both about the first axis only, and (with kinematic information, where home and
    one tilt resolve the COM) one tilt only."""
    n = len(plan.poses())
    cuts = []
    if plan.both_directions:
        cuts.append(replace(plan, both_directions=False))
    if len(plan.axes) > 1:
        cuts.append(replace(plan, axes=plan.axes[:1]))
    if information != "wrenches" and method == "ml" and n > 2:
        cuts.append(replace(plan, axes=plan.axes[:1], both_directions=False))
    return [
        (
            cut,
            f"poses {n} -> {len(cut.poses())}: {[name for name, _ in cut.poses()]} (fewer_poses)",
        )
        for cut in cuts
    ]


def _tilt_rules(
    plan: Plan, max_tilt: float | None, raise_tilt: bool
) -> tuple[Plan, Plan, list[str]]:
    """(``plan`` within ``max_tilt``, that plan at the tilt the planner uses, the changes
    in words): the tilt is lowered to ``max_tilt``, and raised to it only with
    ``raise_tilt``."""
    plan, lowered = within_max_tilt(plan, max_tilt)
    changes = list(lowered)
    if raise_tilt and max_tilt is not None and max_tilt > plan.tilt:
        changes.append(
            f"tilt {plan.tilt:.3g} -> {max_tilt:.3g} rad (raise_tilt: more tilt, less dwell)"
        )
        return plan, replace(plan, tilt=max_tilt), changes
    return plan, plan, changes


def _fits(
    plan: Plan,
    target: float,
    *,
    max_tilt: float | None,
    max_time: float,
    raise_tilt: bool,
    method: str,
    information: str,
) -> bool:
    """``dwell_for_target`` would find ``plan`` feasible (without its remedies' cost)."""
    need = _need(_tilt_rules(plan, max_tilt, raise_tilt)[1], target, method, information)
    return need.dwell is not None and need.duration <= max_time


def within_max_tilt(plan: Plan, max_tilt: float | None) -> tuple[Plan, tuple[str, ...]]:
    """``plan`` with its tilt lowered to ``max_tilt`` (rad) when above it, and the change
    said in words (none when the tilt is within it or there is no limit)."""
    if max_tilt is None or plan.tilt <= max_tilt:
        return plan, ()
    change = f"tilt {plan.tilt:.3g} -> {max_tilt:.3g} rad (the plan's tilt exceeds max_tilt)"
    return replace(plan, tilt=max_tilt), (change,)
