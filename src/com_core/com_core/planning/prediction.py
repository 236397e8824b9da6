"""What a tilt plan will give, before moving: the 1-sigma of the estimate.

``predict(plan, method)`` is the 1-sigma of the estimate that ``method`` will give,
evaluated at the plan's guess of the object, for windows whose covariance follows from
the sensor noise, the rate and the dwell: cov = S (1/N + 1/N_tare) (``planner``).

- ``ml``: the Cramer-Rao bound of the wrench-only model (``estimators.crlb``). The ML
  estimator reaches the bound, so the prediction is the spread a user will see.
- ``ml`` with information ``kinematics`` or ``kinematics+mount``: the bound of the
  kinematic fit (``known_gravity``) for the run's windows at their times
  (``plan_observations``: a cached tare pass, the bracketing bias windows, the object's).
- ``two_pose`` (the paper's eqs. 3, 7, 8, 11): ``estimators.two_pose``'s own first-order
  covariance, J cov J^T, evaluated at noise-free windows built from the guess with the
  wrench model (f = m g_s, tau = p x f). It uses the first two windows in exploration
  order, home and the first tilt, so a plan's further poses do not improve it.

The wrenches' two covariances are linear in the window variance factor c = 1/N +
1/N_tare (J does not depend on the noise; the Fisher information scales with 1/c); the
kinematic fit's tare and bias windows are observations of their own, not a term of c.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.estimators import crlb, two_pose
from com_core.estimation.fits.known_gravity import Observation, kinematic_ml
from com_core.estimation.fits.windows import Window
from com_core.estimation.runs.fit_setup import FitSetup
from com_core.planning.planner import HOME, Plan
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.wrench_model import (
    STANDARD_GRAVITY,
    as_vector,
    gravity_in_sensor,
    gravity_wrench,
    rotation_about,
)

__all__ = ["METHODS", "Prediction", "carried_hysteresis", "plan_observations", "predict"]

METHODS: tuple[str, ...] = ("ml", "two_pose")
"""Estimators the planner predicts for (``com_core.estimation.fits.estimators``)."""

_GRASP_TIME, _RELEASE_TIME = 4.0, 5.0
"""s from the end of a run's empty-hand window at home to its object pass (to the stand,
the fingers, the lift, the grasp check), and from the pass to the window after it (home,
the stand, the fingers, home): the sequencer's."""

_UNKNOWN_WAY = np.full(6, np.inf)
"""The travel (N, N m) of a load's way not known before the run: unbounded."""

_TWO_POSE_EVAL_FACTOR = 1e-6
"""Variance factor at which ``two_pose`` is evaluated for a prediction, then scaled.

Its covariance is exactly linear in the factor; a small one keeps the estimator's
own refusals (no load above 3 sigma, tilt not resolved) out of the prediction."""


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
    and the bias are known exactly: the object's windows alone. The grasp's and the
    release's paths are not known before the run (the fingers press on the table, the lift
    overshoots): the windows after them have an unbounded ``travel``, the most a sensor's
    hysteresis moves on such a way (``Hysteresis.window_sigma``); the moves between poses
    are taken as straight, and the hysteresis's move beyond its first order along them as
    told by this run's samples (``Observation.beyond``), not by the cached pass's."""
    g_home = as_vector(plan.gravity_home, 3, "gravity_home")
    home = _home_rotation(g_home / np.linalg.norm(g_home))
    base_g = np.asarray(DEFAULT_GRAVITY)
    sample_cov, rate = plan.sample_cov(), plan.sensor.rate_hz
    tare_dwell = plan.dwell if plan.tare_dwell is None else plan.tare_dwell
    hand_known = math.isinf(tare_dwell)

    def seen(
        pose: str, rotation, dwell: float, load: bool, epoch: int, time: float
    ) -> Observation:
        g = gravity_in_sensor(rotation, base_g)
        wrench = (
            0.0 if hand_known else gravity_wrench(plan.hand_mass_guess, plan.hand_com_guess, g)
        )
        if load:
            wrench = wrench + gravity_wrench(plan.mass_guess, plan.com_guess, g)
        n = max(1, round(dwell * rate))
        window = Window(pose, wrench, sample_cov / n, n)
        beyond = np.zeros(6) if epoch == 0 else None  # this run's samples tell it
        return Observation(window, rotation, load, epoch, time, beyond=beyond)

    rotations = [(name, home @ r) for name, r in plan.poses()]
    tare_rotations = [(name, home @ r) for name, r in plan.tare_plan().poses()]
    step = plan.move_time + plan.settle  # s between windows

    def at(k: int, dwell: float) -> float:  # the middle of the k-th window of a pass, s
        return k * (step + dwell) + dwell / 2

    observations = [
        seen(name, r, plan.dwell, True, 0, at(k, plan.dwell))
        for k, (name, r) in enumerate(rotations)
    ]
    observations[0] = replace(observations[0], travel=_UNKNOWN_WAY)  # after the grasp
    if not hand_known:
        observations += [
            seen(name, r, tare_dwell, False, 1, at(k, tare_dwell))
            for k, (name, r) in enumerate(tare_rotations)
        ]
        if plan.bias_dwell > 0:
            before = -_GRASP_TIME - plan.bias_dwell / 2
            after = len(rotations) * (step + plan.dwell) + _RELEASE_TIME + plan.bias_dwell / 2
            observations.append(seen(HOME, home, plan.bias_dwell, False, 0, before))
            released = seen(HOME, home, plan.bias_dwell, False, 0, after)
            observations.append(replace(released, travel=_UNKNOWN_WAY))
    return observations


def _kinematic_cov(plan: Plan, fit_mount: bool) -> NDArray[np.float64]:
    """The CRLB (4, 4) of (m, p) of the kinematic fit for a run of ``plan``
    (``plan_observations``), its bias drifting at up to ``bias_drift_rate``: the fit's
    covariance at noise-free windows of the guesses is its CRLB."""
    observations, nuisance_cov = carried_hysteresis(plan, plan_observations(plan))
    rate = None if all(o.load for o in observations) else plan.bias_drift_rate
    fit = kinematic_ml(observations, DEFAULT_GRAVITY, fit_mount, rate,
                       calibration=plan.calibration, nuisance_cov=nuisance_cov)  # fmt: skip
    return fit.estimate.cov


def carried_hysteresis(
    plan: Plan, observations: list[Observation]
) -> tuple[list[Observation], NDArray[np.float64] | None]:
    """``observations`` carrying what ``plan``'s stated hysteresis leaves, and its
    covariance, as the fit weighs them (``FitSetup.with_hysteresis``, ``hysteresis_cov``);
    as they are and None without one."""
    told = FitSetup(hysteresis=plan.hysteresis)
    carried = told.with_hysteresis(observations)
    return carried, told.hysteresis_cov(carried)


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
