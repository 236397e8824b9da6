"""One exploration's solution: the estimate with a status, the checks at the poses no fit
used, and the readers of its diagnostic values.

``solve`` takes an inbox (``inbox``) and what the fits take (``fits.FitSetup``): the
windows cut by the labels (``cutting``), less the tare of their pose or fitted with the
hand and the bias (``fits``), tested for one rigid load, and checked at the
``verify/<pose>`` windows: the wrench the kinematic fit predicts there is compared with
the window's mean (``Verification``). Wrenches are in N and N m, masses in kg, COMs in m,
all in the sensor frame.

Statuses (``com_core.contract``): ERROR (no estimate: no windows, too few poses,
ill-conditioned, no tare, no load), WARN (an estimate, but: the object moved in the grasp,
the wrench at a verification pose is off the prediction, or input was dropped), OK.
``Solution.usable`` tells the estimates to hand on (OK, or WARN for dropped input only)
from those kept for diagnosis (an inconsistent fit, a failed verification).

A solution travels as diagnostic_msgs/KeyValue pairs (``Solution.diagnostic_values``):
vectors comma-joined per axis, floats as their shortest repr; ``vector_value``,
``inertia_value``, ``verification_lines`` and ``noise_line`` read them back.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from com_core.contract import ERROR, OBJECT_PREFIX, OK, TARE_PREFIX, VERIFY_PREFIX, WARN
from com_core.estimation.fits.errors import EstimationError, MissingTareError, WindowError
from com_core.estimation.fits.estimators import Consistency, Estimate, check_consistency
from com_core.estimation.fits.in_place import InPlaceCalibration
from com_core.estimation.fits.known_gravity import KinematicFit, Observation, mount_rpy
from com_core.estimation.fits.stats import chi2_isf
from com_core.estimation.fits.windows import Window, subtract_tare
from com_core.estimation.runs.cutting import (
    motion_spans,
    noise_model,
    reduced_windows,
    segments,
    window_rotation,
    window_time,
)
from com_core.estimation.runs.fit_setup import KINEMATICS, WRENCHES, FitSetup, check_load_direction
from com_core.estimation.runs.inbox import Inbox, shorten
from com_core.estimation.runs.motion_solution import (
    MIN_MOMENT_SIGMAS,
    MOTION,
    STATIC,
    MotionCheck,
    MotionResult,
    solve_motion,
)
from com_core.sensing.noise import NoiseModel

__all__ = [
    "ERROR",
    "OK",
    "WARN",
    "Solution",
    "Verification",
    "format_solution",
    "inertia_value",
    "missing_samples",
    "noise_line",
    "solve",
    "vector_value",
    "verification_lines",
    "verify",
    "window_counts",
]


@dataclass(frozen=True)
class Verification:
    """The compensated wrench at a pose no fit used (a ``verify/<pose>`` window): the
    window's mean less the wrench the kinematic fit predicts there (the bias, the hand and
    the object; ``KinematicFit.predict``), which is zero if the estimate holds beyond the
    poses it was fitted on.

    wrench : (6,) the mean compensated wrench, N and N m, sensor frame. cov : (6, 6) its
    covariance: the window mean's noise (``noise``) plus the prediction's. distance :
    the force's and the torque's Mahalanobis distance from zero (3 dof each), against
    ``allowed``, the distance at the consistency test's alpha.
    """

    pose: str
    wrench: NDArray[np.float64]
    cov: NDArray[np.float64]
    noise: NDArray[np.float64]
    distance: tuple[float, float]
    allowed: float
    n: int

    @property
    def passed(self) -> bool:
        return max(self.distance) <= self.allowed

    @property
    def sigma(self) -> NDArray[np.float64]:
        """(6,) the compensated wrench's sigma per axis, N and N m."""
        return np.sqrt(np.diag(self.cov))

    def as_dict(self) -> dict:
        """The check's values for ``Solution.as_dict``, keyed by its pose."""
        return {
            f"verify_wrench {self.pose}": self.wrench.tolist(),
            f"verify_sigma {self.pose}": self.sigma.tolist(),
            f"verify_noise {self.pose}": np.sqrt(np.diag(self.noise)).tolist(),
            f"verify_distance {self.pose}": [*self.distance, self.allowed],
        }

    def summary(self) -> str:
        f, t = self.wrench[:3], self.wrench[3:]
        return (
            f"verification at {self.pose!r}: compensated |f| {np.linalg.norm(f):.3g} N, "
            f"|tau| {np.linalg.norm(t):.3g} N m; {self.distance[0]:.2f} and "
            f"{self.distance[1]:.2f} sigma (the noise allows {self.allowed:.2f})"
        )


def verify(
    window: Window, predicted: NDArray[np.float64], cov: NDArray[np.float64], alpha: float
) -> Verification:
    """The ``Verification`` of ``window`` against the wrench (6,) a fit ``predicted`` at
    its pose, with the prediction's covariance ``cov`` (6, 6)."""
    residual = window.mean - predicted
    total = window.cov + cov
    distance = tuple(
        math.sqrt(float(residual[k] @ np.linalg.solve(total[k, k], residual[k])))
        for k in (slice(0, 3), slice(3, 6))
    )
    return Verification(
        window.pose,
        residual,
        total,
        window.cov,
        (distance[0], distance[1]),
        math.sqrt(chi2_isf(alpha, 3)),
        window.n,
    )


@dataclass(frozen=True)
class Solution:
    """Outcome of one exploration.

    ``estimate`` is None exactly when ``status`` is ERROR. ``reason`` is one line for
    the user; ``notes`` lists every dropped input.
    """

    status: str
    reason: str
    method: str
    estimate: Estimate | None = None
    consistency: Consistency | None = None
    windows: tuple[Window, ...] = ()
    notes: tuple[str, ...] = ()
    window_samples: Mapping[str, int] = field(default_factory=dict)
    information: str = "wrenches"
    fit: KinematicFit | None = None
    wrenches_sigma_com: NDArray[np.float64] | None = None
    verifications: tuple[Verification | MotionCheck, ...] = ()
    unverified: str = ""
    noise: NoiseModel | None = None
    excitation: str = STATIC
    motion: MotionResult | None = None
    calibrated: InPlaceCalibration | None = None

    @property
    def calibration(self) -> InPlaceCalibration | None:
        """The sensor's calibration in place this exploration of a reference weight
        identified, when it may be kept (status OK); else None."""
        return self.calibrated if self.status == OK else None

    @property
    def usable(self) -> bool:
        """An estimate the estimator stands behind: the fit is consistent with one rigid
        load and holds at every verification pose (status OK, or WARN for dropped input
        only). An inconsistent fit (the object moved in the grasp) or a failed
        verification still carries its numbers, for diagnosis, but is not usable."""
        return (
            self.estimate is not None
            and self.consistency is not None
            and self.consistency.consistent
            and all(v.passed for v in self.verifications)
        )

    def diagnostic_values(self) -> list[tuple[str, str]]:
        """``as_dict`` as diagnostic_msgs/KeyValue pairs (the reason is the status's
        message): vectors per axis (``com_x``), window counts as ``samples <label>``, and
        floats as repr, the shortest text that reads back to the same double."""

        def text(value: object) -> str:
            if isinstance(value, list):
                return ",".join(map(str, value))
            return repr(value) if isinstance(value, float) else str(value)

        out: list[tuple[str, str]] = []
        for key, value in self.as_dict().items():
            if key in ("com", "sigma_com"):
                out += [(f"{key}_{axis}", text(v)) for axis, v in zip("xyz", value, strict=True)]
            elif key == "window_samples":
                out += [(f"{SAMPLES_KEY}{label}", str(n)) for label, n in value.items()]
            elif key not in ("reason", "notes"):
                out.append((key, text(value)))
        return out

    def as_dict(self) -> dict:
        """JSON-ready summary: mass (kg), com (m, sensor frame), their sigmas and
        covariance (``cov``: of (mass, com_x, com_y, com_z), row-major, kg and m), status."""
        out: dict = {
            "status": self.status,
            "usable": self.usable,
            "reason": self.reason,
            "method": self.method,
            "information": self.information,
            "excitation": self.excitation,
            "poses": [w.pose for w in self.windows],
            "notes": list(self.notes),
            "window_samples": dict(self.window_samples),
        }
        if self.estimate is not None:
            e = self.estimate
            out |= {
                "mass": e.mass,
                "com": e.com.tolist(),
                "sigma_mass": e.sigma_mass,
                "sigma_com": e.sigma_com.tolist(),
                "cov": e.cov.ravel().tolist(),
            }
        if self.wrenches_sigma_com is not None:
            out["wrenches_sigma_com"] = self.wrenches_sigma_com.tolist()
        out |= _fit_dict(self.fit) if self.fit is not None else {}
        for v in self.verifications:
            out |= v.as_dict()
        if self.motion is not None:
            out |= self.motion.as_dict()
        if self.unverified:
            out["unverified"] = self.unverified
        if self.calibrated is not None:
            out["calibration"] = self.calibrated.summary()
            out["calibration_left"] = list(self.calibrated.left.values())
        if self.noise is not None:
            out |= _noise_dict(self.noise)
        if self.consistency is not None:
            c = self.consistency
            out |= {
                "chi2": c.chi2,
                "dof": c.dof,
                "p_value": c.p_value,
                "suspect_pose": c.suspect_pose,
            }
        return out


def _tare_spans(
    inbox: Inbox, windows: list[Window], fresh_tares: Mapping[str, Window], until_ns: int | None
) -> list[float] | None:
    """s: per tare-subtracted window, its object window's time less its pose's tare's, the
    span the bias drifts over between them; None when a pose's tare is not this run's (a
    cached one is another session's, on another clock; its drift is the home window's
    check) or there is no window."""
    if not windows or any(w.pose not in fresh_tares for w in windows):
        return None
    stamps = inbox.samples()[0]
    return [
        window_time(inbox, OBJECT_PREFIX + w.pose, stamps, until_ns)
        - window_time(inbox, TARE_PREFIX + w.pose, stamps, until_ns)
        for w in windows
    ]


def solve(inbox: Inbox, setup: FitSetup, until_ns: int | None = None) -> Solution:
    """The solution of the exploration in ``inbox`` up to ``until_ns`` (default: its
    ``done`` label): windows, per-pose tare, estimate by ``setup``'s information,
    consistency test and verifications, with a status (see module)."""
    notes = [f"dropped {n} samples {what}" for what, n in inbox.dropped.items()]
    notes += [f"dropped {n} labels {what}" for what, n in inbox.dropped_labels.items()]
    cut = segments(inbox, until_ns)
    counts = {label: len(samples) for label, samples in cut}
    noise = noise_model(inbox, setup.noise, until_ns, cut)
    if noise is not None and setup.noise is not None and noise is not setup.noise:
        changed = noise.changed_from(setup.noise)
        notes += [changed] if changed else []
    if motion_spans(inbox, until_ns):
        return _solved_in_motion(inbox, setup, until_ns, notes, counts, noise)
    fresh_tares, objects, verifies, refused = reduced_windows(cut, setup.sensor, noise)
    tares = dict(setup.tares) | fresh_tares
    notes += refused
    try:
        if not cut:
            seen = ", ".join(sorted({shorten(lbl) for _, lbl in inbox.labels}))
            raise EstimationError(
                f"no windows: no tare/ or object/ label before the end (labels seen: "
                f"{shorten(seen or 'none', 200)})"
            )
        if not objects:
            seen = ", ".join(sorted({shorten(lbl) for _, lbl in inbox.labels}))
            raise EstimationError(
                f"no object windows (labels seen: {shorten(seen or 'none', 200)})"
            )
        if setup.untared:
            notes.append(
                "no tare: the estimate is of the whole load beyond the sensor (hand + object)"
            )
        information = setup.information_used(notes)
        try:  # the object windows minus the tare of their pose
            windows = objects if setup.untared else subtract_tare(objects, tares.values())
        except MissingTareError:
            if information == WRENCHES:
                raise
            windows = []  # the kinematic fit needs no tare per pose
        if windows and not setup.untared and information == WRENCHES:
            check_load_direction(windows, tares)  # the kinematic fit checks its own
        if setup.reference is not None and information == WRENCHES:
            raise EstimationError(
                "a calibration in place needs the kinematics (information 'kinematics' or "
                "'kinematics+mount', and a robot model)"
            )
        calibrated = None
        if information == WRENCHES:
            fit, wrenches_sigma = None, None
            estimate = setup.wrenches_estimate(
                windows, _tare_spans(inbox, windows, fresh_tares, until_ns)
            )
            tested = setup.calibration.widened(windows) if setup.calibration else windows
            consistency = check_consistency(tested, alpha=setup.alpha, g=setup.g)
            used = windows
        elif setup.reference is not None:
            calibrated, fit, observations = setup.calibrate(
                inbox, objects, fresh_tares, until_ns, notes
            )
            estimate, wrenches_sigma = fit.estimate, None
            used = [o.window for o in observations if o.load]
            consistency = Consistency(calibrated.p_value >= setup.alpha, estimate.chi2,
                                      estimate.dof, calibrated.p_value, setup.alpha)  # fmt: skip
        else:
            fit, observations = setup.kinematic_fit(
                inbox, objects, windows, fresh_tares, information, until_ns, notes
            )
            estimate = fit.estimate
            used = [o.window for o in observations if o.load]
            consistency = setup.kinematic_consistency(fit, observations, information, windows)
            wrenches_sigma = setup.wrenches_sigma(windows)
        verifications, unverified = _verifications(inbox, setup, verifies, fit, until_ns, notes)
    except EstimationError as exc:
        reason = str(exc) + ("; " + "; ".join(notes) if notes else "")
        return Solution(
            ERROR, reason, setup.method, notes=tuple(notes), window_samples=counts, noise=noise
        )
    if calibrated is None:
        status, reason = _status(_summary(estimate), consistency, verifications, notes)
    elif problems := calibrated.problems(setup.alpha):
        status, reason = WARN, "calibration not kept: " + "; ".join(problems)
    else:
        status, reason = _status(calibrated.summary(), consistency, verifications, notes)
    return Solution(
        status,
        reason,
        setup.method,
        estimate,
        consistency,
        tuple(used),
        tuple(notes),
        window_samples=counts,
        information=information,
        fit=fit,
        wrenches_sigma_com=wrenches_sigma,
        verifications=verifications,
        unverified=unverified,
        noise=noise,
        calibrated=calibrated,
    )


def _status(
    summary: str,
    consistency: Consistency,
    verifications: Sequence[Verification | MotionCheck],
    notes: Sequence[str],
    fitted_on: str = "its poses",
) -> tuple[str, str]:
    """(status, reason) of an estimate with its ``summary``: WARN for an inconsistent fit,
    a failed verification (the estimate does not hold beyond what it was ``fitted_on``)
    or dropped input (in that order), else OK."""
    failed = [v.summary() for v in verifications if not v.passed]
    if not consistency.consistent:
        return WARN, consistency.message
    if failed:
        return WARN, "; ".join(failed) + f": the estimate does not hold beyond {fitted_on}"
    if notes:
        return WARN, "; ".join(notes)
    return OK, summary


def _solved_in_motion(
    inbox: Inbox,
    setup: FitSetup,
    until_ns: int | None,
    notes: list[str],
    counts: dict,
    noise: NoiseModel | None,
) -> Solution:
    """The ``Solution`` of an exploration in motion (``motion_solution.solve_motion``,
    with the ``noise`` of its static windows); ``counts`` of their samples gain the
    motions'."""
    stamps = inbox.samples()[0]
    for label, parts in motion_spans(inbox, until_ns).items():
        counts[label] = int(sum(np.count_nonzero((stamps >= a) & (stamps < b)) for a, b in parts))
    try:
        estimate, consistency, result, checks = solve_motion(inbox, setup, noise, until_ns, notes)
    except EstimationError as exc:
        reason = str(exc) + ("; " + "; ".join(notes) if notes else "")
        return Solution(ERROR, reason, setup.method, notes=tuple(notes), window_samples=counts,
                        excitation=MOTION)  # fmt: skip
    status, reason = _status(_motion_summary(estimate, result), consistency, checks, notes,
                             "the motion it was fitted on")  # fmt: skip
    return Solution(status, reason, setup.method, estimate, consistency, (), tuple(notes),
                    window_samples=counts, information=KINEMATICS, verifications=checks,
                    noise=noise, excitation=MOTION, motion=result)  # fmt: skip


def _motion_summary(e: Estimate, result: MotionResult) -> str:
    """Mass and COM, the principal moments (kg cm^2) with their sigmas (or why the inertia
    is not published), and the motion's samples."""
    moments, sigma = result.moments

    def cm2(values) -> str:
        return ", ".join(f"{1e4 * v:.2f}" for v in values)

    found = f"principal moments ({cm2(moments)}) +- ({cm2(sigma)}) kg cm^2"
    if not result.inertia_identified:
        found = (
            f"the inertia not published: {found}, one within {MIN_MOMENT_SIGMAS:g} sigma (a "
            "faster or longer motion, or a calibration in place, would tell it: python -m "
            "com_core.planning.motion_accuracy says which)"
        )
    return f"{_mass_and_com(e)}, {found} from a motion of {result.object.samples} samples"


def _verifications(
    inbox: Inbox,
    setup: FitSetup,
    windows: list[Window],
    fit: KinematicFit | None,
    until_ns: int | None,
    notes: list[str],
) -> tuple[tuple[Verification, ...], str]:
    """The ``Verification`` of every verify window by the kinematic ``fit`` (at the
    window's orientation and time, with what the sensor's hysteresis carries there,
    ``FitSetup.carried``), and why the windows are not checked when they
    cannot be (the wrenches alone: no orientation at a pose no window saw, no bias
    nor hand model); a window without its orientation is noted (a WARN)."""
    if not windows:
        return (), ""
    if fit is None or fit.hand is None:
        return (), (
            "the wrench at a pose no fit used is predicted with information "
            "'kinematics' and the empty hand's windows only"
        )
    robot = setup.robot
    assert robot is not None
    out = []
    stamps, wrenches = inbox.samples()
    for window in windows:
        label = VERIFY_PREFIX + window.pose
        try:
            rotation = window_rotation(inbox, robot, label, until_ns)
        except WindowError as exc:
            notes.append(f"verification left out: {exc}")
            continue
        time = window_time(inbox, label, stamps, until_ns)
        predicted, cov = fit.predict(rotation, time, measured=window.mean)
        observation = Observation(window, rotation, True, 0, time)
        carried = setup.carried(fit, observation, stamps, wrenches)
        if carried is not None:  # the sensor's hysteresis there, as the fit left it
            predicted, cov = predicted + carried[0], cov + carried[1]
        out.append(verify(window, predicted, cov, setup.alpha))
    return tuple(out), ""


def format_solution(solution: Solution) -> str:
    """One line for logs and the command line."""
    name = solution.method
    if solution.information != WRENCHES:
        name += f" ({solution.information})"
    e = solution.estimate
    if e is None or solution.status == OK:
        return f"[{solution.status}] {name}: {solution.reason}"
    summary = _summary(e) if solution.motion is None else _motion_summary(e, solution.motion)
    return f"[{solution.status}] {name}: {solution.reason} | {summary}"


def vector_value(values: Mapping[str, str], key: str, scale: float = 1.0) -> list[float] | None:
    """A vector of ``Solution.diagnostic_values`` read back (its values comma-joined),
    times ``scale``; None when ``values`` has no ``key``."""
    text = values.get(key)
    return [float(v) * scale for v in text.split(",")] if text else None


def inertia_value(values: Mapping[str, str]) -> tuple[list[float] | None, bool]:
    """(the object's inertia elements about the COM, kg m^2, ``INERTIA_ELEMENTS``, and
    whether they were published) of ``Solution.diagnostic_values`` read back: ``inertia``
    when the motion told it, else the fit kept as ``inertia_fit``
    (``MotionResult.as_dict``); (None, False) without either (a static run)."""
    if "inertia" in values:
        return vector_value(values, "inertia"), True
    return vector_value(values, "inertia_fit"), False


def verification_lines(values: Mapping[str, str]) -> list[str]:
    """One line per verification pose of ``Solution.diagnostic_values`` read back: the
    mean compensated force (N) and torque (mN m) with their sigmas, and their distances
    from zero against what the noise allows."""
    lines = []
    for key in values:
        if key.startswith("verify_ratio "):
            lines.append(_motion_check_line(values, key.split(" ", 1)[1]))
        if not key.startswith("verify_wrench "):
            continue
        pose = key.split(" ", 1)[1]
        w = vector_value(values, key) or []
        s = vector_value(values, f"verify_sigma {pose}") or []
        d = vector_value(values, f"verify_distance {pose}") or [math.nan] * 3
        if len(w) != 6 or len(s) != 6 or len(d) != 3:
            continue

        def vec(v: Sequence[float], scale: float = 1.0, digits: int = 3) -> str:
            return "(" + ", ".join(f"{x * scale:.{digits}f}" for x in v) + ")"

        lines.append(
            f"verification {pose!r}: f {vec(w[:3])} +- {vec(s[:3])} N, tau "
            f"{vec(w[3:], 1e3, 2)} +- {vec(s[3:], 1e3, 2)} mN m; {d[0]:.2f} and {d[1]:.2f} "
            f"sigma ({d[2]:.2f} allowed)"
        )
    return lines


def _motion_check_line(values: Mapping[str, str], pose: str) -> str:
    """The check along motion ``pose`` (``MotionCheck``) read back: the compensated
    wrench's rms per axis against its prediction, and their ratio against the allowed."""
    rms = vector_value(values, f"verify_rms {pose}") or [math.nan] * 6
    predicted = vector_value(values, f"verify_rms_predicted {pose}") or [math.nan] * 6
    ratio = vector_value(values, f"verify_ratio {pose}") or [math.nan] * 4

    def vec(v: Sequence[float], scale: float = 1.0) -> str:
        return "(" + ", ".join(f"{x * scale:.3f}" for x in v) + ")"

    return (
        f"verification along {pose!r}: compensated rms f {vec(rms[:3])} N, tau "
        f"{vec(rms[3:], 1e3)} mN m, predicted {vec(predicted[:3])} N, "
        f"{vec(predicted[3:], 1e3)} mN m; {ratio[0]:.2f} and {ratio[1]:.2f} of it "
        f"({ratio[2]:.2f} and {ratio[3]:.2f} allowed)"
    )


SAMPLES_KEY = "samples "
"""A status value's key prefix: ``samples <label>`` holds a window's sample count."""


def window_counts(values: Mapping[str, str]) -> dict[str, int]:
    """The samples (wrenches) of each window a status's ``values`` name, by label."""
    out = {}
    for key, text in values.items():
        if key.startswith(SAMPLES_KEY):
            try:
                out[key.removeprefix(SAMPLES_KEY)] = int(text)
            except ValueError:
                continue
    return out


def missing_samples(used: Mapping[str, int], held: Mapping[str, int]) -> list[str]:
    """One line per window whose bag ``held`` fewer samples than the estimator ``used``
    (both by label): the bag lost them, and a replay of it cannot give the node's
    numbers. [] when the bag holds every sample used."""
    return [
        f"the bag holds {held.get(label, 0)} of the {n} samples the estimator used in {label}"
        for label, n in used.items()
        if held.get(label, 0) < n
    ]


def noise_line(values: Mapping[str, str]) -> str | None:
    """The sensor's noise learnt by a solution, from ``Solution.diagnostic_values`` read
    back: sigma per sample and correlation time, forces and torques (the largest axis),
    and what it was learnt from; None when it has none."""
    sigma = vector_value(values, "noise_sigma")
    time = vector_value(values, "noise_correlation_time", 1e3)
    if not sigma or not time or len(sigma) != 6 or len(time) != 6:
        return None
    order = max(vector_value(values, "noise_ar_order") or [0])
    return (
        f"sensor noise {max(sigma[:3]):.3f} N, {max(sigma[3:]) * 1e3:.2f} mN m per sample, "
        f"correlation time {max(time[:3]):.1f} ms (forces), {max(time[3:]):.1f} ms (torques), "
        f"AR order {order:.0f}, learnt from {values.get('noise_samples', '?')} samples"
    )


def _fit_dict(fit: KinematicFit) -> dict:
    """The kinematic fit's own unknowns for ``Solution.as_dict``: the sensor's bias in
    this run (N, N m), its drift since a cached tare, the hand's mass (kg) and COM (m,
    sensor frame), the mounting (roll, pitch, yaw, rad) and the base tilt (rad)."""
    out: dict = {}
    if len(fit.bias):
        out["bias"] = fit.bias[0].tolist()
        out["sigma_bias"] = np.sqrt(np.diag(fit.bias_cov)[:6]).tolist()
    if len(fit.bias) > 1:
        drift, cov = fit.drift()
        out["bias_drift"] = drift.tolist()
        out["bias_rate"] = fit.bias_rate[0].tolist()
        out["sigma_bias_drift"] = np.sqrt(np.diag(cov)).tolist()
    if fit.hand is not None:
        out["hand_mass"], out["hand_com"] = fit.hand.mass, fit.hand.com.tolist()
    if fit.mount is not None and fit.mount_cov is not None:
        out["mount_rpy"] = mount_rpy(fit.mount).tolist()
        out["sigma_mount"] = np.sqrt(np.diag(fit.mount_cov)).tolist()
    if fit.base_tilt is not None and fit.base_tilt_cov is not None:
        out["base_tilt"] = fit.base_tilt.tolist()
        out["sigma_base_tilt"] = np.sqrt(np.diag(fit.base_tilt_cov)).tolist()
    return out


def _noise_dict(noise: NoiseModel) -> dict:
    """The learnt noise for ``Solution.as_dict``: sigma per sample (N, N m), the
    integrated correlation time (s) and the AR order per axis, the samples learnt from."""
    return {
        "noise_sigma": np.sqrt(noise.variance).tolist(),
        "noise_correlation_time": noise.correlation_time.tolist(),
        "noise_ar_order": list(noise.orders),
        "noise_samples": noise.samples,
    }


def _summary(e: Estimate) -> str:
    return f"{_mass_and_com(e)} from {len(e.poses)} poses"


def _mass_and_com(e: Estimate) -> str:
    c, s = e.com * 1e3, e.sigma_com * 1e3
    return (
        f"mass {e.mass * 1e3:.2f} +- {e.sigma_mass * 1e3:.2f} g, COM ({c[0]:.2f}, "
        f"{c[1]:.2f}, {c[2]:.2f}) +- ({s[0]:.2f}, {s[1]:.2f}, {s[2]:.2f}) mm"
    )
