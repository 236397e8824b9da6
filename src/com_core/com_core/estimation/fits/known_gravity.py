"""Mass and COM when each window's orientation is known from the robot's kinematics (the
``kinematics`` and ``kinematics+mount`` information models), with the hand and the
sensor's bias as a model (the ft_calib model).

Each window i has R_i = R_base_sensor from forward kinematics (``com_core.robot.model``)
and so gravity in the sensor frame g_i = R_i^T g_base (m/s^2). A static rigid load of
mass m and COM p (sensor frame) has the wrench A(g_i) theta with theta = (m, c), c = m p
(kg m):

    f_i   = m g_i
    tau_i = p x (m g_i) = c x g_i = -[g_i]_x c.

The sensor reads the wrench of everything beyond it plus a bias b (6,): its zero, which
drifts. Window i is an ``Observation``: the empty hand (``load`` False) or the hand
holding the object (``load`` True), read with the bias of its ``epoch`` (0: this run's;
1: the bias at an earlier tare pass, a cached one):

    w_i = b_epoch(i) + A(g_i) (theta_hand + load_i theta_object).

The hand is the paper's W_HAND (eq. 2) as a model: known at any orientation once fitted,
not only at the poses a tare pass visited. The bias of each epoch is fitted with the
hand and the object, so a drift since the tare is absorbed and reported
(``KinematicFit.drift``). Within an epoch the bias may drift too: with
``drift_rate_sigma`` (N/s, N m/s) each epoch's bias is b + r (t_i - t_epoch), t_i the
window's time (s) and t_epoch the mean of its epoch's, and the rate r has a zero-mean
Gaussian prior of that sigma per axis (a sensor's drift specification). The prior enters
as 6 pseudo-observations per epoch, so the fit stays linear and its covariance is the
(Bayesian) bound; without it the bias is constant within an epoch.

The unknowns are linear: the maximum-likelihood fit under Gaussian window noise
(covariance S_i of each window mean, N and N m) is weighted least squares, and its
covariance, the inverse Fisher information, is exactly the Cramer-Rao
bound for this information. (m, p = c / m) and their covariance follow to first order.

``fit_mount`` adds the ``kinematics+mount`` unknowns: the sensor's mounting rotation
R_m relative to its URDF frame and the base's tilt R_t (2 angles about the axes across
gravity), constants the windows see as g_i = R_m^T R_i^T R_t g_base; Gauss-Newton from
the fit without them. Without empty-hand windows (no tare: the load beyond the sensor,
or windows that are already tare-subtracted) there is no bias nor hand to fit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.errors import NonPositiveMassError, TooFewPosesError
from com_core.estimation.fits.estimators import Estimate
from com_core.estimation.fits.stats import chi2_sf
from com_core.estimation.fits.windows import Window
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.calibration import Calibration
from com_core.sensing.wrench_model import rotation_about, skew

__all__ = [
    "BIAS_DRIFT_RATE",
    "KinematicFit",
    "Observation",
    "Reference",
    "gravity_designs",
    "kinematic_ml",
    "locate_move",
    "mount_rpy",
]

METHOD = "ml"  # the maximum-likelihood fit of the kinematics information
BIAS_DRIFT_RATE = (0.05 / 60, 0.0025 / 60)
"""N/s, N m/s: the default 1-sigma prior of the bias's drift rate within an epoch, per
axis: 0.05 N/min, and in torque as much relative to a 0.1 N / 0.005 N m sensor's noise."""
_MAX_CONDITION = 1e10
"""The scaled Fisher information (``_condition``) of a fit that resolves its unknowns
is better conditioned."""


@dataclass(frozen=True)
class Observation:
    """A static window and what it saw: ``rotation`` R_base_sensor (3, 3) of the URDF's
    sensor frame over it, whether it holds the object (``load``; else the empty hand),
    and the ``epoch`` of the sensor bias it was read with (0: this run; 1: an earlier
    tare pass), its ``time`` (s, the middle of the window; any origin within an epoch),
    and for a load window its ``group``: windows of another group see the object
    elsewhere in the hand (``locate_move``'s alternatives; the estimate is group 0's).
    ``design`` (6, 4), when given, is the window's mean wrench per unit of theta = (m, c)
    in place of the static ``A(g_i)``: a window taken in motion, whose wrench also holds
    the load's inertial forces (m and c's columns of ``robot.dynamics``' regressor,
    averaged over the window); not with ``fit_mount``. ``nuisance`` (6, k), when given,
    is the window's mean wrench per unit of k unknowns every window shares and no fit
    solves for (the load's inertia: ``robot.dynamics``' last six columns), of prior
    covariance ``kinematic_ml``'s ``nuisance_cov``: they are weighed as a common error of
    the windows, correlated across them (marginalised). ``travel`` (6,; N, N m), when
    known, is the load's total variation on the way from the window before it in its
    epoch (``sensing.hysteresis.travel``; what the sensor's hysteresis moves with), and
    ``reach`` (2, 6; N, N m) the lowest and highest load on that way (``hysteresis.reach``:
    a press or an overshoot beyond what the windows read). ``beyond`` (6,; N, N m), when
    known, is what the hysteresis state moved beyond its first order since its epoch's
    first window, or the first after a contact (``Hysteresis.beyond_first_order``): the
    fits take it off the window's mean (``mean``)."""

    window: Window
    rotation: NDArray[np.float64]
    load: bool = True
    epoch: int = 0
    time: float = 0.0
    group: int = 0
    design: NDArray[np.float64] | None = None
    nuisance: NDArray[np.float64] | None = None
    travel: NDArray[np.float64] | None = None
    reach: NDArray[np.float64] | None = None
    beyond: NDArray[np.float64] | None = None

    @property
    def mean(self) -> NDArray[np.float64]:
        """(6,; N, N m): the window's mean less ``beyond``, what the fits take."""
        return self.window.mean if self.beyond is None else self.window.mean - self.beyond


@dataclass(frozen=True)
class Reference:
    """What is known of the object beforehand (a reference weight: a calibration in
    place, ``estimation.fits.in_place``): its ``mass`` (kg) within ``mass_sigma`` (kg,
    1 sigma) and, when known, its ``com`` (m, sensor frame) within ``com_sigma`` (m, per
    axis). It enters the fit as a Gaussian prior on theta = (m, c = m p): pseudo-
    observations, as the drift rate's prior does (c's sigma m com_sigma, first order)."""

    mass: float
    mass_sigma: float
    com: tuple[float, float, float] | None = None
    com_sigma: float = 0.0

    def prior_rows(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(the prior's mean of theta (4,), its whitening rows (k, 4))."""
        mean = np.zeros(4)
        mean[0] = self.mass
        rows = [np.eye(4)[0] / self.mass_sigma]
        if self.com is not None:
            mean[1:] = self.mass * np.asarray(self.com, dtype=np.float64)
            rows += list(np.eye(4)[1:] / (self.mass * self.com_sigma))
        return mean, np.array(rows)


@dataclass(frozen=True)
class KinematicFit:
    """The fit of ``kinematic_ml``.

    Attributes
    ----------
    estimate : the object's mass (kg) and COM (m, sensor frame), covariance the CRLB; its
        chi2 and dof are the whole fit's. With no load window: the hand's.
    hand : the hand's mass and COM (sensor frame); None without empty-hand windows.
    bias : (epochs, 6) the sensor's bias per epoch (N, N m) at the mean time of the
        epoch's windows; empty without empty-hand windows. bias_cov : (6 epochs, 6
        epochs), the covariance of all epochs' biases together.
    bias_rate : (epochs, 6) its drift rate within each epoch (N/s, N m/s); zeros unless
        ``drift_rate_sigma`` was given.
    mount : the mounting rotation vector (3,), rad (the sensor's axes in the URDF frame
        are R(mount)), and its covariance ``mount_cov`` (3, 3); None unless fitted.
    base_tilt : the base's tilt, a rotation vector (3,), rad, in the base frame (across
        gravity: the base's gravity is R(base_tilt) g), with ``base_tilt_cov`` (3, 3);
        None unless fitted.
    cov : covariance of every unknown, in the order: per epoch its bias (and with a rate
        prior its rate), the hand, the object (and its other places, ``group``), the
        mounting, the tilt.
    """

    estimate: Estimate
    hand: Estimate | None
    bias: NDArray[np.float64]
    bias_cov: NDArray[np.float64]
    bias_rate: NDArray[np.float64]
    mount: NDArray[np.float64] | None
    mount_cov: NDArray[np.float64] | None
    base_tilt: NDArray[np.float64] | None
    base_tilt_cov: NDArray[np.float64] | None
    cov: NDArray[np.float64]
    _model: _Model = field(repr=False, compare=False)
    _x: NDArray[np.float64] = field(repr=False, compare=False)

    def predict(
        self,
        rotation: ArrayLike,
        time: float,
        load: bool = True,
        measured: ArrayLike | None = None,
        design: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The wrench (6,; N, N m) the sensor reads in this run (bias epoch 0) at
        R_base_sensor ``rotation`` (3, 3) of its URDF frame and ``time`` (s, the windows'
        clock): the bias then, the hand's gravity wrench and, with ``load``, the
        object's; with its covariance (6, 6) from the fit's (mounting and tilt
        included). The wrench at a pose no window saw: a verification's prediction.
        With the wrench ``measured`` there (6,) and a calibration, the covariance also
        holds what the calibration's common error adds to measured less predicted
        (``_Model.calibration_term``). ``design`` (6, 4): the wrench per unit of (m, c)
        there in place of the static one (``Observation.design``)."""
        rotation = np.asarray(rotation, dtype=np.float64)
        a = None if design is None else np.asarray(design, dtype=np.float64)
        return self._model.predict(self._x, self.cov, rotation, time, load, measured, a)

    def wrenches(
        self, designs: ArrayLike, times: ArrayLike, load: bool = True
    ) -> NDArray[np.float64]:
        """(n, 6): the wrenches (N, N m) the fit gives in this run (bias epoch 0) at the
        designs (n, 6, 4; ``Observation.design``) and ``times`` (n,; s): the bias then, the
        hand's wrench and, with ``load``, the object's (no mounting: the designs are
        given). For many samples at once (a recording's residual)."""
        model, x = self._model, self._x
        theta = x[model.hand] if model.has_hand else np.zeros(4)
        if load and model.has_object:
            theta = theta + x[model.object]
        out = np.einsum("kij,j->ki", np.asarray(designs, dtype=np.float64), theta)
        if model.epochs:
            elapsed = np.asarray(times, dtype=np.float64) - model.epoch_time[0]
            out += self.bias[0] + np.outer(elapsed, self.bias_rate[0])
        return out

    @property
    def whitening(self) -> NDArray[np.float64]:
        """(6n, 6n) the windows' whitening (``_Model._whitening``): for a fit of the same
        windows with other unknowns (``kinematic_ml``'s ``whitening``)."""
        return self._model.whiten

    @property
    def observations(self) -> tuple[Observation, ...]:
        """The windows fitted, in the order given."""
        return tuple(self._model.obs)

    def nuisance_posterior(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """The windows' shared nuisance (``Observation.nuisance``) given their wrenches:
        its mean (k,) and covariance (k, k), the prior ``nuisance_cov`` conditioned on the
        windows' residuals at the estimate (Sigma N^T C^-1 r and Sigma - Sigma N^T C^-1 N
        Sigma, C the windows' whole covariance; the estimate taken as known); None
        without one."""
        model = self._model
        nuisance = model._nuisance()
        if nuisance is None:
            return None
        rows = 6 * len(model.obs)
        gain = model.nuisance_cov @ nuisance.T @ model.whiten.T  # Sigma N^T W^T
        return gain @ model.residuals(self._x)[:rows], model.nuisance_cov - gain @ gain.T

    def latest_bias(self) -> NDArray[np.float64]:
        """This run's bias (6,; N, N m) at its latest window (``bias_at``: what a
        compensation that goes on after the run starts from)."""
        return self.bias_at(max(o.time for o in self._model.obs if o.epoch == 0))[0]

    def bias_at(self, time: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """This run's bias (6,; N, N m) at ``time`` (s, the windows' clock): the bias of
        epoch 0 carried along its fitted rate from the epoch's mean time, with its
        covariance (6, 6)."""
        model = self._model
        elapsed = time - model.epoch_time[0]
        bias = model.bias[0]
        if not model.rate:
            return self.bias[0].copy(), self.cov[bias, bias].copy()
        rate = model.rate[0]
        index = np.r_[bias.start : bias.stop, rate.start : rate.stop]
        jac = np.hstack([np.eye(6), elapsed * np.eye(6)])
        cov = jac @ self.cov[np.ix_(index, index)] @ jac.T
        return self.bias[0] + self.bias_rate[0] * elapsed, cov

    def drift(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(bias of this run minus that of the tare pass (6,), its covariance (6, 6)): the
        drift since the tare; zeros when the run has one epoch."""
        if len(self.bias) < 2:
            return np.zeros(6), np.zeros((6, 6))
        c = self.bias_cov
        cov = c[:6, :6] + c[6:12, 6:12] - c[:6, 6:12] - c[6:12, :6]
        return self.bias[0] - self.bias[1], cov

    def calibration_error(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(E^ (6, 6), the covariance of vec(E) - vec(E^) (36, 36)): what the windows'
        misfit says of the calibration's error E (``com_core.sensing.calibration``; the
        fit's ``calibration`` its prior): its best linear unbiased prediction
        P J^T Sigma^-1 (y - X x^), and the covariance of its error
        P - P J^T Sigma^-1 J P + P J^T Sigma^-1 X cov(x^) X^T Sigma^-1 J P (Henderson's
        mixed model: P the prior's covariance, J the windows' ``stacked_jacobian``, Sigma
        their joint covariance, X the design of the fit's unknowns). Where the windows
        say nothing of a part of E, the prior is left. ValueError without a calibration."""
        model = self._model
        if model.calibration is None:
            raise ValueError("a fit without a calibration says nothing of its error")
        n = 6 * len(model.obs)
        reading = model.means.reshape(-1, 6) - model.uncalibrated
        error_cov = model.calibration.error_cov
        gain = error_cov @ (model.whiten @ model.calibration.stacked_jacobian(reading)).T
        estimate = gain @ model.residuals(self._x)[:n]
        through = gain @ model.jacobian(self._x)[:n]
        cov = error_cov - gain @ gain.T + through @ self.cov @ through.T
        return estimate.reshape(6, 6), (cov + cov.T) / 2


def _design(gravity: NDArray[np.float64]) -> NDArray[np.float64]:
    """A (6, 4): the wrench of theta = (m, c) at gravity g (m/s^2, sensor frame)."""
    a = np.zeros((6, 4))
    a[:3, 0] = gravity
    a[3:, 1:] = -skew(gravity)
    return a


def gravity_designs(gravity: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 6, 4): the static wrench per unit of theta = (m, c) at each of n gravities
    (n, 3; m/s^2, sensor frame), ``_design`` of each, built for all at once."""
    x, y, z = gravity.T
    cross = np.zeros((len(gravity), 3, 3))  # skew(g) of each
    cross[:, 0, 1], cross[:, 0, 2] = -z, y
    cross[:, 1, 0], cross[:, 1, 2] = z, -x
    cross[:, 2, 0], cross[:, 2, 1] = -y, x
    a = np.zeros((len(gravity), 6, 4))
    a[:, :3, 0] = gravity
    a[:, 3:, 1:] = -cross
    return a


def _mass_com(
    theta: NDArray[np.float64], cov_theta: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """(m, p = c / m, covariance (4, 4) of (m, p)) from theta = (m, c), first order."""
    m, c = theta[0], theta[1:]
    jac = np.zeros((4, 4))
    jac[0, 0] = 1.0
    jac[1:, 0] = -c / m**2
    jac[1:, 1:] = np.eye(3) / m
    return float(m), c / m, jac @ cov_theta @ jac.T


def _rotation(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix (3, 3) of a rotation vector (axis x angle, rad)."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.eye(3) + skew(rotvec)
    return rotation_about(rotvec / angle, angle)


def _across(gravity: NDArray[np.float64]) -> NDArray[np.float64]:
    """(2, 3): two unit axes across ``gravity``, about which a base tilts."""
    u = gravity / np.linalg.norm(gravity)
    first = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
    first /= np.linalg.norm(first)
    return np.stack([first, np.cross(u, first)])


class _Model:
    """The unknowns' layout (per epoch its bias and, with a rate prior, its rate; the
    hand; the object; the mounting and the tilt) and the whitened residuals."""

    def __init__(
        self,
        observations: Sequence[Observation],
        gravity: NDArray[np.float64],
        fit_mount: bool,
        drift_rate_sigma: tuple[float, float] | None,
        calibration: Calibration | None = None,
        uncalibrated: NDArray[np.float64] | None = None,
        whitening: NDArray[np.float64] | None = None,
        nuisance_cov: NDArray[np.float64] | None = None,
        reference: Reference | None = None,
    ) -> None:
        self.obs = list(observations)
        self.calibration = calibration
        self.nuisance_cov = nuisance_cov
        self.uncalibrated = np.zeros(6) if uncalibrated is None else uncalibrated
        self.gravity = gravity
        empty = [o for o in self.obs if not o.load]
        self.epochs = 1 + max((o.epoch for o in self.obs), default=0) if empty else 0
        rates = drift_rate_sigma is not None and max(drift_rate_sigma) > 0
        self.rate_sigma = (
            np.repeat(np.asarray(drift_rate_sigma, dtype=float), 3) if rates else None
        )
        stride = 12 if rates else 6
        self.bias = [slice(stride * e, stride * e + 6) for e in range(self.epochs)]
        self.rate = (
            [slice(stride * e + 6, stride * e + 12) for e in range(self.epochs)] if rates else []
        )
        self.has_hand = bool(empty)
        self.has_object = any(o.load for o in self.obs)
        self.prior = reference.prior_rows() if reference and self.has_object else None
        groups = 1 + max((o.group for o in self.obs if o.load), default=0)
        start = stride * self.epochs
        self.hand = slice(start, start + 4) if self.has_hand else slice(start, start)
        start = self.hand.stop
        self.object = slice(start, start + 4) if self.has_object else slice(start, start)
        self.moved = [slice(start + 4 * k, start + 4 * k + 4) for k in range(groups)]
        start = self.moved[-1].stop if self.has_object else start
        self.mount = slice(start, start + 5) if fit_mount else slice(start, start)
        self.size = self.mount.stop
        self.tilt_axes = _across(gravity)
        self.means = np.concatenate([o.mean for o in self.obs]) if self.obs else None
        self.whiten = self._whitening() if whitening is None else whitening
        self.epoch_time = [
            float(np.mean([o.time for o in self.obs if o.epoch == e] or [0.0]))
            for e in range(self.epochs)
        ]
        # ``linear_design``'s and ``gravities``' parts that the unknowns do not change
        self._fixed_rows: NDArray[np.float64] | None = None
        self._load_groups: list[tuple[slice, NDArray[np.intp]]] = []
        self._rotations_t: NDArray[np.float64] | None = None

    def _whitening(self) -> NDArray[np.float64]:
        """(6n, 6n) W with W^T W the inverse of the windows' joint covariance: each
        window's noise, plus the calibration's common error (``com_core.sensing.calibration``)
        and the nuisance unknowns' (``Observation.nuisance``)."""
        n = len(self.obs)
        nuisance = self._nuisance()
        if self.calibration is None and nuisance is None:  # block diagonal: each its own
            whiten = np.zeros((6 * n, 6 * n))
            if n:
                covs = np.array([o.window.cov for o in self.obs])
                blocks = np.linalg.inv(np.linalg.cholesky(covs))  # all at once
                for i in range(n):
                    whiten[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = blocks[i]
            return whiten
        cov = np.zeros((6 * n, 6 * n))
        for i, o in enumerate(self.obs):
            cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = o.window.cov
        if n and self.calibration is not None:
            cov += self.calibration.cov(self.means.reshape(n, 6) - self.uncalibrated)
        if nuisance is not None:
            cov += nuisance @ self.nuisance_cov @ nuisance.T
        return np.linalg.inv(np.linalg.cholesky(cov)) if n else np.zeros((0, 0))

    def _nuisance(self) -> NDArray[np.float64] | None:
        """(6n, k): the windows' ``nuisance`` designs stacked (zeros where a window has
        none); None without a ``nuisance_cov`` or any window with one."""
        k = None if self.nuisance_cov is None else len(self.nuisance_cov)
        if k is None or all(o.nuisance is None for o in self.obs):
            return None
        zeros = np.zeros((6, k))
        return np.concatenate([zeros if o.nuisance is None else o.nuisance for o in self.obs])

    def gravities(
        self, x: NDArray[np.float64], rotations: Sequence[NDArray[np.float64]] | None = None
    ) -> list[NDArray[np.float64]]:
        """g_i (m/s^2, sensor frame) at the unknowns ``x`` for each R_base_sensor of
        ``rotations`` (default: the observations')."""
        if rotations is None:
            if self._rotations_t is None:  # the observations' R^T, stacked once
                stack = [o.rotation for o in self.obs]
                self._rotations_t = np.array(stack, dtype=np.float64).reshape(-1, 3, 3)
                self._rotations_t = self._rotations_t.transpose(0, 2, 1)
            rotations_t = self._rotations_t
        else:
            rotations_t = np.array(rotations, dtype=np.float64).reshape(-1, 3, 3)
            rotations_t = rotations_t.transpose(0, 2, 1)
        if self.mount.stop == self.mount.start:
            return list(rotations_t @ self.gravity)
        mount_t = _rotation(x[self.mount][:3]).T
        base = _rotation(x[self.mount][3:] @ self.tilt_axes) @ self.gravity
        return list((mount_t @ rotations_t) @ base)

    def design_rows(
        self,
        g: NDArray[np.float64],
        epoch: int,
        time: float,
        load: bool,
        group: int = 0,
        design: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """(6, size): the derivative of the wrench at gravity ``g`` (or of ``design``,
        ``Observation.design``) read with the bias of ``epoch`` at ``time`` (s), with the
        object at its place ``group`` if ``load``, by bias, rate, hand and object (mount
        columns 0)."""
        rows = np.zeros((6, self.size))
        a = _design(g) if design is None else design
        if self.epochs:
            rows[:, self.bias[epoch]] = np.eye(6)
        if self.rate:
            rows[:, self.rate[epoch]] = (time - self.epoch_time[epoch]) * np.eye(6)
        if self.has_hand:
            rows[:, self.hand] = a
        if load:
            rows[:, self.moved[group]] = a
        return rows

    def linear_design(self, gravities: list[NDArray[np.float64]]) -> NDArray[np.float64]:
        """(6n, size): ``design_rows`` of every observation, built for all at once (the
        bias and rate columns, which gravity does not enter, once per model)."""
        n = len(self.obs)
        if not n:
            return np.zeros((0, self.size))
        if len(gravities) != n:
            raise ValueError(f"{len(gravities)} gravities for {n} observations")
        if self._fixed_rows is None:
            fixed = np.zeros((n, 6, self.size))
            for i, o in enumerate(self.obs):
                fixed[i] = self.design_rows(np.zeros(3), o.epoch, o.time, False)
            self._fixed_rows = fixed
            loads = [i for i, o in enumerate(self.obs) if o.load]
            groups = sorted({self.obs[i].group for i in loads})
            self._load_groups = [
                (self.moved[k], np.array([i for i in loads if self.obs[i].group == k]))
                for k in groups
            ]
        a = gravity_designs(np.asarray(gravities, dtype=np.float64).reshape(n, 3))
        for i, o in enumerate(self.obs):
            if o.design is not None:
                a[i] = o.design
        rows = self._fixed_rows.copy()
        if self.has_hand:
            rows[:, :, self.hand] = a
        for columns, index in self._load_groups:
            rows[index, :, columns] = a[index]
        return rows.reshape(6 * n, self.size)

    def predict(
        self,
        x: NDArray[np.float64],
        cov: NDArray[np.float64],
        rotation: NDArray[np.float64],
        time: float,
        load: bool,
        measured: ArrayLike | None = None,
        design: NDArray[np.float64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The wrench (6,) the unknowns ``x`` give at R_base_sensor ``rotation`` (or with
        ``design``) and ``time`` in epoch 0 (with the object if ``load``), and its
        covariance (6, 6) from ``cov`` (and the calibration's, ``calibration_term``, for a
        ``measured`` wrench); the mounting and the tilt enter by central differences."""

        def rows(at: NDArray[np.float64]) -> NDArray[np.float64]:
            g = self.gravities(at, [rotation])[0]
            return self.design_rows(g, 0, time, load, design=design)

        def wrench(at: NDArray[np.float64]) -> NDArray[np.float64]:
            return rows(at) @ at

        jac = rows(x)
        for k in range(self.mount.start, self.mount.stop):
            step = np.zeros(self.size)
            step[k] = 1e-6
            jac[:, k] = (wrench(x + step) - wrench(x - step)) / 2e-6
        out = jac @ cov @ jac.T
        if measured is not None:
            out = out + self.calibration_term(x, cov, jac, np.asarray(measured, dtype=float))
        return wrench(x), out

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Whitened residuals at the unknowns ``x``: 6 per window, then 6 per epoch for
        the rate prior."""
        predicted = self.linear_design(self.gravities(x)) @ x
        prior = [-x[r] / self.rate_sigma for r in self.rate]
        if self.prior is not None:
            mean, rows = self.prior
            prior.append(rows @ (mean - x[self.object]))
        return np.concatenate([self.whiten @ (self.means - predicted), *prior])

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """d residuals / d x: exact for the linear unknowns, central differences for the
        mounting and the tilt."""
        n = 6 * len(self.obs)
        rows = 0 if self.prior is None else len(self.prior[1])
        whitened = np.zeros((n + 6 * len(self.rate) + rows, self.size))
        whitened[:n] = -self.whiten @ self.linear_design(self.gravities(x))
        for e, r in enumerate(self.rate):
            whitened[n + 6 * e : n + 6 * e + 6, r] = -np.diag(1.0 / self.rate_sigma)
        if rows:
            whitened[len(whitened) - rows :, self.object] = -self.prior[1]
        for k in range(self.mount.start, self.mount.stop):
            step = np.zeros(self.size)
            step[k] = 1e-6
            whitened[:, k] = (self.residuals(x + step) - self.residuals(x - step)) / 2e-6
        return whitened

    def calibration_term(
        self,
        x: NDArray[np.float64],
        cov: NDArray[np.float64],
        predicted_jacobian: NDArray[np.float64],
        measured: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """(6, 6): what the calibration's common error adds to the covariance of a window
        ``measured`` (6,) that no fit used less the prediction there (whose derivative by
        the unknowns is ``predicted_jacobian``, (6, size)): its own share, less its
        correlation with the fit's windows through the unknowns (``com_core.sensing.calibration``).
        Zero without a calibration."""
        if self.calibration is None:
            return np.zeros((6, 6))
        n = 6 * len(self.obs)
        jac = self.jacobian(x)[:n]
        gain = -cov @ jac.T @ self.whiten  # d x / d (window means)
        own = self.calibration.jacobian(measured - self.uncalibrated)
        through = (
            predicted_jacobian
            @ gain
            @ self.calibration.stacked_jacobian(self.means.reshape(-1, 6) - self.uncalibrated)
        )
        diff = own - through
        return self.calibration.spread(diff) - self.calibration.spread(through)


def _estimate(
    x: NDArray[np.float64], cov: NDArray[np.float64], part: slice, chi2: float, dof: int, poses
) -> Estimate:
    mass, com, cov_mp = _mass_com(x[part], cov[part, part])
    return Estimate(
        method=METHOD,
        mass=mass,
        com=com,
        cov=cov_mp,
        chi2=chi2,
        dof=dof,
        p_value=chi2_sf(chi2, dof) if dof > 0 else 1.0,
        poses=poses,
    )


def _condition(jac: NDArray[np.float64]) -> float:
    """Condition number of the Fisher information J^T J with its unknowns scaled to unit
    information (their units, and how precise each window is, do not enter)."""
    info = jac.T @ jac
    scale = 1.0 / np.sqrt(np.maximum(np.diag(info), np.finfo(float).tiny))
    return float(np.linalg.cond(info * np.outer(scale, scale)))


def kinematic_ml(
    observations: Sequence[Observation],
    gravity: ArrayLike = DEFAULT_GRAVITY,
    fit_mount: bool = False,
    drift_rate_sigma: tuple[float, float] | None = None,
    iterations: int = 30,
    calibration: Calibration | None = None,
    uncalibrated: ArrayLike | None = None,
    positive_object: bool = True,
    whitening: NDArray[np.float64] | None = None,
    nuisance_cov: NDArray[np.float64] | None = None,
    reference: Reference | None = None,
) -> KinematicFit:
    """The ML fit of bias, hand and object to ``observations`` (see module), with
    ``gravity`` (m/s^2) in the base frame; ``fit_mount`` also fits the sensor's mounting
    and the base's tilt; ``drift_rate_sigma`` (N/s, N m/s) lets each epoch's bias drift
    (see module); ``calibration`` weighs the windows with the calibration's common error
    too (``com_core.sensing.calibration``), on the windows' means less ``uncalibrated``
    (6,; N, N m: the sensor's bias, which its calibration does not scale, when known). The
    covariance is the CRLB; chi2 has 6n (+ 6 per epoch with a rate prior) - (unknowns)
    dof. ``positive_object`` False lets the object's mass be any sign: the object is then a
    change of load between windows (``estimation.recordings.recording_fit``).
    ``whitening``: that of a fit of the same windows in the same order with the same
    calibration (``KinematicFit.whitening``), not computed again. ``nuisance_cov`` (k, k):
    the prior covariance of the unknowns the windows' ``nuisance`` designs multiply.
    ``reference``: what is known of the object beforehand, a prior (``Reference``; its
    pseudo-observations count in chi2's dof).

    Raises TooFewPosesError when the windows' orientations do not resolve the unknowns
    (a COM needs two gravity directions; a bias beside the load needs its gravity to
    change; the mounting and the tilt need rotations about two axes), and
    NonPositiveMassError for an object mass at or below zero.
    """
    g = np.asarray(gravity, dtype=np.float64).reshape(3)
    offset = None if uncalibrated is None else np.asarray(uncalibrated, dtype=np.float64)
    model = _Model(
        observations, g, fit_mount, drift_rate_sigma, calibration, offset, whitening,
        nuisance_cov, reference,
    )  # fmt: skip
    if fit_mount and any(o.design is not None for o in model.obs):
        raise ValueError("windows with their own design cannot fit the mounting")
    if not model.obs:
        raise TooFewPosesError("no windows to fit")
    x = np.zeros(model.size)
    free = np.arange(model.mount.start)  # the linear unknowns first: one step solves them
    for k in range(1 + (iterations if fit_mount else 0)):
        jac = model.jacobian(x)[:, free]
        if _condition(jac) > _MAX_CONDITION:
            raise TooFewPosesError(
                "the windows' orientations do not resolve the fit (a COM needs two gravity "
                "directions; a bias beside the load, its gravity to change; the mounting "
                "and the base tilt, rotations about two axes)"
            )
        delta = np.linalg.lstsq(jac, -model.residuals(x), rcond=None)[0]
        x[free] += delta
        if k > 0 and np.max(np.abs(delta[model.mount])) < 1e-12:
            break
        free = np.arange(model.size)  # then Gauss-Newton with the mount and the tilt
    jac, res = model.jacobian(x), model.residuals(x)
    cov = np.linalg.inv(jac.T @ jac)
    chi2, dof = float(res @ res), len(res) - model.size
    poses = tuple(o.window.pose for o in model.obs if o.load)
    hand = (
        _estimate(x, cov, model.hand, chi2, dof, tuple(o.window.pose for o in model.obs))
        if model.has_hand
        else None
    )
    if model.has_object:
        if positive_object and not x[model.object][0] > 0:
            raise NonPositiveMassError(f"mass {x[model.object][0] * 1e3:.3g} g: at or below zero")
        estimate = _estimate(x, cov, model.object, chi2, dof, poses)
    else:
        assert hand is not None
        estimate = hand
    axes = model.tilt_axes
    biases = np.array([i for b in model.bias for i in range(b.start, b.stop)], dtype=int)
    return KinematicFit(
        estimate=estimate,
        hand=hand,
        bias=x[biases].reshape(-1, 6),
        bias_cov=cov[np.ix_(biases, biases)],
        bias_rate=np.array([x[r] for r in model.rate] or np.zeros((model.epochs, 6))).reshape(
            -1, 6
        ),
        mount=x[model.mount][:3].copy() if fit_mount else None,
        mount_cov=cov[model.mount, model.mount][:3, :3].copy() if fit_mount else None,
        base_tilt=x[model.mount][3:] @ axes if fit_mount else None,
        base_tilt_cov=axes.T @ cov[model.mount, model.mount][3:, 3:] @ axes if fit_mount else None,
        cov=cov,
        _model=model,
        _x=x,
    )


def locate_move(
    observations: Sequence[Observation],
    gravity: ArrayLike = DEFAULT_GRAVITY,
    fit_mount: bool = False,
    drift_rate_sigma: tuple[float, float] | None = None,
    calibration: Calibration | None = None,
    nuisance_cov: NDArray[np.float64] | None = None,
) -> tuple[int, float] | None:
    """Where the object moved in the grasp, for a fit that failed its chi-square test:
    (index of the load window, in the order given, and the chi-square of the best
    alternative), or None when there are too few load windows. The alternatives give the
    object a second place in the hand: "window k alone" and "from window k on" (as
    ``estimators.check_consistency`` does for the wrenches alone); the one with the
    smallest chi-square names k."""
    loads = [i for i, o in enumerate(observations) if o.load]
    best: tuple[int, float] | None = None
    for k in range(len(loads)):
        alone, after = {loads[k]}, set(loads[k:])
        for moved in (alone, after) if 0 < k < len(loads) - 1 else (alone,):
            split = [
                replace(o, group=int(i in moved)) if o.load else o
                for i, o in enumerate(observations)
            ]
            try:
                chi2 = kinematic_ml(
                    split, gravity, fit_mount, drift_rate_sigma, calibration=calibration,
                    nuisance_cov=nuisance_cov,
                ).estimate.chi2  # fmt: skip
            except (TooFewPosesError, NonPositiveMassError):
                continue
            if best is None or chi2 < best[1]:
                best = (k, chi2)
    return best


def mount_rpy(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Roll, pitch, yaw (rad; fixed axes x, y, z) of a mounting rotation vector."""
    r = _rotation(np.asarray(rotvec, dtype=np.float64))
    return np.array(
        [
            math.atan2(r[2, 1], r[2, 2]),
            -math.asin(max(-1.0, min(1.0, r[2, 0]))),
            math.atan2(r[1, 0], r[0, 0]),
        ]
    )
