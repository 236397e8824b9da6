"""The solution of an exploration in motion: the empty hand's motion, the object's and a
check along a motion neither fit used (docs/design.md, Identification in motion).

The labels ``motion/tare``, ``motion/object`` and ``motion/verify`` (``com_core.contract``)
span the three motions; the static windows of the same run (``tare/<pose>``, the empty
hand at rest) give the sensor's noise model. Each motion is fitted by
``motion.fit_motion`` with the joint states of the inbox: the hand first (the whole load
of the empty hand; without ``motion/tare`` the hand's fit of an earlier run,
``FitSetup.hand_motion``), then the object with the hand taken off. The object's fit is
consistent with one rigid load when its whitened residual is no larger than
``MAX_CHI2_PER_DOF`` times what the noise model, the encoders' noise, the calibration's
error and a misfit in common with the empty hand's motion explain (``MotionFit.expected``;
a load that moves in the grasp leaves a residual the model has no parameter for), or
than what they explain with the calibration's misfit at its 1 - alpha quantile over
sensors in place of its mean (``allowed_chi2_per_dof``). The
check along the verification motion (``MotionCheck``) compares the rms of the
compensated wrench with what the noise, the fit's covariance and the calibration predict,
within what one draw of the fit's and the calibration's errors may give. The inertia is
published only when the motion told it: every principal moment beyond its sigma
(``MotionResult.inertia_identified``). Units: N, N m, kg, m, kg m^2, s; the sensor frame.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from com_core.contract import MOTION_OBJECT, MOTION_REST, MOTION_TARE, MOTION_VERIFY
from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.estimators import Consistency, Estimate
from com_core.estimation.fits.motion import (
    WINDOW,
    MotionFit,
    fit_motion,
    joint_motion,
    motion_calibration,
    principal_moments,
    regressors_along,
)
from com_core.estimation.fits.stats import chi2_isf
from com_core.estimation.runs.cutting import motion_spans
from com_core.estimation.runs.fit_setup import FitSetup
from com_core.estimation.runs.hand_motion import PATH_POINTS, HandMotion
from com_core.estimation.runs.inbox import Inbox
from com_core.robot.model import RobotModel
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import NoiseModel

__all__ = [
    "EXCITATIONS",
    "MAX_CHI2_PER_DOF",
    "MIN_MOMENT_SIGMAS",
    "MOTION",
    "STATIC",
    "MotionCheck",
    "MotionResult",
    "allowed_chi2_per_dof",
    "fitted_wrenches",
    "hand_motion_of",
    "solve_motion",
]

STATIC, MOTION = "static", "motion"
EXCITATIONS = (STATIC, MOTION)
"""How an exploration excites the load: windows at rest, or the wrist's motion."""
MAX_CHI2_PER_DOF = 1.5
"""The object's fit is one rigid load while chi^2/dof stays below this times what the
noise, the encoders, the calibration's error and a misfit in common with the hand's
motion explain (``MotionFit.expected``;
chi^2/dof 0.99-1.10 measured over 73 sensors with the realistic profile at 0.5 kg, and
1.69 at 2 kg on the xArm6, 1.37 times the 1.23 explained)."""
MIN_MOMENT_SIGMAS = 1.0
"""The inertia is published when every principal moment exceeds this many of its sigmas:
a moment within its sigma is told no better than by a point mass at the COM."""
_MIN_JOINT_STATES = 10  # a motion's joint states, at the least
_DRAWS = 2000  # of the fit's and the calibration's errors, for the check's allowance
_DRAW_SAMPLES = 300  # samples of the motion each draw is evaluated at
_FORCE, _TORQUE = slice(0, 3), slice(3, 6)


@dataclass(frozen=True)
class MotionCheck:
    """The compensated wrench along a motion no fit used: ``rms`` (6,) per axis, N and
    N m, against ``predicted`` (6,), the rms the sensor's noise, the fit's error through
    the regressor and the calibration's error give; ``ratio`` (forces, torques) of the
    pooled rms to the pooled prediction, against ``allowed`` (forces, torques; see
    ``check_motion``); ``n`` samples."""

    pose: str
    rms: NDArray[np.float64]
    predicted: NDArray[np.float64]
    ratio: tuple[float, float]
    allowed: tuple[float, float]
    n: int

    @property
    def passed(self) -> bool:
        return all(r <= a for r, a in zip(self.ratio, self.allowed, strict=True))

    def summary(self) -> str:
        return (
            f"verification along {self.pose!r}: compensated rms {self.ratio[0]:.2f} and "
            f"{self.ratio[1]:.2f} times the prediction (allowed {self.allowed[0]:.2f} and "
            f"{self.allowed[1]:.2f})"
        )

    def as_dict(self) -> dict:
        return {
            f"verify_rms {self.pose}": self.rms.tolist(),
            f"verify_rms_predicted {self.pose}": self.predicted.tolist(),
            f"verify_ratio {self.pose}": [*self.ratio, *self.allowed],
        }


@dataclass(frozen=True)
class MotionResult:
    """The fits of one exploration in motion: the empty ``hand``'s (its whole load) and
    the ``object``'s (the hand taken off), and the covariance ``load_cov`` (10, 10) of the
    object's ``MotionFit.load_vector`` (mass, COM, the inertia's ``INERTIA_ELEMENTS``);
    ``allowed`` the chi^2/dof the one-rigid-load test allowed the object's fit
    (``allowed_chi2_per_dof``; NaN: not tested)."""

    hand: MotionFit
    object: MotionFit
    load_cov: NDArray[np.float64]
    allowed: float = math.nan

    @property
    def inertia(self) -> NDArray[np.float64]:
        """(3, 3) kg m^2: the object's inertia about its COM, ``ft_sensor``."""
        return self.object.load()[2]

    @property
    def sigma_inertia(self) -> NDArray[np.float64]:
        """(6,) kg m^2, of the ``INERTIA_ELEMENTS``."""
        return np.sqrt(np.diag(self.load_cov)[4:])

    @property
    def moments(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(the principal moments (3,), ascending, their sigmas (3,)): kg m^2, of
        ``inertia`` (``principal_moments``)."""
        return principal_moments(self.inertia, self.load_cov[4:, 4:])

    @property
    def inertia_identified(self) -> bool:
        """Every principal moment exceeds ``MIN_MOMENT_SIGMAS`` of its sigma: the motion
        told the inertia. Otherwise it is not published (nor in the payload: the object a
        point mass at its COM); its fit stays in the diagnostics as ``inertia_fit``."""
        moments, sigma = self.moments
        return bool(np.all(moments > MIN_MOMENT_SIGMAS * sigma))

    def as_dict(self) -> dict:
        hand_mass, hand_com, _ = self.hand.load()
        return {
            "inertia" if self.inertia_identified else "inertia_fit": (
                self.object.load_vector()[4:].tolist()
            ),
            "sigma_inertia": self.sigma_inertia.tolist(),
            "inertia_cov": self.load_cov[4:, 4:].ravel().tolist(),
            "bias": self.object.bias.tolist(),
            "hand_mass": hand_mass,
            "hand_com": hand_com.tolist(),
            "parameters": self.object.pi.tolist(),
            "hand_parameters": self.hand.pi.tolist(),
            "delay": self.object.delay,
            "chi2_expected_per_dof": self.object.expected,
            "chi2_allowed_per_dof": self.allowed,
            "chi2_common_per_dof": self.object.common / self.object.dof,
            "motion_samples": self.object.samples,
        }


def joint_arrays(
    inbox: Inbox, robot: RobotModel, start_ns: int, stop_ns: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(stamps s (n,), positions (n, ``robot.joint_names``)) of the inbox's joint states
    in [start_ns, stop_ns), in time order, one per stamp; a state without every joint that
    moves the sensor (``robot.chain_names``; another publisher's: a gripper's) is left out,
    and the joints beyond the sensor hold 0. EstimationError when fewer than
    ``_MIN_JOINT_STATES`` are left."""
    names, chain = robot.joint_names, robot.chain_names
    rows = {
        t: [joints.get(n, 0.0) for n in names]
        for t, joints in inbox.joint_states
        if start_ns <= t < stop_ns and all(n in joints for n in chain)
    }
    if len(rows) < _MIN_JOINT_STATES:
        raise EstimationError(
            f"{len(rows)} joint states with every joint that moves the sensor "
            f"({', '.join(chain)}) from {start_ns * 1e-9:.3f} to {stop_ns * 1e-9:.3f} s"
        )
    stamps = sorted(rows)
    return np.array(stamps, dtype=np.float64) * 1e-9, np.array([rows[t] for t in stamps])


def _motion_data(
    inbox: Inbox, robot: RobotModel, label: str, until_ns: int | None
) -> tuple[NDArray[np.float64], ...]:
    """(joint stamps s, joint positions, wrench stamps s, wrenches) of motion ``label``:
    the wrenches within its span but its rest (``MOTION_REST``: the fits weigh every
    period of the excitation alike, the hand's and the object's), the joint states a
    second beyond it either way."""
    parts = motion_spans(inbox, until_ns).get(label)
    if not parts:
        raise EstimationError(f"no {label!r} span before the end")
    start, stop = parts[0][0], parts[-1][1]
    stamps, wrenches = inbox.samples()
    inside = (stamps >= start) & (stamps < stop - round(MOTION_REST * 1e9))
    joint_times, positions = joint_arrays(inbox, robot, start - 10**9, stop + 10**9)
    return joint_times, positions, stamps[inside] * 1e-9, wrenches[inside]


def _fit(
    inbox: Inbox,
    setup: FitSetup,
    label: str,
    noise: NoiseModel,
    until_ns: int | None,
    hand: MotionFit | None = None,
) -> MotionFit:
    assert setup.robot is not None
    data = _motion_data(inbox, setup.robot, label, until_ns)
    try:
        return fit_motion(
            setup.robot, *data, noise, hand, setup.calibration, hysteresis=setup.hysteresis
        )
    except ValueError as exc:
        raise EstimationError(f"{label}: {exc}") from exc


def check_motion(
    robot: RobotModel,
    result: MotionResult,
    noise: NoiseModel,
    calibration: Calibration | None,
    data: tuple[NDArray[np.float64], ...],
    pose: str,
    alpha: float,
) -> MotionCheck:
    """The ``MotionCheck`` of the load ``result`` along the motion ``data`` (joint stamps
    s, joint positions, wrench stamps s, wrenches): the wrenches less the hand's and the
    object's wrench, less their mean (the bias, fitted again: the check is of the load).

    What the compensated wrench holds besides the noise is one draw of the fits' errors,
    the same at every sample, which the rms does not average away: the calibration's
    error E read along this motion less what the fits made of it on theirs (their
    ``calibration_gain``), and the object fit's noise (its bound, widened as the fit
    widened it; the hand's error, taken off along the same trajectory, the object's fit
    took up). ``predicted`` is the rms over ``_DRAWS`` seeded draws of both and of the
    noise model's own error (its variance learnt from ``noise.samples`` correlated
    samples); the allowance, forces and torques apart, the 1 - ``alpha`` / 2 quantile of
    the ratio over them (the two tests together at ``alpha``)."""
    joint_times, positions, times, wrenches = data
    hand, fit = result.hand, result.object
    inner = _covered(joint_times, times, fit.delay)
    times, wrenches = times[inner], wrenches[inner]
    if len(times) < 100:
        raise EstimationError(f"{pose}: {len(times)} samples within the joint states' span")
    along = regressors_along(robot, *joint_motion(joint_times, positions, times - fit.delay))
    left = wrenches - along @ (hand.least_squares + fit.pi)
    left -= left.mean(axis=0)
    every = max(len(times) // _DRAW_SAMPLES, 1)
    Y = along[::every]
    rng = np.random.default_rng(0)
    widened = fit.bound * fit.widening
    shift = rng.multivariate_normal(np.zeros(10), widened, _DRAWS, method="eigh")
    errors = np.einsum("nai,di->dna", Y, shift)
    if calibration is not None:
        J = calibration.stacked_jacobian(wrenches[::every]).reshape(len(Y), 6, 36)
        read = J - np.einsum("nai,ij->naj", Y, hand.calibration_gain + fit.calibration_gain)
        E = calibration.draws(rng, _DRAWS)
        errors += np.einsum("naj,dj->dna", read, E)
    errors -= errors.mean(axis=1, keepdims=True)
    learnt_from = 1 / noise.samples if noise.samples > 0 else 0.0  # 0: assumed, not learnt
    spread = np.sqrt(2 * noise.variance_dof_factor * (learnt_from + 1 / len(times)))
    variance = noise.variance * np.maximum(1 + spread * rng.standard_normal((_DRAWS, 6)), 0.0)
    mean_square = variance + np.mean(errors**2, axis=1)  # (draws, 6)
    predicted = np.sqrt(np.mean(mean_square, axis=0))
    rms = np.sqrt(np.mean(left**2, axis=0))

    def pooled(x: NDArray[np.float64], axes: slice) -> NDArray[np.float64]:
        return np.sqrt(np.sum(x[..., axes], axis=-1) / np.sum(predicted[axes] ** 2))

    ratio = [float(pooled(rms**2, axes)) for axes in (_FORCE, _TORQUE)]
    allowed = [float(np.quantile(pooled(mean_square, axes), 1 - alpha / 2))
               for axes in (_FORCE, _TORQUE)]  # fmt: skip
    return MotionCheck(pose, rms, predicted, (ratio[0], ratio[1]), (allowed[0], allowed[1]),
                       len(times))  # fmt: skip


def _covered(
    joint_times: NDArray[np.float64], times: NDArray[np.float64], delay: float
) -> NDArray[np.bool_]:
    """Which wrench ``times`` (s) the joint states cover with the joint motion's window
    on both sides, ``delay`` s earlier."""
    margin = WINDOW + abs(delay)
    return (times > joint_times[0] + margin) & (times < joint_times[-1] - margin)


def solve_motion(
    inbox: Inbox,
    setup: FitSetup,
    noise: NoiseModel | None,
    until_ns: int | None,
    notes: list[str],
) -> tuple[Estimate, Consistency, MotionResult, tuple[MotionCheck, ...]]:
    """(estimate of mass and COM, consistency, the motion fits, the verification) of the
    motions in ``inbox`` with the sensor's ``noise`` model (see module). EstimationError
    with the reason when there is no robot model, no noise model, or a motion is missing
    or does not excite the load; a verification motion that cannot be checked is noted
    in ``notes``."""
    robot = setup.robot
    if robot is None:
        why = setup.robot_problem or "no URDF on /robot_description"
        raise EstimationError(f"an exploration in motion needs the robot model ({why})")
    if noise is None:
        raise EstimationError(
            "no noise model: no empty-hand window at rest to learn it from, and none known"
        )
    spans = motion_spans(inbox, until_ns)
    if MOTION_TARE in spans:
        hand = _fit(inbox, setup, MOTION_TARE, noise, until_ns)
    elif setup.hand_motion is not None:  # the empty hand's motion of an earlier run
        hand = setup.hand_motion
    else:
        raise EstimationError(
            f"no {MOTION_TARE!r} span and no empty hand's motion fit of an earlier run "
            "(hand_motion.json beside the tare cache): the object's fit needs the hand's"
        )
    fit = _fit(inbox, setup, MOTION_OBJECT, noise, until_ns, hand)
    mass, com, _ = fit.load()
    load_cov = fit.load_cov()
    per_dof, allowed = fit.chi2 / fit.dof, allowed_chi2_per_dof(fit, setup.alpha)
    result = MotionResult(hand, fit, load_cov, allowed)
    consistent = per_dof <= allowed
    consistency = Consistency(
        consistent,
        fit.chi2,
        fit.dof,
        math.nan,  # over ~10^4 dof any model error is significant: chi^2/dof is the test
        setup.alpha,
        None if consistent else "motion",
        "" if consistent else (
            f"the object's motion leaves chi^2/dof {per_dof:.2f} (allowed {allowed:.2f}: "
            f"{MAX_CHI2_PER_DOF:g} times the {fit.expected:.2f} the noise, the "
            "calibration's error and the empty hand's misfit explain, or the "
            "calibration's at its quantile): not one rigid load (did it move in the grasp?)"
        ),
    )  # fmt: skip
    estimate = Estimate(
        setup.method, mass, com, load_cov[:4, :4], fit.chi2, fit.dof, consistency.p_value,
        ("motion",),
    )  # fmt: skip
    checks: tuple[MotionCheck, ...] = ()
    if MOTION_VERIFY in spans:
        try:
            data = _motion_data(inbox, robot, MOTION_VERIFY, until_ns)
            calibration = motion_calibration(setup.calibration, setup.hysteresis, data[3])
            check = check_motion(robot, result, noise, calibration, data, "motion",
                                 setup.alpha)  # fmt: skip
            checks = (check,)
        except (EstimationError, ValueError) as exc:
            notes.append(f"verification left out: {exc}")
    return estimate, consistency, result, checks


def allowed_chi2_per_dof(fit: MotionFit, alpha: float) -> float:
    """The chi^2/dof the one-rigid-load test allows ``fit``: ``MAX_CHI2_PER_DOF`` times
    what is explained (``MotionFit.expected``), or, where the calibration's misfit rules,
    what is explained with that misfit at its 1 - ``alpha`` quantile over sensors in place
    of its mean. The misfit of one sensor is a sum of few squared normals
    (``MotionFit.misfit``): matched in mean and variance by c chi^2_nu, nu = sum(l)^2 /
    sum(l^2), c = sum(l^2) / sum(l); with 3 % of a 2 kg load's wrench nu is a few, and
    one sensor in some tens leaves more than 1.5 times its mean."""
    allowed = MAX_CHI2_PER_DOF * fit.expected
    if fit.misfit_squares > 0.0:
        nu = fit.misfit**2 / fit.misfit_squares
        quantile = fit.misfit_squares / fit.misfit * chi2_isf(alpha, nu)
        allowed = max(allowed, fit.expected + (quantile - fit.misfit) / fit.dof)
    return allowed


def fitted_wrenches(
    inbox: Inbox,
    robot: RobotModel,
    load: NDArray[np.float64],
    bias: NDArray[np.float64],
    delay: float,
) -> list[tuple[str, NDArray[np.float64], NDArray[np.float64]]]:
    """(label, wrench stamps s, the wrench (n, 6) the fitted ``load`` (10,; hand and
    object) and ``bias`` (6,) give ``delay`` s after the joint states) of the object's
    motions in ``inbox`` (what a report draws against the measured wrench); a motion
    whose joint states do not cover it is left out."""
    out = []
    for label in (MOTION_OBJECT, MOTION_VERIFY):
        try:
            joint_times, positions, times, _ = _motion_data(inbox, robot, label, None)
            at = times[_covered(joint_times, times, delay)]
            if len(at) < 2:
                continue
            Y = regressors_along(robot, *joint_motion(joint_times, positions, at - delay))
        except (EstimationError, ValueError):
            continue
        out.append((label, at, Y @ load + bias))
    return out


def hand_motion_of(
    inbox: Inbox, solution_motion: MotionResult | None, robot: RobotModel | None, owner: str
) -> HandMotion | None:
    """The ``HandMotion`` of ``owner`` (the hand on the sensor) to cache from an exploration
    whose empty hand moved (``motion/tare``) and whose solution in motion is
    ``solution_motion`` (of a usable solution), with ``PATH_POINTS`` of its joint states;
    None otherwise."""
    parts = motion_spans(inbox).get(MOTION_TARE)
    if solution_motion is None or robot is None or not parts:
        return None
    start, stop = parts[0][0], parts[-1][1]
    try:
        times, positions = joint_arrays(inbox, robot, start, stop)
    except EstimationError:
        return None
    kept = np.linspace(0, len(times) - 1, PATH_POINTS).round().astype(int)
    return HandMotion(owner, robot.urdf_sha256, start, times[kept] - start * 1e-9,
                      positions[kept], time.time(), solution_motion.hand)  # fmt: skip
