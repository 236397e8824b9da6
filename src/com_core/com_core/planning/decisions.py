"""What an exploration run decides before and between its motions.

A run's plan is the one its settings ask for (``requested_plan``), kept within
``max_tilt`` and the arm's reach (``plan_within_reach``: a pose no joint solution reaches
lowers the tilt to the largest the arm reaches) and, with a target COM sigma, given the
dwell (and tilt, poses) the planner finds for it (``plan_for_target``); every change is
named. It plans for the noise the newest tare pass of the hand learnt, else the assumed
one (``planning_noise``). A cached tare pass serves the run when the estimator reads the
same cache and the entry is young enough and complete (``tare_decision``), and then only
when a fresh empty-hand window at home confirms it (``tare_reuse``; docs/design.md, "The
tare cache"). After the lift the hand must hold ``min_load`` beyond the tare along
gravity, less what the sensor's hysteresis can hide (``held_mass``, ``grasp_holds``,
``hysteresis_hides``).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, fields, replace
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.windows import Window
from com_core.estimation.runs.tare_cache import (
    TareCache,
    drift_accepted,
    latest_hand_model,
    load_tares,
    reusable,
)
from com_core.planning.dwell import dwell_for_target
from com_core.planning.planner import Plan
from com_core.planning.prediction import Prediction, predict
from com_core.planning.search import within_max_tilt
from com_core.robot.choreography import Choreography, PoseUnreachable
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis, edge
from com_core.sensing.noise import NoiseModel, ar1_noise
from com_core.sensing.wrench_model import STANDARD_GRAVITY, SensorModel

__all__ = [
    "BAG_BYTES_PER_S",
    "BIAS_AFTER_SUFFIX",
    "BIAS_WINDOW_SUFFIX",
    "GRIPPER_CLOSED_FULLY",
    "GRIPPER_HOLDING",
    "GRIPPER_TIME",
    "PlanInfeasible",
    "PlannedRun",
    "Poses",
    "RunSettings",
    "TareDecision",
    "TareReuse",
    "bag_bytes",
    "bag_room_refusal",
    "cached_tare",
    "closing_problem",
    "com_guess",
    "complete_tare_pass",
    "estimator_calibration",
    "free_room",
    "grasp_holds",
    "held_mass",
    "hysteresis_hides",
    "may_hold_object",
    "newest_hand_model",
    "plan_for_target",
    "plan_within_reach",
    "planning_noise",
    "predicted_run",
    "reachable_tilt",
    "requested_plan",
    "resolving_tilt",
    "tare_cache_path",
    "tare_decision",
    "tare_reuse",
    "timed_plan",
]

GRIPPER_TIME = 0.6
"""s (sim) the fingers are given to close or open."""
GRIPPER_HOLDING = 0.025
"""A gripper closed beyond this fraction of its stroke may hold an object (a run that
stopped): it is put back on the stand before a run."""
BIAS_WINDOW_SUFFIX = "_check"
"""The empty-hand window at home of a run with a cached tare (matches no object window)."""
BIAS_AFTER_SUFFIX = "_after"
"""The empty-hand window after the pass (kinematic information)."""

Poses = list[tuple[str, list[float]]]
"""(pose name, arm joints in rad) per pose, in the pass's order."""


class PlanInfeasible(ValueError):  # noqa: N818 (a plan, refused)
    """No plan runs within the settings and the arm's reach; the message says why."""


@dataclass(frozen=True)
class RunSettings:
    """The settings of a run that decide its plan and the noise it plans for (the
    sequencer's parameters of the same names and units: rad, s, rad/s, m, kg, N, N m,
    Hz)."""

    tilt: float
    tilt_axes: tuple[str, ...]
    both_directions: bool
    dwell: float
    tare_dwell: float
    settle: float
    speed: float
    max_tilt: float
    raise_tilt: bool
    target_com_sigma: float
    fewer_poses: bool
    max_object_time: float
    sigma_f: float
    sigma_tau: float
    correlation_time: float
    rate: float
    mass_guess: float
    com_guess: tuple[float, ...]
    """m, in the sensor frame; one value ((0.0,)): the grasp centre."""
    bias_dwell: float

    @classmethod
    def from_parameters(cls, value: Callable[[str], Any]) -> RunSettings:
        """The settings of the parameters ``value(name)`` gives (lists become tuples)."""
        values = {f.name: value(f.name) for f in fields(cls)}
        for name in ("tilt_axes", "com_guess"):
            values[name] = tuple(values[name])
        return cls(**values)


def tare_cache_path(tare_cache: str, bag_dir: str) -> Path:
    """The tare cache file: ``tare_cache``, or ``<bag_dir>/tare_cache.json`` when ''."""
    return Path(tare_cache or Path(bag_dir) / "tare_cache.json")


def newest_hand_model(path: Path | str, owner: str) -> TareCache | None:
    """The newest entry of the cache in ``path`` that models the hand on the sensor
    ``owner`` (``latest_hand_model``); None when there is none or the file is unreadable."""
    try:
        return latest_hand_model(path, owner)
    except (ValueError, KeyError, OSError):
        return None


def planning_noise(cache: TareCache | None, settings: RunSettings) -> tuple[NoiseModel, str]:
    """(the sensor's noise to plan for, where it comes from): the noise the tare pass of
    ``cache`` (the hand's newest) learnt, else assumed from ``sigma_f``, ``sigma_tau``,
    ``correlation_time`` and ``rate``."""
    if cache is not None and cache.noise is not None:
        return cache.noise, "learnt by the cached tare pass"
    sigma = [settings.sigma_f] * 3 + [settings.sigma_tau] * 3
    noise = ar1_noise(sigma, settings.correlation_time, settings.rate)
    return noise, "assumed from sigma_f, sigma_tau and correlation_time"


def estimator_calibration(accuracy: float, full_scale: Sequence[float]) -> Calibration | None:
    """The sensor's stated accuracy the estimator fits with: ``accuracy`` (fraction of
    full scale) and ``full_scale`` (N, N m); None when it states none (accuracy <= 0 or
    not two full scales)."""
    if accuracy > 0 and len(full_scale) == 2:
        return Calibration(accuracy, *full_scale)
    return None


def com_guess(settings: RunSettings, motion: Choreography) -> tuple[float, ...]:
    """m, sensor frame: the settings' guess of the object's COM, ``(0.0,)`` read as the
    grasp centre."""
    guess = settings.com_guess
    return tuple(motion.pivot if len(guess) == 1 else guess)


def requested_plan(settings: RunSettings, motion: Choreography, noise: NoiseModel) -> Plan:
    """The plan the settings ask for, as set: the COM guess ((0.0,): the grasp centre)
    and the gravity at home from the arm's model, planned for ``noise`` (its move time
    is set when its poses are solved: ``timed_plan``)."""
    gravity = motion.robot.gravity_in_sensor(motion.home_positions())
    return Plan(
        tilt=settings.tilt,
        axes=tuple(settings.tilt_axes),
        both_directions=settings.both_directions,
        dwell=settings.dwell,
        tare_dwell=settings.tare_dwell,
        settle=settings.settle,
        sensor=SensorModel.from_scalars(
            settings.sigma_f, settings.sigma_tau, rate_hz=settings.rate
        ),
        mass_guess=settings.mass_guess,
        com_guess=com_guess(settings, motion),
        gravity_home=tuple(gravity / np.linalg.norm(gravity)),
        bias_dwell=settings.bias_dwell,
        noise=noise,
    )


def reachable_tilt(plan: Plan, motion: Choreography, refusals: list[PoseUnreachable]) -> float:
    """The largest tilt (rad, up to ``plan.tilt``) at which the arm reaches every pose of
    ``plan``'s tare pass (which holds the object pass's); each pose refused on the way is
    appended to ``refusals``. PlanInfeasible when a pose is out of reach at any tilt."""
    while True:
        try:
            motion.pose_joints(plan.tare_plan())
            return plan.tilt
        except PoseUnreachable as exc:
            if exc.largest <= 0.0:
                raise PlanInfeasible(f"no exploration is feasible: {exc}") from exc
            refusals.append(exc)
            plan = replace(plan, tilt=exc.largest)


def timed_plan(plan: Plan, motion: Choreography, speed: float) -> tuple[Plan, Poses]:
    """(``plan`` with its move time the longest move of its pass at ``speed`` rad/s, the
    joints of its poses). PlanInfeasible when a pose is out of reach."""
    try:
        poses = motion.pose_joints(plan)
    except PoseUnreachable as exc:  # checked with the tare's poses: not expected
        raise PlanInfeasible(f"no exploration is feasible: {exc}") from exc
    moves = [motion.motion_time(a, b, speed) for (_, a), (_, b) in pairwise(poses)]
    return replace(plan, move_time=max(moves, default=plan.move_time)), poses


@dataclass(frozen=True)
class PlannedRun:
    """A plan, the joints of its poses, the poses refused before moving and every change
    made to the plan the settings asked for (one line each, with its reason)."""

    plan: Plan
    poses: Poses
    refusals: tuple[PoseUnreachable, ...] = ()
    changes: tuple[str, ...] = ()


def plan_within_reach(
    settings: RunSettings,
    motion: Choreography,
    noise: NoiseModel,
    calibration: Calibration | None = None,
    bias_drift_rate: Sequence[float] = (),
    hysteresis: Hysteresis | None = None,
) -> PlannedRun:
    """The plan of ``settings`` within ``max_tilt`` and the arm's reach (a pose no joint
    solution reaches is refused and the tilt lowered to the largest the arm reaches),
    with the estimator's ``calibration``, ``bias_drift_rate`` (N/s, N m/s; used when it
    has both) and ``hysteresis``, and its move time the longest move of the pass.
    PlanInfeasible when a pose is out of reach at any tilt."""
    plan = replace(requested_plan(settings, motion, noise), calibration=calibration,
                   hysteresis=hysteresis)  # fmt: skip
    if len(bias_drift_rate) == 2:  # the estimator's (kinematic information)
        plan = replace(plan, bias_drift_rate=tuple(bias_drift_rate))
    plan, lowered = within_max_tilt(plan, settings.max_tilt)
    changes = list(lowered)
    refusals: list[PoseUnreachable] = []
    reach = reachable_tilt(plan, motion, refusals)
    if refusals:
        last = refusals[-1]
        changes.append(
            f"tilt {plan.tilt:.3f} -> {reach:.3f} rad (the largest the arm reaches at "
            f"{last.pose}: {last.reason})"
        )
        plan = replace(plan, tilt=reach)
    plan, poses = timed_plan(plan, motion, settings.speed)
    return PlannedRun(plan, poses, tuple(refusals), tuple(changes))


def plan_for_target(
    planned: PlannedRun,
    settings: RunSettings,
    motion: Choreography,
    method: str,
    information: str,
) -> PlannedRun:
    """With a ``target_com_sigma`` (> 0), ``planned`` with the dwell (with ``raise_tilt``
    the tilt, up to ``max_tilt`` and what the arm reaches; with ``fewer_poses`` the
    poses) the planner finds for it within ``max_object_time``, for the estimator's
    ``method`` and ``information``, the planner's changes added; without one,
    ``planned``. PlanInfeasible when the target cannot be met (the reason says what
    would meet it)."""
    if not settings.target_com_sigma > 0:
        return planned
    plan = planned.plan
    ceiling = settings.max_tilt
    if settings.raise_tilt and ceiling > plan.tilt:  # no higher than the arm reaches
        ceiling = reachable_tilt(replace(plan, tilt=ceiling), motion, [])
    advice = dwell_for_target(
        plan,
        settings.target_com_sigma,
        max_tilt=ceiling,
        max_time=settings.max_object_time,
        raise_tilt=settings.raise_tilt,
        method=method,
        information=information,
        fewer_poses=settings.fewer_poses,
    )
    if not advice.feasible:
        raise PlanInfeasible(f"target COM sigma cannot be met: {advice.reason}")
    plan, poses = timed_plan(advice.plan, motion, settings.speed)
    return PlannedRun(plan, poses, planned.refusals, planned.changes + tuple(advice.changes))


def predicted_run(
    planned: PlannedRun,
    settings: RunSettings,
    motion: Choreography,
    method: str,
    information: str,
) -> tuple[PlannedRun, Prediction]:
    """``plan_for_target`` of ``planned`` and the sigmas predicted for it (``predict``).
    PlanInfeasible, with the tilt that would do (``resolving_tilt``), when the plan's
    orientations cannot resolve the fit the estimator makes (``information``: a kinematic
    model with the sensor's mounting needs rotations about two axes, each well beyond the
    noise); the target's own infeasibility as ``plan_for_target`` says it, and, for a tilt
    below ``max_tilt``, what the planner would do with ``raise_tilt``."""
    try:
        planned = plan_for_target(planned, settings, motion, method, information)
        return planned, predict(planned.plan, method, information)
    except PlanInfeasible as refusal:
        if settings.raise_tilt or not planned.plan.tilt < settings.max_tilt:
            raise
        hint = _raised(planned, settings, motion, method, information)
        raise PlanInfeasible(f"{refusal}; {hint}") from refusal
    except EstimationError as error:
        plan, target = planned.plan, settings.target_com_sigma
        ceiling = reachable_tilt(replace(plan, tilt=settings.max_tilt), motion, [])
        model = f"{method} ({information})" if method == "ml" else method
        found = target and resolving_tilt(plan, method, information, ceiling, target)
        if found:
            goal = f" for a {target * 1e3:g} mm COM sigma at dwell {plan.dwell:g} s"
            fix = "raise tilt or allow raise_tilt"
        else:
            found, goal = resolving_tilt(plan, method, information, ceiling), " to resolve it"
            fix = "raise tilt" + (" and allow raise_tilt for the target" if target else "")
        if found:
            tilt, prediction = found
            fix = f"it needs tilt >= {tilt:.3f} rad{goal} (predicted there: {prediction}); {fix}"
        else:
            fix = (
                f"no tilt up to max_tilt {settings.max_tilt:.3f} rad within the arm's reach "
                "resolves it: raise max_tilt, or choose information 'wrenches'"
            )
        raise PlanInfeasible(
            f"tilt={plan.tilt!r} refused: too small for the {model} model ({error}); {fix}"
        ) from error


def _raised(
    planned: PlannedRun, settings: RunSettings, motion: Choreography, method: str, information: str
) -> str:
    """What the planner would do for the target with ``raise_tilt`` (the remedy a tilt
    below ``max_tilt`` may hide)."""
    try:
        raised = plan_for_target(planned, replace(settings, raise_tilt=True), motion, method,
                                 information)  # fmt: skip
    except (PlanInfeasible, EstimationError) as refusal:
        return f"with raise_tilt as well: {refusal}"
    return (
        f"with raise_tilt it plans tilt {raised.plan.tilt:.3f} rad and dwell "
        f"{raised.plan.dwell:g} s per pose: allow raise_tilt"
    )


def resolving_tilt(
    plan: Plan, method: str, information: str, ceiling: float, target: float = 0.0
) -> tuple[float, Prediction] | None:
    """(the smallest tilt, rad to 1 mrad, above ``plan``'s and up to ``ceiling`` at
    which the fit of ``method`` and ``information`` is predicted without an
    EstimationError and, with a ``target`` (m), each COM sigma within it; the prediction
    there); None when even ``ceiling`` does not do."""

    def prediction(tilt: float) -> Prediction | None:
        try:
            out = predict(replace(plan, tilt=tilt), method, information)
        except EstimationError:
            return None
        return out if not target or max(out.sigma_com) <= target else None

    low, high = plan.tilt, ceiling
    best = prediction(high) if high > low else None
    if best is None:
        return None
    while high - low > 1e-3:
        middle = 0.5 * (low + high)
        if (found := prediction(middle)) is not None:
            high, best = middle, found
        else:
            low = middle
    return high, best


def cached_tare(
    path: Path | str, owner: str, signature: str, hand_model: bool
) -> tuple[TareCache | None, str]:
    """(the cache entry that may serve the run, why the file cannot be read or ''): with
    a ``hand_model`` the newest entry of ``owner`` (the hand on the sensor) with its joint
    positions, else the entry of the run's ``signature`` (owner and tare poses); None when
    there is none."""
    try:
        if hand_model:
            return latest_hand_model(path, owner), ""
        return load_tares(path, signature), ""
    except (ValueError, KeyError, OSError) as exc:
        return None, str(exc)


@dataclass(frozen=True)
class TareDecision:
    """Whether a cached tare entry may serve the run.

    shared : the estimator reads the same cache file (else it could not see the entry).
    check : take an empty-hand window at home and let ``tare_reuse`` decide; else take a
        new tare pass.
    unshared : an entry exists but the estimator reads another file: a new tare pass is
        taken for that reason.
    """

    shared: bool
    check: bool
    unshared: bool


def tare_decision(
    entry: TareCache | None,
    path: Path | str,
    estimator_cache: str,
    max_age: float,
    plan_poses: Iterable[str],
    hand_model: bool,
) -> TareDecision:
    """Whether ``entry`` (of the cache in ``path``) may serve a run: the estimator reads
    the same file (its ``estimator_cache``), and the entry is younger than ``max_age`` s
    and, with the wrenches alone, has a window for each of ``plan_poses`` (with a
    ``hand_model`` it serves any plan)."""
    shared = bool(estimator_cache) and Path(estimator_cache).resolve() == Path(path).resolve()
    needed = [] if hand_model else list(plan_poses)
    return TareDecision(
        shared=shared,
        check=shared and reusable(entry, max_age, needed),
        unshared=entry is not None and not shared,
    )


@dataclass(frozen=True)
class TareReuse:
    """The verdict of the fresh empty-hand window at home on a cached entry.

    reuse : the entry serves the run. verdict : why, in words (logged).
    home : the empty-hand window at home the run weighs its grasp against: the fresh
        one with a hand model, else the entry's.
    """

    reuse: bool
    verdict: str
    home: Window


def tare_reuse(
    entry: TareCache, home_name: str, fresh: Window | None, hand_model: bool
) -> TareReuse:
    """Whether ``entry`` serves the run after the ``fresh`` window at home (None: not
    recorded): with a ``hand_model`` whenever there is a fresh window (the bias is fitted
    with the object), else when it agrees with the entry's window at ``home_name``
    (``drift_accepted``: chi-square, 6 dof)."""
    if hand_model and fresh is not None:
        return TareReuse(True, "its hand model; the bias is fitted with the object", fresh)
    reuse, chi2, p = drift_accepted(entry.windows[home_name], fresh)
    verdict = f"drift chi2 {chi2:.1f}, 6 dof, p {p:.2g}"
    return TareReuse(reuse, verdict, entry.windows[home_name])


def complete_tare_pass(windows: Iterable[str], pose_names: Iterable[str]) -> bool:
    """A tare pass has a window for every pose (only such a pass is cached)."""
    return set(pose_names) <= set(windows)


def may_hold_object(closed: float) -> bool:
    """Fingers closed beyond ``GRIPPER_HOLDING`` of their stroke (``closed``, a
    fraction) may hold an object: it is put back on the stand before a run."""
    return closed > GRIPPER_HOLDING


def held_mass(
    stamps: NDArray[np.int64],
    forces: NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    tare_force: NDArray[np.float64],
) -> float | None:
    """kg the hand holds beyond the tare: the mean force of the samples stamped in
    [``start_ns``, ``end_ns``) minus ``tare_force`` (N, the empty hand at the same pose),
    along gravity (the tare force's direction), over g. ``forces``: shape (n, >= 3), the
    force first. None when no sample is in the interval, or the tare weighs nothing (a
    hand the sensor does not see: no direction of gravity)."""
    held = np.asarray(forces)[(stamps >= start_ns) & (stamps < end_ns), :3]
    tare = np.asarray(tare_force, dtype=np.float64)
    if len(held) == 0 or not np.linalg.norm(tare) > 0:
        return None
    gravity = tare / np.linalg.norm(tare)
    return float((held.mean(axis=0) - tare) @ gravity) / STANDARD_GRAVITY


GRIPPER_CLOSED_FULLY = 0.98
"""Fingers closed beyond this fraction of their stroke have closed on nothing."""


def closing_problem(
    stalled: bool | None, reached_goal: bool | None, closed: float, what: str
) -> str:
    """Why a closing of the gripper on the object did not grasp it, or '' when it did:
    the gripper's answer (``stalled``, ``reached_goal``; None: a command without one) and
    its finger joint states (``closed``, the fraction of the stroke) must both show the
    fingers stopped on something short of closed. ``what`` names the gripper's command."""
    if reached_goal and not stalled:
        return f"{what} reached its closed goal: the fingers closed on nothing"
    if stalled is not None and not stalled:
        return f"{what} neither stalled on the object nor reached its goal"
    if closed >= GRIPPER_CLOSED_FULLY:
        return (
            f"the finger joint states show the gripper {closed:.0%} closed: the fingers "
            "closed on nothing"
        )
    return ""


def hysteresis_hides(hysteresis: Hysteresis | None, tare_force: ArrayLike) -> float:
    """kg by which the sensor's hysteresis can move ``held_mass`` at most: each force
    axis's state is anywhere within +-b at the tare, and anywhere within it again after
    the grasp's contact (``com_core.sensing.hysteresis``), so the two differ by up to 2 b
    per axis; summed along gravity u (the tare force's direction, sensor frame) as
    2 sum_i b_i |u_i|, over g. 0 without hysteresis, or for a tare that weighs nothing."""
    tare = np.asarray(tare_force, dtype=np.float64)[:3]
    if hysteresis is None or not np.linalg.norm(tare) > 0:
        return 0.0
    b = edge(hysteresis.band)[:3]
    return float(2.0 * b @ np.abs(tare / np.linalg.norm(tare))) / STANDARD_GRAVITY


def grasp_holds(mass: float, min_load: float, hidden: float = 0.0) -> bool:
    """The grasp is not shown empty: ``mass`` (kg, ``held_mass``) is not below
    ``min_load`` kg by more than the ``hidden`` kg the sensor can move it by
    (``hysteresis_hides``)."""
    return mass >= min_load - hidden  # NaN: not held


BAG_BYTES_PER_S = 250_000
"""Bytes a run's bag grows by per second (sim) of a 1 kHz sensor with the joint states and
the clock: 5.8 MB over a 28 s demo run, measured, and some more."""
BAG_EXTRAS = 2_000_000
"""Bytes beside the MCAP file: the report (0.3 MB), the payload, tare and robot files, the
writer's reserve."""


def bag_bytes(planned_s: float, margin: float = 1.5) -> int:
    """Bytes a run ``planned_s`` s (sim) long is planned to record, with ``margin``."""
    return round(margin * (planned_s * BAG_BYTES_PER_S + BAG_EXTRAS))


def free_room(path: Path | str | None) -> str:
    """'N MB free on <the directory>' for the file system that holds ``path`` (or its
    nearest existing parent)."""
    where = _existing(Path(path) if path is not None else Path.cwd())
    try:
        free = shutil.disk_usage(where).free
    except OSError as exc:
        return f"the free room on {where} unknown ({exc.strerror})"
    return f"{free / 1e6:.1f} MB free on {where}"


def bag_room_refusal(bag_dir: Path | str, planned_s: float) -> str:
    """Why a run ``planned_s`` s (sim) long cannot record to ``bag_dir`` ('' when its file
    system has room for ``bag_bytes``)."""
    try:
        free = shutil.disk_usage(_existing(Path(bag_dir))).free
    except OSError:
        return ""  # the writability check says what is wrong
    needed = bag_bytes(planned_s)
    if free >= needed:
        return ""
    return (
        f"bag_dir {bag_dir}: {free / 1e6:.1f} MB free, and this run's bag needs about "
        f"{needed / 1e6:.1f} MB ({planned_s:.0f} s at {BAG_BYTES_PER_S / 1e3:.0f} kB/s, x1.5): "
        "free some room or give another bag_dir"
    )


def _existing(path: Path) -> Path:
    """``path``, or its nearest parent that exists."""
    while not path.exists() and path != path.parent:
        path = path.parent
    return path
