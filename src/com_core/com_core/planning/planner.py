"""Exploration planner: predict the accuracy of a tilt plan before moving, and invert it.

``predict(plan, method)`` is the 1-sigma of the estimate that ``method`` will give,
evaluated at the plan's guess of the object, for windows whose covariance follows from
the sensor noise, the rate and the dwell: cov = S (1/N + 1/N_tare) with N = dwell * rate
samples (the window mean minus its pose's tare mean) and S what one sample is worth in a
long window's mean (``Plan.sample_cov``): the noise's per-sample covariance times its
long-run factor, so a sensor whose samples are correlated is planned by its effective
number of samples, N / f (``com_core.sensing.noise``).

- ``ml``: the Cramer-Rao bound of the wrench-only model (``estimators.crlb``). The ML
  estimator reaches the bound, so the prediction is the spread a user will see.
- ``ml`` with information ``kinematics`` or ``kinematics+mount``: the bound of the
  kinematic fit (``known_gravity``) for the run's windows at their times
  (``plan_observations``: a cached tare pass, the bracketing bias windows, the object's);
  its dwell for a target is bisected on samples (the tare and bias windows are
  observations of their own, not a term of the variance factor below).
- ``two_pose`` (the paper's eqs. 3, 7, 8, 11): ``estimators.two_pose``'s own first-order
  covariance, J cov J^T, evaluated at noise-free windows built from the guess with the
  wrench model (f = m g_s, tau = p x f). It uses the first two windows in exploration
  order, home and the first tilt, so a plan's further poses do not improve it; with
  five poses it is 1.8-2.9x the ``ml`` bound.

The wrenches' two covariances are linear in the window variance factor c = 1/N +
1/N_tare (J does not depend on the noise; the Fisher information scales with 1/c), which
is how ``dwell_for_target`` solves their dwell for a requested COM sigma in closed form.

Information about the COM component along gravity grows with sin^2(tilt): at 0.05 rad
a plan needs ~100x the dwell of pi/6 for the same sigma. ``dwell_for_target`` says so
before the robot moves, names every change it makes to the plan, and keeps the plan's
tilt unless told it may raise it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.estimators import crlb, two_pose
from com_core.estimation.known_gravity import BIAS_DRIFT_RATE, Observation, kinematic_ml
from com_core.estimation.windows import Window
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import COV_FLOOR, NoiseModel, white_noise
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    SensorModel,
    as_vector,
    gravity_wrench,
    rotation_about,
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

HOME = "home"

METHODS: tuple[str, ...] = ("ml", "two_pose")
"""Estimators the planner predicts for (``com_core.estimation.estimators``)."""

_GRASP_TIME, _RELEASE_TIME = 4.0, 5.0
"""s from the end of a run's empty-hand window at home to its object pass (to the stand,
the fingers, the lift, the grasp check), and from the pass to the window after it (home,
the stand, the fingers, home): the sequencer's."""

_TILT_CEILING = 1.5
"""rad; the largest tilt the planner ever suggests as a remedy (Plan needs < pi/2)."""

_TWO_POSE_EVAL_FACTOR = 1e-6
"""Variance factor at which ``two_pose`` is evaluated for a prediction, then scaled.

Its covariance is exactly linear in the factor; a small one keeps the estimator's
own refusals (no load above 3 sigma, tilt not resolved) out of the prediction."""


@dataclass(frozen=True)
class Plan:
    """A tilt plan and what is known before moving.

    Attributes
    ----------
    tilt : rad; wrist tilt from home, about each axis of ``axes`` (sensor frame).
    axes : tilt axes, e.g. ('x', 'y'); the paper tilts once about x.
    both_directions : tilt +tilt and -tilt about each axis (else +tilt only).
    dwell : s of samples averaged per pose.
    tare_dwell : s per pose of the tare windows; None = same as ``dwell``; inf = the
        hand's wrench is known exactly (no tare noise).
    settle : s waited after each motion before the window starts.
    move_time : s per motion between poses.
    sensor : noise and rate of the F/T sensor (per sample).
    noise : the sensor's noise as learnt (a tare pass's, ``com_core.sensing.noise``) or assumed;
        None: white at ``sensor``'s sigma.
    calibration : the sensor's stated accuracy (``com_core.sensing.calibration``): the kinematic
        fit's prediction holds its systematic share, a floor no dwell lowers.
    mass_guess : kg. com_guess : shape (3,); m; sensor frame.
    gravity_home : shape (3,); gravity direction at home in the sensor frame (measure it
        from the tare's force; the paper's top grasp is (0, 0, -1)).
    bias_dwell : s of the empty-hand window of the object run that fits the sensor's
        bias (kinematic information; 0: the bias is fitted from the object windows).
    bias_drift_rate : N/s, N m/s; the estimator's prior on the bias's drift rate within
        a run (``known_gravity``).
    hand_mass_guess : kg. hand_com_guess : shape (3,); m; sensor frame (the hand's load
        is what resolves the mounting of ``kinematics+mount``).
    """

    tilt: float = math.pi / 6
    axes: tuple[str, ...] = ("x", "y")
    both_directions: bool = True
    dwell: float = 1.0
    tare_dwell: float | None = None
    settle: float = 0.3
    move_time: float = 1.0
    sensor: SensorModel = field(default_factory=lambda: SensorModel.from_scalars(0.1, 0.005))
    mass_guess: float = 0.1
    com_guess: tuple[float, float, float] = (0.0, 0.0, 0.05)
    gravity_home: tuple[float, float, float] = (0.0, 0.0, -1.0)
    bias_dwell: float = 3.0
    bias_drift_rate: tuple[float, float] = BIAS_DRIFT_RATE
    hand_mass_guess: float = 1.0
    hand_com_guess: tuple[float, float, float] = (0.0, 0.0, 0.04)
    noise: NoiseModel | None = None
    calibration: Calibration | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.tilt < math.pi / 2:
            raise ValueError(f"tilt must be in (0, pi/2) rad, got {self.tilt}")
        if not self.axes or any(a not in ("x", "y", "z") for a in self.axes):
            raise ValueError(f"axes must be a non-empty subset of x, y, z, got {self.axes}")
        if not self.dwell > 0 or not self.mass_guess > 0:
            raise ValueError("dwell and mass_guess must be > 0")
        if self.tare_dwell is not None and not self.tare_dwell > 0:
            raise ValueError(f"tare_dwell must be > 0 or None, got {self.tare_dwell}")
        if not self.bias_dwell >= 0:
            raise ValueError(f"bias_dwell must be >= 0, got {self.bias_dwell}")

    def tare_plan(self) -> Plan:
        """The plan of the tare pass: both directions about x, y and the plan's axes. A
        hand model needs tilts about two axes, and a pass cut to fewer poses
        (``fewer_poses``) then finds its poses tared."""
        axes = tuple(dict.fromkeys((*self.axes, "x", "y")))
        return replace(self, axes=axes, both_directions=True)

    def poses(self) -> list[tuple[str, NDArray[np.float64]]]:
        """(name, R_home_pose) per pose, home first: 'home', 'tilt_x+', 'tilt_x-', ..."""
        out = [(HOME, np.eye(3))]
        signs = (1, -1) if self.both_directions else (1,)
        for axis in self.axes:
            for sign in signs:
                name = f"tilt_{axis}{'+' if sign > 0 else '-'}"
                out.append((name, rotation_about(axis, sign * self.tilt)))
        return out

    def gravity_directions(self) -> NDArray[np.float64]:
        """Unit gravity direction per pose in the sensor frame, shape (n, 3)."""
        g_home = as_vector(self.gravity_home, 3, "gravity_home")
        g_home = g_home / np.linalg.norm(g_home)
        return np.array([R.T @ g_home for _, R in self.poses()])

    def samples_per_window(self) -> int:
        return max(1, round(self.dwell * self.sensor.rate_hz))

    def noise_model(self) -> NoiseModel:
        """The sensor's noise planned for: ``noise``, else white at ``sensor``'s."""
        if self.noise is not None:
            return self.noise
        return white_noise(self.sensor.sample_covariance(), self.sensor.rate_hz)

    def sample_cov(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of what one sample is worth in a long window's mean: the
        noise's per-sample covariance scaled per axis pair by sqrt(f_a f_b), f its
        long-run factor (n correlated samples are worth n / f independent ones), plus
        ``COV_FLOOR``^2 so that a noise-free sensor plans (its shortest dwell serves)."""
        noise = self.noise_model()
        root = np.sqrt(noise.long_run_factor)
        return noise.cov * np.outer(root, root) + np.diag(COV_FLOOR**2)

    def window_cov(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of each tare-subtracted window mean; N, N m."""
        return self.sample_cov() * self._variance_factor(self.dwell)

    def _variance_factor(self, dwell: float) -> float:
        """1/N + 1/N_tare for a window of ``dwell`` s."""
        rate = self.sensor.rate_hz
        tare = dwell if self.tare_dwell is None else self.tare_dwell
        return 1.0 / max(1.0, round(dwell * rate)) + (
            0.0 if math.isinf(tare) else 1.0 / max(1.0, round(tare * rate))
        )

    def duration(self) -> float:
        """s of one object pass: every pose's motion, settle and dwell."""
        return len(self.poses()) * (self.move_time + self.settle + self.dwell)


@dataclass(frozen=True)
class Prediction:
    """Predicted 1-sigma of the estimate ``method`` will give for a plan.

    Attributes
    ----------
    sigma_mass : kg.
    sigma_com : shape (3,); m; sensor frame.
    cov : shape (4, 4); covariance of (mass, com_x, com_y, com_z); kg, m.
    method : the estimator predicted for, one of ``METHODS``.
    information : what it uses, 'wrenches' or 'kinematics' (``exploration.INFORMATION``).
    """

    sigma_mass: float
    sigma_com: NDArray[np.float64]
    cov: NDArray[np.float64]
    method: str = "ml"
    information: str = "wrenches"

    def __str__(self) -> str:
        s = self.sigma_com * 1e3
        name = (
            self.method
            if self.information == "wrenches"
            else f"{self.method} ({self.information})"
        )
        return (
            f"{name}: sigma mass {self.sigma_mass * 1e3:.3g} g, COM ({s[0]:.3g}, "
            f"{s[1]:.3g}, {s[2]:.3g}) mm"
        )


def predict(plan: Plan, method: str = "ml", information: str = "wrenches") -> Prediction:
    """Predicted sigma of mass and each COM axis for ``plan`` and estimator ``method``.

    ``method`` 'ml': the CRLB at the guess (``estimators.crlb``; with ``information``
    'kinematics' or 'kinematics+mount', the kinematic fit's, ``_kinematic_cov``);
    'two_pose': the paper's method's own first-order covariance at noise-free windows of
    the guess (home and the first tilt; see the module), the wrenches' information
    whatever ``information`` says (as the estimator's). Raises ValueError for another
    method.
    """
    _check_method(method)
    information = information if method == "ml" else "wrenches"
    n = len(plan.poses())
    if information != "wrenches" and method == "ml":
        cov = _kinematic_cov(plan, information == "kinematics+mount")
    elif method == "two_pose":
        cov = _two_pose_cov(plan) * plan._variance_factor(plan.dwell)
    else:
        cov = crlb(
            plan.mass_guess,
            plan.com_guess,
            plan.gravity_directions(),
            np.repeat(plan.window_cov()[None], n, axis=0),
        )
    return Prediction(math.sqrt(cov[0, 0]), np.sqrt(np.diag(cov)[1:]), cov, method, information)


def _home_rotation(gravity_home: NDArray[np.float64]) -> NDArray[np.float64]:
    """A rotation R_base_sensor at home that sees the base's gravity (DEFAULT_GRAVITY)
    along ``gravity_home`` (unit, sensor frame): R @ gravity_home = the base's direction."""
    down = np.asarray(DEFAULT_GRAVITY) / np.linalg.norm(DEFAULT_GRAVITY)
    axis = np.cross(gravity_home, down)
    sin, cos = float(np.linalg.norm(axis)), float(gravity_home @ down)
    if sin < 1e-12:  # parallel, or opposite: half a turn about x
        return np.eye(3) if cos > 0 else rotation_about("x", math.pi)
    return rotation_about(axis, math.atan2(sin, cos))


def plan_observations(plan: Plan) -> list[Observation]:
    """The windows (noise-free, of the guesses; N, N m) the kinematic fit
    (``known_gravity.kinematic_ml``) sees in a run of ``plan`` that reuses a cached tare
    pass (``tare_plan``, ``tare_dwell`` per pose; epoch 1) and fits its bias from the
    object's windows and two ``bias_dwell`` windows at home that bracket them (the
    sequencer's; epoch 0), each at its time in the run. With ``tare_dwell`` inf the hand
    and the bias are known exactly: the object's windows alone."""
    g_home = as_vector(plan.gravity_home, 3, "gravity_home")
    home = _home_rotation(g_home / np.linalg.norm(g_home))
    base_g = np.asarray(DEFAULT_GRAVITY)
    sample_cov, rate = plan.sample_cov(), plan.sensor.rate_hz
    tare_dwell = plan.dwell if plan.tare_dwell is None else plan.tare_dwell
    hand_known = math.isinf(tare_dwell)

    def seen(
        pose: str, rotation, dwell: float, load: bool, epoch: int, time: float
    ) -> Observation:
        g = rotation.T @ base_g
        wrench = (
            0.0 if hand_known else gravity_wrench(plan.hand_mass_guess, plan.hand_com_guess, g)
        )
        if load:
            wrench = wrench + gravity_wrench(plan.mass_guess, plan.com_guess, g)
        n = max(1, round(dwell * rate))
        return Observation(Window(pose, wrench, sample_cov / n, n), rotation, load, epoch, time)

    rotations = [(name, home @ r) for name, r in plan.poses()]
    tare_rotations = [(name, home @ r) for name, r in plan.tare_plan().poses()]
    step = plan.move_time + plan.settle  # s between windows

    def at(k: int, dwell: float) -> float:  # the middle of the k-th window of a pass, s
        return k * (step + dwell) + dwell / 2

    observations = [
        seen(name, r, plan.dwell, True, 0, at(k, plan.dwell))
        for k, (name, r) in enumerate(rotations)
    ]
    if not hand_known:
        observations += [
            seen(name, r, tare_dwell, False, 1, at(k, tare_dwell))
            for k, (name, r) in enumerate(tare_rotations)
        ]
        if plan.bias_dwell > 0:
            before = -_GRASP_TIME - plan.bias_dwell / 2
            after = len(rotations) * (step + plan.dwell) + _RELEASE_TIME + plan.bias_dwell / 2
            for time in (before, after):
                observations.append(seen(HOME, home, plan.bias_dwell, False, 0, time))
    return observations


def _kinematic_cov(plan: Plan, fit_mount: bool) -> NDArray[np.float64]:
    """The CRLB (4, 4) of (m, p) of the kinematic fit for a run of ``plan``
    (``plan_observations``), its bias drifting at up to ``bias_drift_rate``: the fit's
    covariance at noise-free windows of the guesses is its CRLB."""
    observations = plan_observations(plan)
    rate = None if all(o.load for o in observations) else plan.bias_drift_rate
    return kinematic_ml(
        observations, DEFAULT_GRAVITY, fit_mount, rate, calibration=plan.calibration
    ).estimate.cov


def _check_method(method: str) -> None:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")


def _two_pose_cov(plan: Plan, g: float = STANDARD_GRAVITY) -> NDArray[np.float64]:
    """``two_pose``'s covariance (4, 4) of (m, p) per unit variance factor; kg, m.

    Windows in the order an exploration delivers them (``plan.poses()``: home first),
    means f = m g d_i, tau = p x f from the guess (``wrench_model.gravity_wrench``),
    covariance S * eps; two_pose propagates J cov J^T, so dividing by eps gives the
    covariance at c = 1 exactly (the Jacobian does not depend on the covariance).
    """
    cov = plan.sample_cov() * _TWO_POSE_EVAL_FACTOR
    windows = [
        Window(name, gravity_wrench(plan.mass_guess, plan.com_guess, g * d), cov, 1)
        for (name, _), d in zip(plan.poses(), plan.gravity_directions(), strict=True)
    ]
    return two_pose(windows, g, min_tilt_sigmas=0.0).cov / _TWO_POSE_EVAL_FACTOR


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


@dataclass(frozen=True)
class _Need:
    """What a plan (at its tilt) needs for a target; see ``_need``."""

    floor: float  # m; the worst COM-axis sigma with an unlimited dwell (the tare's)
    c_needed: float  # the largest variance factor that meets the target (nan: kinematic)
    dwell: float | None  # s per pose; None when the tare alone exceeds the target
    duration: float  # s of the object pass at that dwell (inf when dwell is None)


def _need(plan: Plan, target: float, method: str, information: str) -> _Need:
    """Shortest dwell at ``plan``'s tilt whose predicted worst COM sigma is <= target.

    sigma^2 = c * worst_unit^2 with c = 1/N + 1/N_tare (module): c_needed =
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


def _up(x: float) -> float:
    """``x`` rounded up to 3 significant digits (a remedy quoted must suffice)."""
    if not math.isfinite(x) or x <= 0:
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.ceil(x / scale * (1 - 1e-12)) * scale


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
    of the covariance with c = 1/N + 1/N_tare (module docstring). Infeasible when the
    tare's own noise already exceeds the target, or when the pass would take longer
    than ``max_time``; the reason then states the limit, what would meet the target
    (the least tilt, the time limit, or the tare needed) and the sigma reachable
    within the limits.

    fewer_poses : the plan's poses may also be cut (``_fewer_poses``): the advice is then
        the feasible one of the shortest object pass, its cut named in ``changes``.

    Raises ValueError for a target <= 0, an unknown method, max_tilt outside
    (0, pi/2), max_time <= 0, or raise_tilt without max_tilt.
    """
    if not target_com_sigma > 0:
        raise ValueError(f"target_com_sigma must be > 0 m, got {target_com_sigma}")
    _check_method(method)
    if max_tilt is not None and not 0.0 < max_tilt < math.pi / 2:
        raise ValueError(f"max_tilt must be in (0, pi/2) rad, got {max_tilt}")
    if not max_time > 0:
        raise ValueError(f"max_time must be > 0 s, got {max_time}")
    if raise_tilt and max_tilt is None:
        raise ValueError("raise_tilt needs max_tilt (the tilt to raise to)")
    if fewer_poses:  # the feasible plans (a cheap test), then the advice of the shortest
        options = dict(max_tilt=max_tilt, max_time=max_time, raise_tilt=raise_tilt)
        options |= dict(method=method, information=information)
        feasible = [
            (cut, why)
            for cut, why in [(plan, ""), *_fewer_poses(plan, method, information)]
            if _fits(cut, target_com_sigma, **options)
        ]
        if not feasible:
            return dwell_for_target(plan, target_com_sigma, **options)
        advices = [
            (dwell_for_target(cut, target_com_sigma, **options), why) for cut, why in feasible
        ]
        best, why = min(advices, key=lambda a: a[0].plan.duration())
        return replace(best, changes=(why, *best.changes)) if why else best

    plan, base, changes = _tilt_rules(plan, max_tilt, raise_tilt)
    tilt = base.tilt
    target_mm = target_com_sigma * 1e3
    need = _need(base, target_com_sigma, method, information)

    def with_dwell(dwell: float, why: str) -> Plan:
        if dwell != plan.dwell:
            tare = " and per tare pose (tare_dwell None)" if plan.tare_dwell is None else ""
            changes.append(
                f"dwell {plan.dwell:.3g} -> {dwell:.3g} s per pose{tare} ({why}; object pass "
                f"{replace(base, dwell=plan.dwell).duration():.3g} -> "
                f"{replace(base, dwell=dwell).duration():.3g} s)"
            )
        return replace(base, dwell=dwell)

    if need.dwell is not None and need.duration <= max_time:
        out = with_dwell(need.dwell, f"the shortest for {method} COM sigma {target_mm:.3g} mm")
        return Advice(True, out, predict(out, method, information), "", tuple(changes))

    # Infeasible: what fails, what would make it feasible, what the limits reach.
    n = len(base.poses())
    if need.dwell is None:
        floor = need.floor * 1e3
        fails = (
            f"the tare ({base.tare_dwell:g} s per pose) alone gives {method} COM sigma "
            f"{floor:.3g} mm > target {target_mm:.3g} mm; take a longer tare"
        )
    else:
        fails = (
            f"{method} COM sigma {target_mm:.3g} mm at tilt {tilt:.3g} rad needs "
            f"{need.dwell:.3g} s per pose ({need.duration:.3g} s in all) > limit {max_time:g} s"
        )
    remedies = []
    # the least tilt that meets it within max_time (at most max_tilt, else above it)
    within = None if max_tilt is None or tilt >= max_tilt else max_tilt
    least = (
        _least_tilt(base, target_com_sigma, method, information, max_time, within)
        if within
        else None
    )
    if least is not None:
        remedies.append(
            f"tilt >= {least:.3f} rad (max_tilt {max_tilt:.3g} allows it: set the tilt, "
            "or raise_tilt)"
        )
    else:
        least = _least_tilt(base, target_com_sigma, method, information, max_time, _TILT_CEILING)
        if least is not None:
            above = f", above max_tilt {max_tilt:.3g} rad" if max_tilt is not None else ""
            remedies.append(f"tilt >= {least:.3f} rad{above}")
    if need.dwell is not None:
        remedies.append(f"max_time >= {_up(need.duration):.3g} s")
    elif math.isnan(need.c_needed):
        remedies.append("a longer tare_dwell or bias_dwell (the kinematic fit's hand and bias)")
    else:
        # a tare long enough to leave room for a dwell within max_time, else the tare
        # and dwell that meet it, with the time they take
        rate = base.sensor.rate_hz
        n_obj = 0
        if math.isfinite(max_time):
            n_obj = max(0, math.floor((max_time / n - base.move_time - base.settle) * rate))
        room = need.c_needed - 1.0 / max(1, n_obj)
        if n_obj >= 1 and room > 0:
            remedies.append(
                f"tare_dwell >= {_up(math.ceil(1.0 / room) / rate):.3g} s per pose "
                f"(with dwell {n_obj / rate:.3g} s)"
            )
        else:
            both = _up(math.ceil(2.0 / need.c_needed) / rate)
            time = f" and max_time >= {_up(replace(base, dwell=both).duration()):.3g} s"
            remedies.append(
                f"tare_dwell >= {both:.3g} s and dwell >= {both:.3g} s per pose"
                + (time if math.isfinite(max_time) else "")
            )
    remedy = f"; feasible with {', or '.join(remedies)}" if remedies else ""

    dwell_max = max_time / n - base.move_time - base.settle
    if math.isfinite(max_time) and dwell_max <= 0:
        reason = f"{n} poses cannot even be visited in {max_time:g} s{remedy}"
        return Advice(False, base, predict(base, method, information), reason, tuple(changes))
    if math.isfinite(max_time):
        best_plan = with_dwell(dwell_max, f"the longest within {max_time:g} s; target not met")
    else:
        best_plan = base
    best = predict(best_plan, method, information)
    reason = f"{fails}{remedy}; within the limits: {best}"
    return Advice(False, best_plan, best, reason, tuple(changes))
