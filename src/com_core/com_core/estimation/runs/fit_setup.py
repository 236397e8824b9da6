"""The fits an exploration's windows take, and what they take them with (``FitSetup``).

The information a fit uses:

- 'wrenches': each pose's gravity direction is unknown; the object's windows less the
  tare of their pose (the paper's W_HAND, eq. 2; ``windows.subtract_tare``) are fitted
  by ``method``: 'ml' (every pose, ``estimators.ml``) or 'two_pose' (the paper's, eqs.
  3, 7, 8, 11), and tested for one rigid load (``estimators.check_consistency``); the load's
  force must point the way the hand's does (both are gravity);
- 'kinematics': each window's gravity in the sensor frame comes from the URDF and the
  joint states (``cutting.window_rotation``); the hand, the sensor's bias (one per run,
  drifting at ``bias_drift_rate``) and the object are fitted together
  (``known_gravity.kinematic_ml``);
- 'kinematics+mount': and the sensor's mounting and the base tilt.

Wrenches are in N and N m in the sensor frame, masses in kg, COMs in m in the sensor
frame. Without a robot model, or with a method other than 'ml', the fit uses the
wrenches and says so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from com_core.contract import OBJECT_PREFIX, TARE_PREFIX
from com_core.estimation.fits.errors import (
    EstimationError,
    MissingTareError,
    NonPositiveMassError,
    WindowError,
)
from com_core.estimation.fits.estimators import (
    DEFAULT_ALPHA,
    MIN_TILT_SIGMAS,
    Consistency,
    Estimate,
    check_consistency,
    ml,
    two_pose,
)
from com_core.estimation.fits.in_place import InPlaceCalibration, calibrate_in_place
from com_core.estimation.fits.known_gravity import (
    BIAS_DRIFT_RATE,
    KinematicFit,
    Observation,
    Reference,
    kinematic_ml,
    locate_move,
)
from com_core.estimation.fits.motion import MotionFit
from com_core.estimation.fits.stats import chi2_isf, chi2_sf
from com_core.estimation.fits.windows import Window
from com_core.estimation.runs.cutting import window_rotation, window_time
from com_core.estimation.runs.inbox import Inbox
from com_core.estimation.runs.tare_cache import TareCache
from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis, Way
from com_core.sensing.noise import NoiseModel
from com_core.sensing.wrench_model import STANDARD_GRAVITY, SensorModel

__all__ = [
    "INFORMATION",
    "KINEMATICS",
    "KINEMATICS_MOUNT",
    "LOAD_SIGMAS",
    "MAX_DRIFT_F",
    "MAX_DRIFT_TAU",
    "METHODS",
    "WRENCHES",
    "FitSetup",
    "check_load_direction",
    "drifted",
]

LOAD_SIGMAS = 5.0
"""A window's load along the tare's gravity must exceed this many sigma to count as held."""
METHODS = {"ml": ml, "two_pose": two_pose}
WRENCHES, KINEMATICS, KINEMATICS_MOUNT = "wrenches", "kinematics", "kinematics+mount"
INFORMATION = (WRENCHES, KINEMATICS, KINEMATICS_MOUNT)
"""What the fit uses: the wrenches only, or also each window's gravity from kinematics."""
_DRIFT_STEP = 1e-3
"""The drift rate's central-difference step in ``wrenches_estimate``, in its sigmas."""
MAX_DRIFT_F, MAX_DRIFT_TAU = 1.0, 0.05
"""N, N m: a bias drift since the tare beyond either, as far as the fit can tell
(``drifted``), is a WARN (re-tare; the fit absorbs it, but a sensor drifting that fast is
warming up or was overloaded)."""


@dataclass
class FitSetup:
    """What the fits take besides the windows.

    Attributes
    ----------
    method : 'ml' or 'two_pose'.
    sensor : sensor model for saturation and motion tests; None uses the samples alone.
    noise : the sensor's noise known from before (a cached tare pass's,
        ``com_core.sensing.noise``): used when an exploration's own static windows are too
        few to learn it, and compared with what they give (a changed noise is named).
    alpha : false-alarm rate of the consistency and verification tests, and the drift's.
    min_tilt_sigmas : refuse tilts below this many sigma of noise.
    g : m/s^2, the gravity the wrench-only fits divide by.
    cached_tare : a tare pass known from before (``tare_cache.TareCache``, its windows
        as this exploration's samples are read): its windows by pose (``tares``; an
        exploration's own tare windows take precedence), with the joint positions and
        the time of each for the hand model of the kinematic information, and, for a
        sensor of stated hysteresis, each one's way from the one before it in its pass.
    untared : estimate the whole load beyond the sensor (hand + object) without any
        tare; the solution is then at best WARN and says so.
    information : 'wrenches', 'kinematics' or 'kinematics+mount' (see module); with no
        robot model the fit falls back to 'wrenches' and says so.
    robot, robot_problem : the robot model for the kinematic information, and why there
        is none.
    bias_drift_rate : N/s, N m/s; the sensor bias's drift rate to allow for within a
        run (1 sigma; (0, 0): a constant bias within a run).
    max_drift_f, max_drift_tau : N, N m; a larger bias drift since a cached tare is a WARN.
    calibration : the sensor's stated accuracy and full scales: the fits weigh their
        windows with the calibration's common error too (``com_core.sensing.calibration``);
        None: a perfect calibration.
    hysteresis : the sensor's hysteresis: each static window of the kinematic fit weighs
        what the change of its load leaves (``com_core.sensing.hysteresis``); None: none.
    reference : the object is a reference weight of known mass: the exploration
        calibrates the sensor in place (``estimation.fits.in_place``) instead of weighing
        it; None: an unknown object.
    hand_motion : the empty hand's motion fit known from before (``hand_motion``), for an
        exploration in motion that does not move the empty hand.
    """

    method: str = "ml"
    sensor: SensorModel | None = None
    noise: NoiseModel | None = None
    alpha: float = DEFAULT_ALPHA
    min_tilt_sigmas: float = MIN_TILT_SIGMAS
    g: float = STANDARD_GRAVITY
    cached_tare: TareCache | None = None
    untared: bool = False
    information: str = WRENCHES
    robot: RobotModel | None = None
    robot_problem: str = ""
    bias_drift_rate: tuple[float, float] = BIAS_DRIFT_RATE
    max_drift_f: float = MAX_DRIFT_F
    max_drift_tau: float = MAX_DRIFT_TAU
    calibration: Calibration | None = None
    reference: Reference | None = None
    hysteresis: Hysteresis | None = None
    hand_motion: MotionFit | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}, got {self.method!r}")
        if self.information not in INFORMATION:
            raise ValueError(f"information must be one of {INFORMATION}, got {self.information!r}")

    @property
    def tares(self) -> Mapping[str, Window]:
        """The cached tare pass's windows by pose ({} without one)."""
        return {} if self.cached_tare is None else self.cached_tare.windows

    def information_used(self, notes: list[str]) -> str:
        """The information the fit can use: ``information``; 'wrenches' for a method other
        than ml, and without a robot model (with the reason in ``notes``)."""
        if self.information == WRENCHES or self.method != "ml":  # two_pose: the wrenches
            return WRENCHES
        if self.robot is None:
            why = self.robot_problem or "none given"
            notes.append(
                f"no robot model ({why}): information 'wrenches', not {self.information!r}"
            )
            return WRENCHES
        return self.information

    def wrenches_estimate(
        self, windows: list[Window], spans: Sequence[float] | None = None
    ) -> Estimate:
        """``method``'s estimate from the tare-subtracted ``windows``, its covariance with
        the calibration's share (``Calibration.propagated``) and, given ``spans`` (s, per
        window: its time less its pose's tare's), the bias's drift between them: a rate
        common to every window of prior sigma ``bias_drift_rate`` per axis, which shifts
        window i by r span_i, propagated through the estimator's Jacobian by central
        differences (the kinematic fit weighs the same prior as a bias per epoch)."""

        def fit(ws: list[Window]) -> Estimate:
            return METHODS[self.method](ws, g=self.g, min_tilt_sigmas=self.min_tilt_sigmas)

        def numbers(ws: list[Window]) -> NDArray[np.float64]:
            e = fit(ws)
            return np.array([e.mass, *e.com])

        estimate = fit(windows)
        cov = estimate.cov
        if self.calibration is not None:
            cov = cov + self.calibration.propagated(numbers, windows)
        if spans is not None:

            def moved(shift: NDArray[np.float64]) -> NDArray[np.float64]:
                return numbers([replace(w, mean=w.mean + dt * shift)
                                for w, dt in zip(windows, spans, strict=True)])  # fmt: skip

            for axis, sigma in enumerate(np.repeat(self.bias_drift_rate, 3)):
                shift = np.zeros(6)
                shift[axis] = _DRIFT_STEP * sigma
                gain = (moved(shift) - moved(-shift)) / (2.0 * _DRIFT_STEP)
                cov = cov + np.outer(gain, gain)
        return replace(estimate, cov=cov)

    def wrenches_sigma(self, windows: list[Window]) -> NDArray[np.float64] | None:
        """For a kinematic fit, the COM sigma (m) the wrenches alone give on the same
        tare-subtracted ``windows`` (None when a pose has no tare or they give none)."""
        try:
            return ml(windows, g=self.g, min_tilt_sigmas=0.0).sigma_com if windows else None
        except EstimationError:
            return None

    def kinematic_consistency(
        self,
        fit: KinematicFit,
        observations: list[Observation],
        information: str,
        subtracted: list[Window],
    ) -> Consistency:
        """The chi-square test of the kinematic fit. When it fails, the object moved in the
        grasp if one move explains the windows (``known_gravity.locate_move``: the best
        alternative passes the test; the message names the pose), or if the wrenches alone
        fail too (``check_consistency`` of the tare-subtracted windows: a slip that goes on,
        a friction grasp); else the misfit is the kinematic model's: what the wrenches
        alone cannot see (a sensor mounted off its URDF frame, a wrong base gravity, joint
        states of another time) or a bias drifting faster than ``bias_drift_rate``."""
        e = fit.estimate
        head = f"chi2 {e.chi2:.1f}, {e.dof} dof, p {e.p_value:.2g}"
        if e.p_value >= self.alpha:
            return Consistency(True, e.chi2, e.dof, e.p_value, self.alpha, None, "")
        robot = self.robot
        assert robot is not None
        found = locate_move(
            observations,
            robot.gravity,
            information == KINEMATICS_MOUNT,
            self.bias_drift_rate,
            self.calibration,
            self.hysteresis_cov(observations),
        )
        loads = [o.window.pose for o in observations if o.load]
        if found is not None and chi2_sf(found[1], e.dof - 4) >= self.alpha:
            pose = loads[found[0]]
            message = (
                f"poses inconsistent ({head}): the object moved in the grasp at pose {pose!r}"
            )
            return Consistency(False, e.chi2, e.dof, e.p_value, self.alpha, pose, message)
        tested = self.calibration.widened(subtracted) if self.calibration else subtracted
        try:  # as the wrenches' own fit tests them: each window widened by its calibration share
            alone = check_consistency(tested, alpha=self.alpha, g=self.g) if tested else None
        except EstimationError:
            alone = None
        if alone is not None and not alone.consistent:
            message = f"kinematic fit {head}; the wrenches alone: {alone.message}"
            return Consistency(
                False, e.chi2, e.dof, e.p_value, self.alpha, alone.suspect_pose, message
            )
        message = (
            f"the wrenches do not fit the kinematic gravity ({head}): a sensor mounted off "
            "its URDF frame, a wrong base gravity, joint states of another time, or a bias "
            "drifting faster than bias_drift_rate"
        )
        return Consistency(False, e.chi2, e.dof, e.p_value, self.alpha, None, message)

    def kinematic_observations(
        self,
        inbox: Inbox,
        objects: list[Window],
        subtracted: list[Window],
        fresh_tares: Mapping[str, Window],
        until_ns: int | None,
        notes: list[str],
    ) -> list[Observation]:
        """Every window with its orientation and time (from ``inbox``) for
        ``known_gravity.kinematic_ml``: this run's empty-hand windows (its tare pass, or
        the window that checks a cached tare) share this run's bias, a cached tare pass
        has its own; a window without an orientation is left out, with the reason in
        ``notes``. A cached tare without joint positions cannot give the hand at other
        poses: the tare-subtracted windows (``subtracted``) stand for the objects', as the
        load alone (MissingTareError without them)."""
        assert self.robot is not None
        robot = self.robot
        observations: list[Observation] = []
        stamps, wrenches = inbox.samples()

        def add(
            window: Window,
            label: str,
            load: bool,
            epoch: int,
            cached: tuple[Mapping[str, float], float] | None = None,
            way: Way | None = None,
        ) -> None:
            try:
                if cached is None:
                    rotation = window_rotation(inbox, robot, label, until_ns)
                    time = window_time(inbox, label, stamps, until_ns)
                else:
                    rotation, time = robot.sensor_rotation(cached[0]), cached[1]
            except (WindowError, KinematicsError) as exc:
                notes.append(f"left out: {exc}")
                return
            observations.append(with_way(Observation(window, rotation, load, epoch, time), way))

        if not self.untared:
            for pose, window in fresh_tares.items():
                add(window, TARE_PREFIX + pose, False, 0)
            if (tare := self.cached_tare) is not None:
                for pose, window in tare.windows.items():
                    if pose not in fresh_tares and pose in tare.joints:
                        cached = (tare.joints[pose], tare.times.get(pose, 0.0))
                        way = tare.ways.get(pose)
                        add(window, f"cached tare {pose!r}", False, 1, cached, way)
        loads = objects
        if not self.untared and all(o.load for o in observations):
            if not subtracted:
                raise MissingTareError(
                    "no tare for the object's poses, and no empty-hand window with joint "
                    "positions to model the hand from"
                )
            notes.append("the tare has no joint positions: subtracted per pose, no bias fit")
            loads = subtracted
        for window in loads:
            add(window, OBJECT_PREFIX + window.pose, True, 0)
        return self.with_hysteresis(self.with_ways(observations, stamps, wrenches))

    def with_ways(
        self,
        observations: list[Observation],
        stamps: NDArray[np.int64],
        wrenches: NDArray[np.float64],
    ) -> list[Observation]:
        """``observations`` of this run (epoch 0) with the load's ``travel`` from the window
        before each, in time order: the samples (``stamps`` ns, ``wrenches`` (n, 6)) from
        the middle of one window to the middle of the next (``sensing.hysteresis.travel``),
        the lowest and highest load on it (``reach``), and what the sensor's hysteresis
        state moved beyond its first order since the first window after the epoch's start
        or the last way through contact (``beyond``; ``Hysteresis.beyond_first_order``);
        as they are without a hysteresis."""
        if self.hysteresis is None:
            return observations
        out = list(observations)
        order = np.argsort(stamps, kind="stable")
        times, loads = stamps[order] * 1e-9, wrenches[order]
        for epoch in _epoch_orders(out):
            if out[epoch[0]].epoch != 0:
                continue
            found = self.hysteresis.ways(
                [out[i].time for i in epoch], _contacts(out, epoch), times, loads
            )
            for i, way in zip(epoch, found, strict=True):
                out[i] = with_way(out[i], way)
        return out

    def with_hysteresis(self, observations: list[Observation]) -> list[Observation]:
        """``observations`` with the sensor's hysteresis as a nuisance each window carries
        (``Observation.nuisance``): the state's increment at every change of load up to
        it in its epoch (each epoch's windows in time order), which persists, and the
        share it still carries of the state's offset at the epoch's first window and at
        the first after each way through contact (``Hysteresis.start_memory``), of the
        covariance ``hysteresis_cov`` (``com_core.sensing.hysteresis``)."""
        if self.hysteresis is None:
            return observations
        out, ways = list(observations), self._hysteresis_ways(observations)
        n = len(out)
        offsets = [memory for _, _, memories in ways for memory in memories]
        k = 6 * (n + len(offsets))
        column = 6 * n
        for order, _, memories in ways:
            designs = {i: np.zeros((6, k)) for i in order}
            for rank, i in enumerate(order):
                for j in order[: rank + 1]:
                    designs[i][:, 6 * j : 6 * j + 6] = np.eye(6)
            for memory in memories:
                for rank, i in enumerate(order):
                    designs[i][:, column : column + 6] = np.diag(memory[rank])
                column += 6
            for i in order:
                out[i] = replace(out[i], nuisance=designs[i])
        return out

    def hysteresis_cov(self, observations: Sequence[Observation]) -> NDArray[np.float64] | None:
        """The covariance of the nuisance ``with_hysteresis`` gives ``observations`` (the
        increments, then each offset: anywhere within the band,
        ``Hysteresis.start_variance``); None without a hysteresis."""
        if self.hysteresis is None:
            return None
        variance = np.zeros((len(observations), 6))
        ways = self._hysteresis_ways(observations)
        for order, sigma, _ in ways:
            variance[order] = sigma**2
        starts = [self.hysteresis.start_variance()] * sum(len(m) for _, _, m in ways)
        return np.diag(np.concatenate([variance.ravel(), *starts]))

    def carried(
        self,
        fit: KinematicFit,
        observation: Observation,
        stamps: NDArray[np.int64],
        wrenches: NDArray[np.float64],
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """What the sensor's hysteresis adds to a window of this run the ``fit`` did not
        use (a verification's ``observation``): its mean (6,; N, N m) and covariance
        (6, 6), the increments and the offsets it shares with the fit's windows as the
        fit left them (``KinematicFit.nuisance_posterior``) and its own increment
        since the window before it as ``hysteresis_cov`` weighs it, the ways from the
        samples (``stamps`` ns, ``wrenches`` (n, 6)); None without a hysteresis."""
        posterior = fit.nuisance_posterior()
        if self.hysteresis is None or posterior is None:
            return None
        used = list(fit.observations)
        n = 6 * len(used)
        ways = self.with_ways([*used, observation], stamps, wrenches)
        extended = self.with_hysteresis(ways)
        design = extended[-1].nuisance
        own_cov = self.hysteresis_cov(extended)
        assert design is not None and own_cov is not None
        assert design.shape[1] == len(posterior[0]) + 6, "the window changed the ways' contacts"
        shared = np.hstack([design[:, :n], design[:, n + 6 :]])  # the fit's unknowns
        own = design[:, n : n + 6] @ own_cov[n : n + 6, n : n + 6] @ design[:, n : n + 6].T
        mean, cov = posterior
        beyond = ways[-1].beyond
        assert beyond is not None, "a window of this run without its way's samples"
        return shared @ mean + beyond, shared @ cov @ shared.T + own

    def _hysteresis_ways(
        self, observations: Sequence[Observation]
    ) -> list[tuple[list[int], NDArray[np.float64], list[NDArray[np.float64]]]]:
        """Per epoch: its windows' indices in time order, the sigma of the state's move to
        each (``Hysteresis.window_sigma``) and the share each carries of the state's
        offset (``Hysteresis.start_memory``) at the epoch's first window and at the first
        after each way through contact, where the object was grasped or released (the
        fingers, the table or the stand). Such a way moves the state more than its
        samples show, the contact chattering within their noise, and leaves it anywhere
        in its band (``bench/hysteresis_ways.py``): its move is weighed at the most it can
        be, as the planner weighs it, and its offset after it as a run's start's."""
        h = self.hysteresis
        assert h is not None
        out = []
        for order in _epoch_orders(observations):
            picked = [observations[i] for i in order]  # no travel: a straight way, NaN
            means = [o.window.mean for o in picked]
            travels = [np.full(6, np.nan) if o.travel is None else o.travel for o in picked]
            reaches = [np.full((2, 6), np.nan) if o.reach is None else o.reach for o in picked]
            contact = _contacts(observations, order)
            moves = np.array(travels, dtype=np.float64)
            moves[contact] = np.inf
            sigma = h.window_sigma(means, moves, reaches, [o.beyond is not None for o in picked])
            starts = [0, *contact]
            out.append((order, sigma, [h.start_memory(means, travels, j) for j in starts]))
        return out

    def calibrate(
        self,
        inbox: Inbox,
        objects: list[Window],
        fresh_tares: Mapping[str, Window],
        until_ns: int | None,
        notes: list[str],
    ) -> tuple[InPlaceCalibration, KinematicFit, list[Observation]]:
        """The sensor's calibration in place from the ``reference``'s windows and the
        empty hand's (``kinematic_observations``; ``in_place.calibrate_in_place``), with
        the stated ``calibration`` as its prior; with its fit and observations.
        EstimationError without a stated accuracy, or with readings already corrected."""
        assert self.robot is not None and self.reference is not None
        if self.calibration is None or self.calibration.estimate is not None:
            raise EstimationError(
                "a calibration in place needs the sensor's stated accuracy (accuracy > 0) "
                "and its readings as they came (no calibration applied)"
            )
        observations = self.kinematic_observations(inbox, objects, [], fresh_tares, until_ns,
                                                   notes)  # fmt: skip
        result, fit = calibrate_in_place(observations, self.reference, self.calibration,
                                         self.robot.gravity, self.bias_drift_rate,
                                         self.hysteresis_cov(observations))  # fmt: skip
        return result, fit, observations

    def kinematic_fit(
        self,
        inbox: Inbox,
        objects: list[Window],
        subtracted: list[Window],
        fresh_tares: Mapping[str, Window],
        information: str,
        until_ns: int | None,
        notes: list[str],
    ) -> tuple[KinematicFit, list[Observation]]:
        """The hand, the bias and the object fitted to every window with its orientation
        (``kinematic_observations``; ``known_gravity.kinematic_ml``). A bias drift beyond
        ``max_drift_f`` or ``max_drift_tau`` as far as the fit can tell (``drifted``) is
        noted (a WARN). Returns the fit and its observations."""
        assert self.robot is not None
        robot = self.robot
        observations = self.kinematic_observations(
            inbox, objects, subtracted, fresh_tares, until_ns, notes
        )
        fit = kinematic_ml(
            observations,
            robot.gravity,
            fit_mount=information == KINEMATICS_MOUNT,
            drift_rate_sigma=self.bias_drift_rate,
            calibration=self.calibration,
            nuisance_cov=self.hysteresis_cov(observations),
        )
        e = fit.estimate
        if not self.untared and e.mass < LOAD_SIGMAS * e.sigma_mass:
            raise NonPositiveMassError(
                f"no load beyond the hand ({e.mass * 1e3:.3g} +- {e.sigma_mass * 1e3:.2g} g): "
                "the object was not held (an empty grasp, or it fell)"
            )
        drift, cov = fit.drift()
        if drifted(drift[:3], cov[:3, :3], self.max_drift_f, self.alpha) or drifted(
            drift[3:], cov[3:, 3:], self.max_drift_tau, self.alpha
        ):
            force, torque = float(np.linalg.norm(drift[:3])), float(np.linalg.norm(drift[3:]))
            notes.append(
                f"the sensor's bias drifted {force:.3g} N, {torque:.3g} N m since the cached "
                f"tare (more than {self.max_drift_f:g} N or {self.max_drift_tau:g} N m, "
                "beyond the fit's sigma): the fit absorbed it; re-tare"
            )
        return fit, observations


def drifted(drift: NDArray[np.float64], cov: NDArray[np.float64], limit: float,
            alpha: float) -> bool:  # fmt: skip
    """Whether the bias drifted more than ``limit`` (N or N m) since the tare, as far as
    the fit can tell: the norm of ``drift`` (3,) exceeds it by more than the one-sided
    1 - ``alpha`` quantile of its sigma along it (``cov`` (3, 3)). A sensor of stated
    hysteresis leaves an offset after each contact that the fit cannot tell from a drift,
    and it is in that sigma (the xArm F/T sensor's: 0.1-0.5 N per axis)."""
    size = float(np.linalg.norm(drift))
    if size <= limit:
        return False
    along = drift / size
    sigma = math.sqrt(max(float(along @ cov @ along), 0.0))
    return size - limit > math.sqrt(chi2_isf(2.0 * alpha, 1)) * sigma


def with_way(observation: Observation, way: Way | None) -> Observation:
    """``observation`` with its way's ``travel``, ``reach`` and ``beyond`` (``Way``);
    as it is for none."""
    if way is None:
        return observation
    return replace(observation, travel=way.travel, reach=way.reach, beyond=way.beyond)


def _contacts(observations: Sequence[Observation], order: list[int]) -> list[int]:
    """The places in ``order`` (an epoch's indices in time order) whose window follows a
    way through contact: the object grasped or released (``Observation.load`` changed)."""
    return [k for k in range(1, len(order))
            if observations[order[k]].load != observations[order[k - 1]].load]  # fmt: skip


def _epoch_orders(observations: Sequence[Observation]) -> list[list[int]]:
    """The indices of each epoch's observations, in time order."""
    epochs = sorted({o.epoch for o in observations})
    return [sorted((i for i, o in enumerate(observations) if o.epoch == e),
                   key=lambda i: observations[i].time) for e in epochs]  # fmt: skip


def check_load_direction(windows: Sequence[Window], tares: Mapping[str, Window]) -> None:
    """The object's force must point the way the hand's does (both are gravity), and be
    more than ``LOAD_SIGMAS`` sigma of its own noise along it.

    No load along gravity: the object was not held (an empty grasp, or it fell). A load
    against gravity: a mass below zero, the tare was taken with the object in the hand.
    Raises NonPositiveMassError with the pose and the load (g).
    """
    for w in windows:
        along = tares[w.pose].force / np.linalg.norm(tares[w.pose].force)
        load = float(w.force @ along)  # N, along gravity
        sd = math.sqrt(max(float(along @ w.cov[:3, :3] @ along), 0.0))
        if load > LOAD_SIGMAS * sd:
            continue
        grams = f"{load / STANDARD_GRAVITY * 1e3:.3g} +- {sd / STANDARD_GRAVITY * 1e3:.2g} g"
        if load < -LOAD_SIGMAS * sd:
            raise NonPositiveMassError(
                f"pose {w.pose!r}: the load's force points against gravity ({grams}; was "
                f"the tare taken with the object in the hand?)"
            )
        raise NonPositiveMassError(
            f"pose {w.pose!r}: no load beyond the hand ({grams}): the object was not held "
            f"(an empty grasp, or it fell)"
        )
