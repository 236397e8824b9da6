"""The plan a target COM sigma asks for: the prediction inverted.

``dwell_for_target`` is the one entry point for "meet this COM sigma": it checks the
request (``_check_request``), searches for the shortest plan (``com_core.planning.search``:
the dwell at the plan's tilt, the tilt rules, the cut poses) and answers with an
``Advice`` (``com_core.planning.advice``): the plan to run with every change it makes,
or what the limits cannot reach, why, and what would.

Information about the COM component along gravity grows with sin^2(tilt), so a small
tilt needs a long dwell: ``dwell_for_target`` says so before the robot moves, names every
change it makes to the plan, and keeps the plan's tilt unless told it may raise it.
"""

from __future__ import annotations

import math
from dataclasses import replace

from com_core.planning.advice import Advice, _infeasible, _with_dwell
from com_core.planning.planner import Plan
from com_core.planning.prediction import _check_method, predict
from com_core.planning.search import _fewer_poses, _fits, _need, _tilt_rules

__all__ = ["dwell_for_target"]


def dwell_for_target(
    plan: Plan,
    target_com_sigma: float,
    max_tilt: float | None = None,
    max_time: float = math.inf,
    *,
    raise_tilt: bool = False,
    method: str = "ml",
    information: str = "wrenches",
    fewer_poses: bool = False,
) -> Advice:
    """Shortest dwell whose predicted worst COM-axis sigma is <= ``target_com_sigma`` (m).

    The one entry point for "meet this COM sigma": a sequencer passes its plan and
    limits, logs ``Advice.changes`` and runs ``Advice.plan`` when ``feasible``, or
    refuses with ``Advice.reason``.

    Parameters
    ----------
    plan : the plan as the user set it; its tilt is a limit (see ``raise_tilt``).
    target_com_sigma : m; the worst COM axis (sensor frame) must predict at most this.
    max_tilt : rad, in (0, pi/2); the largest tilt the object allows. A plan tilt above
        it is lowered to it (reported in ``changes``). None: no limit.
    max_time : s; the longest object pass (``Plan.duration``: motion, settle and dwell
        of every pose).
    raise_tilt : False (default): the plan's tilt is kept and only the dwell changes.
        True: the tilt is raised to ``max_tilt`` (more tilt, less dwell; needs
        ``max_tilt``).
    method : the estimator that will run, 'ml' or 'two_pose'; the prediction and the
        dwell are for it (``predict``).

    Returns an ``Advice``; its ``plan`` differs from ``plan`` only in tilt (by the rule
    above) and dwell (with tare_dwell None the tare windows follow the dwell), each
    named in ``changes``. The dwell is solved in closed form from the linear scaling
    of the covariance with c = 1/N + 1/N_tare (``prediction``). Infeasible when the
    tare's own noise already exceeds the target, or when the pass would take longer
    than ``max_time``; the reason then states the limit, what would meet the target
    (the least tilt, the time limit, or the tare needed) and the sigma reachable
    within the limits.

    fewer_poses : the plan's poses may also be cut (``_fewer_poses``): the advice is then
        the feasible one of the shortest object pass, its cut named in ``changes``.

    Raises ValueError for a target <= 0, an unknown method, max_tilt outside
    (0, pi/2), max_time <= 0, or raise_tilt without max_tilt.
    """
    _check_request(target_com_sigma, method, max_tilt, max_time, raise_tilt)
    if fewer_poses:
        return _shortest_cut(
            plan,
            target_com_sigma,
            max_tilt=max_tilt,
            max_time=max_time,
            raise_tilt=raise_tilt,
            method=method,
            information=information,
        )
    _, base, changes = _tilt_rules(plan, max_tilt, raise_tilt)
    need = _need(base, target_com_sigma, method, information)
    if need.dwell is None or need.duration > max_time:
        return _infeasible(
            base, need, tuple(changes), target_com_sigma, method, information, max_tilt, max_time
        )
    why = f"the shortest for {method} COM sigma {target_com_sigma * 1e3:.3g} mm"
    out, changed = _with_dwell(base, need.dwell, why)
    return Advice(True, out, predict(out, method, information), "", (*changes, *changed))


def _check_request(
    target_com_sigma: float,
    method: str,
    max_tilt: float | None,
    max_time: float,
    raise_tilt: bool,
) -> None:
    """ValueError for a request ``dwell_for_target`` cannot answer (see there)."""
    if not target_com_sigma > 0:
        raise ValueError(f"target_com_sigma must be > 0 m, got {target_com_sigma}")
    _check_method(method)
    if max_tilt is not None and not 0.0 < max_tilt < math.pi / 2:
        raise ValueError(f"max_tilt must be in (0, pi/2) rad, got {max_tilt}")
    if not max_time > 0:
        raise ValueError(f"max_time must be > 0 s, got {max_time}")
    if raise_tilt and max_tilt is None:
        raise ValueError("raise_tilt needs max_tilt (the tilt to raise to)")


def _shortest_cut(plan: Plan, target_com_sigma: float, **options) -> Advice:
    """``dwell_for_target`` with ``fewer_poses``: of ``plan`` and its cuts
    (``_fewer_poses``), those feasible (a cheap test, ``_fits``), then the advice of the
    shortest object pass, its cut named first in ``changes``; none feasible: the advice
    for ``plan`` as it is."""
    method, information = options["method"], options["information"]
    feasible = [
        (cut, why)
        for cut, why in [(plan, ""), *_fewer_poses(plan, method, information)]
        if _fits(cut, target_com_sigma, **options)
    ]
    if not feasible:
        return dwell_for_target(plan, target_com_sigma, **options)
    advices = [(dwell_for_target(cut, target_com_sigma, **options), why) for cut, why in feasible]
    best, why = min(advices, key=lambda a: a[0].plan.duration())
    return replace(best, changes=(why, *best.changes)) if why else best
