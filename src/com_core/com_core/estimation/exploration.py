"""One exploration: stamped samples and stamped pose labels in, a solution with a status out.

The estimator node and the offline replay both feed an ``Exploration`` and call
``solve``: the same messages give the same numbers, to the last bit, because every
decision here depends only on the messages' contents, never on arrival order across
topics:

- a label (std_msgs/Header: ``frame_id`` the label, ``stamp`` the time from which it
  applies) opens a window at its stamp that ends at the next label's stamp; samples
  are assigned to windows by their own header stamps;
- labels ``tare/<pose>`` and ``object/<pose>`` name static windows; ``verify/<pose>``
  names a static window with the object in the hand that no fit uses: the wrench the fit
  predicts there is checked against it (``Verification``); any other label (``moving``,
  ``done``, ...) closes the current window; ``done`` asks for a solution from the labels
  up to it;
- samples are kept in arrival order; one whose stamp equals the latest kept stamp is
  dropped and counted as a duplicate stamp, one stamped before it as out of time order,
  as are non-finite samples and samples in another frame than the expected one; a jump
  back by more than 1 s is a restarted clock, not a late sample: what came before it is
  dropped (``time_resets``);
- a label stamped more than ``max_label_gap`` s after the latest label starts a new
  exploration: the earlier labels and samples belong to a run that stopped (a killed
  sequencer) and are dropped (``stale_drops``), so two runs' windows of the same name
  never merge; labels longer than ``MAX_LABEL_LENGTH`` characters are refused.

Statuses: ERROR (no estimate: no windows, too few poses, ill-conditioned, no tare, no
load), WARN (an estimate, but: the object moved in the grasp, the wrench at a
verification pose is off the prediction, or input was dropped), OK. ``Solution.usable``
tells the estimates to hand on (OK, or WARN for dropped input only) from those kept for
diagnosis (an inconsistent fit, a failed verification).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.contract import DONE, ERROR, OBJECT_PREFIX, OK, TARE_PREFIX, VERIFY_PREFIX, WARN
from com_core.estimation.errors import (
    EstimationError,
    MissingTareError,
    NonPositiveMassError,
    WindowError,
)
from com_core.estimation.estimators import (
    DEFAULT_ALPHA,
    MIN_TILT_SIGMAS,
    Consistency,
    Estimate,
    check_consistency,
    ml,
    two_pose,
)
from com_core.estimation.known_gravity import (
    BIAS_DRIFT_RATE,
    KinematicFit,
    Observation,
    kinematic_ml,
    locate_move,
    mount_rpy,
)
from com_core.estimation.stats import chi2_isf, chi2_sf
from com_core.estimation.windows import Window, reduce_window, subtract_tare
from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import NoiseModel, learn_noise
from com_core.sensing.wrench_model import STANDARD_GRAVITY, SensorModel

__all__ = [
    "ERROR",
    "MAX_LABEL_GAP",
    "MAX_LABEL_LENGTH",
    "METHODS",
    "OK",
    "WARN",
    "Exploration",
    "Solution",
    "Verification",
    "done_stamp",
    "format_solution",
    "noise_line",
    "shorten",
    "vector_value",
    "verification_lines",
]

_NO_STAMP = -(2**62)
TIME_RESET_NS = 1_000_000_000
"""A sample stamped this much before its predecessor starts a new clock, not a late one."""
MAX_LABEL_GAP = 120.0
"""s (sensor time) without a label after which the next label starts a new exploration."""
MAX_LABEL_LENGTH = 128
"""Characters; a longer label is refused (pose names are short: ``object/tilt_x+``)."""
LOAD_SIGMAS = 5.0
"""A window's load along the tare's gravity must exceed this many sigma to count as held."""
METHODS = {"ml": ml, "two_pose": two_pose}
WRENCHES, KINEMATICS, KINEMATICS_MOUNT = "wrenches", "kinematics", "kinematics+mount"
INFORMATION = (WRENCHES, KINEMATICS, KINEMATICS_MOUNT)
"""What the fit uses: the wrenches only, or also each window's gravity from kinematics."""
IDLE_KEEP = 10.0
"""s (sensor time) of samples an exploration keeps before its first label."""
JOINT_STATE_GAP = 0.1
"""s; a window without a joint state in it takes the nearest this close to it."""
JOINT_MOTION = 2e-3
"""rad (or m); joints that move more than this within a window leave it out."""
MAX_DRIFT_F, MAX_DRIFT_TAU = 1.0, 0.05
"""N, N m: a bias drift since the tare beyond either is a WARN (re-tare; the fit absorbs
it, but a sensor drifting that fast is warming up or was overloaded)."""


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
    verifications: tuple[Verification, ...] = ()
    unverified: str = ""
    noise: NoiseModel | None = None

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
                out += [(f"samples {label}", str(n)) for label, n in value.items()]
            elif key not in ("reason", "notes"):
                out.append((key, text(value)))
        return out

    def as_dict(self) -> dict:
        """JSON-ready summary: mass (kg), com (m, sensor frame), their sigmas, status."""
        out: dict = {
            "status": self.status,
            "usable": self.usable,
            "reason": self.reason,
            "method": self.method,
            "information": self.information,
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
            }
        if self.wrenches_sigma_com is not None:
            out["wrenches_sigma_com"] = self.wrenches_sigma_com.tolist()
        out |= _fit_dict(self.fit) if self.fit is not None else {}
        for v in self.verifications:
            out[f"verify_wrench {v.pose}"] = v.wrench.tolist()
            out[f"verify_sigma {v.pose}"] = v.sigma.tolist()
            out[f"verify_noise {v.pose}"] = np.sqrt(np.diag(v.noise)).tolist()
            out[f"verify_distance {v.pose}"] = [*v.distance, v.allowed]
        if self.unverified:
            out["unverified"] = self.unverified
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


@dataclass
class Exploration:
    """Collects one exploration's samples and labels and solves it (see module).

    Attributes
    ----------
    method : 'ml' or 'two_pose'.
    expected_frame : frame_id the samples must carry ('' accepts any).
    sensor : sensor model for saturation and motion tests; None uses the samples alone.
    noise : the sensor's noise known from before (a cached tare pass's,
        ``com_core.sensing.noise``): used when this exploration's own static windows are too few
        to learn it, and compared with what they give (a changed noise is named).
    tares : tare windows known from before (a cached tare pass), by pose; this
        exploration's own tare windows take precedence.
    untared : estimate the whole load beyond the sensor (hand + object) without any
        tare; the solution is then at best WARN and says so.
    max_label_gap : s (sensor time); a label this long after the previous one starts a
        new exploration (0: never).
    tare_joints, tare_times : the joint positions (rad, m; by name) and the time (s) of
        each cached tare window, for the hand model of the kinematic information.
    information : 'wrenches' (each pose's gravity direction unknown: the wrenches only),
        'kinematics' (each window's orientation from ``robot`` and the joint states; the
        hand, the sensor bias and the object fitted together, ``known_gravity``) or
        'kinematics+mount' (and the sensor's mounting and the base tilt); with no robot
        model the fit falls back to 'wrenches' and says so.
    bias_drift_rate : N/s, N m/s; the sensor bias's drift rate to allow for within a
        run (1 sigma; (0, 0): a constant bias within a run).
    max_drift_f, max_drift_tau : N, N m; a larger bias drift since a cached tare is a WARN.
    calibration : the sensor's stated accuracy and full scales: the kinematic fit weighs
        its windows with the calibration's common error too (``com_core.sensing.calibration``);
        None: a perfect calibration.
    """

    method: str = "ml"
    expected_frame: str = "ft_sensor"
    sensor: SensorModel | None = None
    noise: NoiseModel | None = None
    alpha: float = DEFAULT_ALPHA
    min_tilt_sigmas: float = MIN_TILT_SIGMAS
    g: float = STANDARD_GRAVITY
    tares: Mapping[str, Window] = field(default_factory=dict)
    tare_joints: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    tare_times: Mapping[str, float] = field(default_factory=dict)
    untared: bool = False
    max_label_gap: float = MAX_LABEL_GAP
    information: str = WRENCHES
    robot: RobotModel | None = None
    robot_problem: str = ""
    bias_drift_rate: tuple[float, float] = BIAS_DRIFT_RATE
    max_drift_f: float = MAX_DRIFT_F
    max_drift_tau: float = MAX_DRIFT_TAU
    calibration: Calibration | None = None
    _joint_states: list[tuple[int, dict[str, float]]] = field(default_factory=list, repr=False)
    _stamps: list[NDArray[np.int64]] = field(default_factory=list, repr=False)
    _wrenches: list[NDArray[np.float64]] = field(default_factory=list, repr=False)
    _labels: list[tuple[int, str]] = field(default_factory=list, repr=False)
    _last_stamp: int = field(default=_NO_STAMP, repr=False)
    dropped: dict[str, int] = field(default_factory=dict)
    dropped_labels: dict[str, int] = field(default_factory=dict)
    time_resets: int = 0
    stale_drops: int = 0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}, got {self.method!r}")
        if self.information not in INFORMATION:
            raise ValueError(f"information must be one of {INFORMATION}, got {self.information!r}")

    @property
    def sample_count(self) -> int:
        return sum(len(s) for s in self._stamps)

    @property
    def latest_stamp(self) -> int | None:
        """Stamp (ns) of the latest sample kept, or None before the first."""
        return None if self._last_stamp == _NO_STAMP else self._last_stamp

    @property
    def labels(self) -> list[tuple[int, str]]:
        """(stamp ns, label) in arrival order."""
        return list(self._labels)

    def add_samples(
        self, stamps_ns: ArrayLike, wrenches: ArrayLike, frames: ArrayLike | str
    ) -> int:
        """Add samples in arrival order; returns how many were kept.

        stamps_ns : shape (n,), int ns. wrenches : shape (n, 6), N and N m.
        frames : frame_id per sample, or one for all.
        """
        stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
        w = np.asarray(wrenches, dtype=np.float64).reshape(-1, 6)
        if len(stamps) != len(w):
            raise ValueError(f"{len(stamps)} stamps for {len(w)} wrenches")
        keep = np.ones(len(stamps), dtype=bool)
        if self.expected_frame:
            frame_ids = np.asarray(frames, dtype=object)
            frame_ok = np.broadcast_to(frame_ids == self.expected_frame, keep.shape)
            if not frame_ok.all():
                names = sorted(set(np.broadcast_to(frame_ids, keep.shape)[~frame_ok]))
                self._count(
                    f"in frame {'/'.join(names)!r}, not {self.expected_frame!r}",
                    int((~frame_ok).sum()),
                )
            keep &= frame_ok
        finite = np.isfinite(w).all(axis=1)
        self._count("not finite (NaN or inf)", int((keep & ~finite).sum()))
        keep &= finite
        kept_idx = np.flatnonzero(keep)
        if kept_idx.size:
            s = stamps[kept_idx]
            # a restarted clock: a sample more than TIME_RESET_NS before the latest one
            while True:
                latest = np.maximum.accumulate(np.concatenate([[self._last_stamp], s]))[:-1]
                restarts = np.flatnonzero(s <= latest - TIME_RESET_NS)
                if not restarts.size:
                    break
                first = int(restarts[0])
                self._restart_clock(int(s[first]))
                keep[kept_idx[:first]] = False
                kept_idx, s = kept_idx[first:], s[first:]
            # not after the latest stamp kept so far: a duplicate, or out of time order
            prior = np.maximum.accumulate(np.concatenate([[self._last_stamp], s[:-1]]))
            self._count("with a duplicate stamp", int((s == prior).sum()))
            self._count("out of time order", int((s < prior).sum()))
            keep[kept_idx[s <= prior]] = False
            self._last_stamp = max(self._last_stamp, int(s.max()))
        self._stamps.append(stamps[keep])
        self._wrenches.append(w[keep])
        return int(keep.sum())

    def samples(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """All kept samples: stamps (n,) ns and wrenches (n, 6), in arrival order."""
        if not self._stamps:
            return np.empty(0, np.int64), np.empty((0, 6))
        return np.concatenate(self._stamps), np.concatenate(self._wrenches)

    def _restart_clock(self, stamp_ns: int) -> None:
        """The sensor's clock restarted at ``stamp_ns`` (a restarted simulator, a looped
        bag): the samples and labels of the old timeline are dropped, so the two
        timelines' stamps never mix in a window; counted in ``time_resets``."""
        self.time_resets += 1
        self._stamps.clear()
        self._wrenches.clear()
        self._labels = [(t, lbl) for t, lbl in self._labels if t <= stamp_ns + TIME_RESET_NS]
        self._last_stamp = _NO_STAMP

    def add_label(self, stamp_ns: int, label: str) -> None:
        """A pose label applying from ``stamp_ns`` (see module)."""
        stamp_ns = int(stamp_ns)
        if len(label) > MAX_LABEL_LENGTH:
            what = f"longer than {MAX_LABEL_LENGTH} characters ({shorten(label)})"
            self.count_dropped(what, 1, labels=True)
            return
        if self._labels and self.max_label_gap > 0:
            latest = max(t for t, _ in self._labels)
            if stamp_ns - latest > self.max_label_gap * 1e9:
                self._drop_before(stamp_ns)
        self._labels.append((stamp_ns, label))

    def _drop_before(self, stamp_ns: int) -> None:
        """Forget the labels and the samples before ``stamp_ns``: they belong to an
        exploration that stopped (see module); counted in ``stale_drops``."""
        self.stale_drops += 1
        self._labels.clear()
        self.dropped.clear()
        self.dropped_labels.clear()
        kept = [(t >= stamp_ns, t, w) for t, w in zip(self._stamps, self._wrenches, strict=True)]
        self._stamps = [t[k] for k, t, _ in kept]
        self._wrenches = [w[k] for k, _, w in kept]

    def forget_idle(self, keep_s: float = IDLE_KEEP) -> None:
        """Before the first window label, keep only the last ``keep_s`` s (sensor time) of
        samples and joint states: the lead-in a first window may reach back into. A node
        that only compensates (no exploration running) then holds a bounded buffer."""
        windows = (TARE_PREFIX, OBJECT_PREFIX, VERIFY_PREFIX)
        opened = any(label.startswith(windows) for _, label in self._labels)
        if opened or self._last_stamp == _NO_STAMP:
            return
        cut = self._last_stamp - round(keep_s * 1e9)
        if self._stamps and (len(self._stamps[0]) == 0 or self._stamps[0][0] < cut):
            kept = [(t >= cut, t, w) for t, w in zip(self._stamps, self._wrenches, strict=True)]
            self._stamps = [t[k] for k, t, _ in kept if k.any()]
            self._wrenches = [w[k] for k, _, w in kept if k.any()]
        if self._joint_states and self._joint_states[0][0] < cut:
            self._joint_states = [(t, q) for t, q in self._joint_states if t >= cut]

    def done_stamp(self) -> int | None:
        """Stamp of the ``done`` that ends this exploration (see ``done_stamp``)."""
        return done_stamp(self._labels)

    def count_dropped(self, what: str, n: int, labels: bool = False) -> None:
        """Count ``n`` samples (or ``labels``) dropped before they reached this
        exploration (e.g. bytes that do not decode); the solution says so, as for the
        input it drops itself."""
        if labels:
            if n:
                self.dropped_labels[what] = self.dropped_labels.get(what, 0) + n
        else:
            self._count(what, n)

    def _count(self, what: str, n: int) -> None:
        if n:
            self.dropped[what] = self.dropped.get(what, 0) + n

    def spans(self, until_ns: int | None = None) -> dict[str, list[tuple[int, int]]]:
        """[start, stop) stamps (ns) of every tare, object and verify window, per label.

        Windows run from a label's stamp to the next label's; ``until_ns`` ends the
        last one (default: the ``done`` label, else after the last sample).
        """
        labels = sorted(self._labels, key=lambda sl: sl[0])  # stable: ties keep arrival order
        end = self.done_stamp() if until_ns is None else until_ns
        if end is not None:
            labels = [(s, lbl) for s, lbl in labels if s <= end]
        if not labels:
            return {}
        bounds = [s for s, _ in labels[1:]] + [end if end is not None else 2**62]
        spans: dict[str, list[tuple[int, int]]] = {}
        for (start, label), stop in zip(labels, bounds, strict=True):
            if label.startswith((TARE_PREFIX, OBJECT_PREFIX, VERIFY_PREFIX)):
                spans.setdefault(label, []).append((start, stop))
        return spans

    def segments(self, until_ns: int | None = None) -> list[tuple[str, NDArray[np.float64]]]:
        """(label, samples (n, 6)) of every window of ``spans``, merged per label."""
        stamps, wrenches = self.samples()
        return [
            (label, np.concatenate([wrenches[(stamps >= a) & (stamps < b)] for a, b in parts]))
            for label, parts in self.spans(until_ns).items()
        ]

    def add_joint_state(
        self, stamp_ns: int, names: Sequence[str], positions: Sequence[float]
    ) -> None:
        """A joint state (sensor_msgs/JointState: names, positions in rad or m) at
        ``stamp_ns``, for the gravity of each window under ``information`` 'kinematics'."""
        self._joint_states.append((int(stamp_ns), dict(zip(names, positions, strict=True))))

    def window_rotation(self, label: str, until_ns: int | None = None) -> NDArray[np.float64]:
        """R_base_sensor (3, 3) over window ``label`` from the robot model and the joint
        states in its span (or the nearest within JOINT_STATE_GAP s of it). Raises
        WindowError with the reason when there is none or the joints moved."""
        assert self.robot is not None
        spans = self.spans(until_ns)[label]
        stamps = np.array([t for t, _ in self._joint_states], dtype=np.int64)
        # distance (ns) of each joint state to the window: 0 inside it
        distance = np.full(len(stamps), np.inf)
        for a, b in spans:
            distance = np.minimum(
                distance, np.maximum(a - stamps, 0) + np.maximum(stamps - b + 1, 0)
            )
        inside = list(np.flatnonzero(distance == 0))
        if not inside and len(stamps) and distance.min() <= JOINT_STATE_GAP * 1e9:
            inside = [int(np.argmin(distance))]
        if not inside:
            raise WindowError(f"no joint state within {JOINT_STATE_GAP:g} s of window {label!r}")
        names = self.robot.joint_names
        try:
            q = np.array([[self._joint_states[k][1][n] for n in names] for k in inside])
        except KeyError as error:
            raise WindowError(f"window {label!r}: the joint states lack {error}") from error
        moved = float(np.max(np.ptp(q, axis=0)))
        if moved > JOINT_MOTION:
            raise WindowError(f"window {label!r}: the joints moved {moved * 1e3:.1f} mrad")
        return self.robot.sensor_rotation(dict(zip(names, q.mean(axis=0), strict=True)))

    def window_time(
        self, label: str, stamps: NDArray[np.int64], until_ns: int | None = None
    ) -> float:
        """The mean stamp (s) of the samples of window ``label``; ``stamps`` (ns) are every
        kept sample's (``samples``), taken once by a caller that asks for many windows."""
        inside = np.zeros(len(stamps), dtype=bool)
        for a, b in self.spans(until_ns)[label]:
            inside |= (stamps >= a) & (stamps < b)
        return float(np.mean(stamps[inside])) * 1e-9

    def noise_model(
        self,
        until_ns: int | None = None,
        segments: list[tuple[str, NDArray[np.float64]]] | None = None,
    ) -> NoiseModel | None:
        """The sensor's noise learnt from the second halves of every static window
        (``segments``, default ``segments(until_ns)``; the arm's ringing has settled
        there; ``com_core.sensing.noise``), at the rate of the kept samples' stamps; ``noise``
        when they are too few; None without either."""
        if segments is None:
            segments = self.segments(until_ns)
        stamps = self.samples()[0]
        steps = np.diff(stamps)
        steps = steps[steps > 0]
        rate = 1e9 / float(np.median(steps)) if len(steps) else 1000.0
        learnt = learn_noise([x[len(x) // 2 :] for _, x in segments], rate)
        return learnt if learnt is not None else self.noise

    def reduced_windows(
        self,
        until_ns: int | None = None,
        noise: NoiseModel | None = None,
        segments: list[tuple[str, NDArray[np.float64]]] | None = None,
    ) -> tuple[dict[str, Window], list[Window], list[Window], list[str]]:
        """Every window of ``segments`` reduced to its mean with the sensor's ``noise``
        (default: ``noise_model``): (tare windows by pose, object windows, verify
        windows, notes on the windows refused: empty, motion, NaN, saturation)."""
        tares: dict[str, Window] = {}
        objects: list[Window] = []
        verifies: list[Window] = []
        notes: list[str] = []
        if segments is None:
            segments = self.segments(until_ns)
        if noise is None:
            noise = self.noise_model(until_ns, segments)
        for label, samples in segments:
            kind, pose = label.split("/", 1)
            if len(samples) == 0:
                notes.append(f"window {shorten(label)!r} has no samples")
                continue
            try:
                window = reduce_window(pose, samples, self.sensor, noise)
            except (WindowError, ValueError) as exc:
                notes.append(f"{kind} {exc}")
                continue
            if kind + "/" == TARE_PREFIX:
                tares[pose] = window
            elif kind + "/" == OBJECT_PREFIX:
                objects.append(window)
            else:
                verifies.append(window)
        return tares, objects, verifies, notes

    def solve(self, until_ns: int | None = None) -> Solution:
        """Windows, per-pose tare, estimate and consistency test, with a status."""
        notes = [f"dropped {n} samples {what}" for what, n in self.dropped.items()]
        notes += [f"dropped {n} labels {what}" for what, n in self.dropped_labels.items()]
        segments = self.segments(until_ns)
        counts = {label: len(samples) for label, samples in segments}
        noise = self.noise_model(until_ns, segments)
        if noise is not None and self.noise is not None and noise is not self.noise:
            changed = noise.changed_from(self.noise)
            notes += [changed] if changed else []
        fresh_tares, objects, verifies, refused = self.reduced_windows(until_ns, noise, segments)
        tares = dict(self.tares) | fresh_tares
        notes += refused
        try:
            if not segments:
                seen = ", ".join(sorted({shorten(lbl) for _, lbl in self._labels}))
                raise EstimationError(
                    f"no windows: no tare/ or object/ label before the end (labels seen: "
                    f"{shorten(seen or 'none', 200)})"
                )
            if not objects:
                seen = ", ".join(sorted({shorten(lbl) for _, lbl in self._labels}))
                raise EstimationError(
                    f"no object windows (labels seen: {shorten(seen or 'none', 200)})"
                )
            if self.untared:
                notes.append(
                    "no tare: the estimate is of the whole load beyond the sensor (hand + object)"
                )
            information = self._information(notes)
            try:  # the object windows minus the tare of their pose
                windows = objects if self.untared else subtract_tare(objects, tares.values())
            except MissingTareError:
                if information == WRENCHES:
                    raise
                windows = []  # the kinematic fit needs no tare per pose
            if windows and not self.untared and information == WRENCHES:
                _check_load_direction(windows, tares)  # the kinematic fit checks its own
            if information == WRENCHES:
                fit, wrenches_sigma = None, None
                estimate = self._wrenches_estimate(windows)
                tested = self.calibration.widened(windows) if self.calibration else windows
                consistency = check_consistency(tested, alpha=self.alpha, g=self.g)
                used = windows
            else:
                fit, observations = self._kinematic_fit(
                    objects, windows, fresh_tares, information, until_ns, notes
                )
                estimate = fit.estimate
                used = [o.window for o in observations if o.load]
                consistency = self._kinematic_consistency(fit, observations, information, windows)
                wrenches_sigma = self._wrenches_sigma(windows)
            verifications, unverified = self._verifications(verifies, fit, until_ns, notes)
        except EstimationError as exc:
            reason = str(exc) + ("; " + "; ".join(notes) if notes else "")
            return Solution(
                ERROR, reason, self.method, notes=tuple(notes), window_samples=counts, noise=noise
            )
        status, reason = OK, _summary(estimate)
        failed = [v.summary() for v in verifications if not v.passed]
        if not consistency.consistent:
            status, reason = WARN, consistency.message
        elif failed:
            status = WARN
            reason = "; ".join(failed) + ": the estimate does not hold beyond its poses"
        elif notes:
            status, reason = WARN, "; ".join(notes)
        return Solution(
            status,
            reason,
            self.method,
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
        )

    def _verifications(
        self,
        windows: list[Window],
        fit: KinematicFit | None,
        until_ns: int | None,
        notes: list[str],
    ) -> tuple[tuple[Verification, ...], str]:
        """The ``Verification`` of every verify window by the kinematic ``fit`` (at the
        window's orientation and time), and why the windows are not checked when they
        cannot be (the wrenches alone: no orientation at a pose no window saw, no bias
        nor hand model); a window without its orientation is noted (a WARN)."""
        if not windows:
            return (), ""
        if fit is None or fit.hand is None:
            return (), (
                "the wrench at a pose no fit used is predicted with information "
                "'kinematics' and the empty hand's windows only"
            )
        assert self.robot is not None
        out = []
        stamps = self.samples()[0]
        for window in windows:
            label = VERIFY_PREFIX + window.pose
            try:
                rotation = self.window_rotation(label, until_ns)
            except WindowError as exc:
                notes.append(f"verification left out: {exc}")
                continue
            time = self.window_time(label, stamps, until_ns)
            predicted, cov = fit.predict(rotation, time, measured=window.mean)
            out.append(verify(window, predicted, cov, self.alpha))
        return tuple(out), ""

    def _information(self, notes: list[str]) -> str:
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

    def _wrenches_estimate(self, windows: list[Window]) -> Estimate:
        """``method``'s estimate from the tare-subtracted ``windows``, its covariance with
        the calibration's share (``Calibration.propagated``)."""

        def fit(ws: list[Window]) -> Estimate:
            return METHODS[self.method](ws, g=self.g, min_tilt_sigmas=self.min_tilt_sigmas)

        estimate = fit(windows)
        if self.calibration is None:
            return estimate

        def numbers(ws: list[Window]) -> NDArray[np.float64]:
            e = fit(ws)
            return np.array([e.mass, *e.com])

        share = self.calibration.propagated(numbers, windows)
        return replace(estimate, cov=estimate.cov + share)

    def _wrenches_sigma(self, windows: list[Window]) -> NDArray[np.float64] | None:
        """For a kinematic fit, the COM sigma (m) the wrenches alone give on the same
        tare-subtracted ``windows`` (None when a pose has no tare or they give none)."""
        try:
            return ml(windows, g=self.g, min_tilt_sigmas=0.0).sigma_com if windows else None
        except EstimationError:
            return None

    def _kinematic_consistency(
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
        )
        loads = [o.window.pose for o in observations if o.load]
        if found is not None and chi2_sf(found[1], e.dof - 4) >= self.alpha:
            pose = loads[found[0]]
            message = (
                f"poses inconsistent ({head}): the object moved in the grasp at pose {pose!r}"
            )
            return Consistency(False, e.chi2, e.dof, e.p_value, self.alpha, pose, message)
        try:
            alone = (
                check_consistency(subtracted, alpha=self.alpha, g=self.g) if subtracted else None
            )
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

    def _kinematic_fit(
        self,
        objects: list[Window],
        subtracted: list[Window],
        fresh_tares: Mapping[str, Window],
        information: str,
        until_ns: int | None,
        notes: list[str],
    ) -> tuple[KinematicFit, list[Observation]]:
        """The hand, the bias and the object fitted to every window with its orientation
        (``known_gravity.kinematic_ml``): this run's empty-hand windows (its tare pass, or
        the window that checks a cached tare) share this run's bias, a cached tare pass
        has its own; a window without an orientation is left out, with the reason in
        ``notes``. A cached tare without joint positions cannot give the hand at other
        poses: the tare-subtracted windows (``subtracted``) are fitted, as the load alone.
        A bias drift beyond ``max_drift_f`` or ``max_drift_tau`` is noted (a WARN).
        Returns the fit and its observations."""
        assert self.robot is not None
        robot = self.robot
        observations: list[Observation] = []
        stamps = self.samples()[0]

        def add(
            window: Window,
            label: str,
            load: bool,
            epoch: int,
            cached: tuple[Mapping[str, float], float] | None = None,
        ) -> None:
            try:
                if cached is None:
                    rotation = self.window_rotation(label, until_ns)
                    time = self.window_time(label, stamps, until_ns)
                else:
                    rotation, time = robot.sensor_rotation(cached[0]), cached[1]
            except (WindowError, KinematicsError) as exc:
                notes.append(f"left out: {exc}")
                return
            observations.append(Observation(window, rotation, load, epoch, time))

        if not self.untared:
            for pose, window in fresh_tares.items():
                add(window, TARE_PREFIX + pose, False, 0)
            for pose, window in self.tares.items():
                if pose not in fresh_tares and pose in self.tare_joints:
                    cached = (self.tare_joints[pose], self.tare_times.get(pose, 0.0))
                    add(window, f"cached tare {pose!r}", False, 1, cached)
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
        fit = kinematic_ml(
            observations,
            robot.gravity,
            fit_mount=information == KINEMATICS_MOUNT,
            drift_rate_sigma=self.bias_drift_rate,
            calibration=self.calibration,
        )
        e = fit.estimate
        if not self.untared and e.mass < LOAD_SIGMAS * e.sigma_mass:
            raise NonPositiveMassError(
                f"no load beyond the hand ({e.mass * 1e3:.3g} +- {e.sigma_mass * 1e3:.2g} g): "
                "the object was not held (an empty grasp, or it fell)"
            )
        drift = fit.drift()[0]
        force, torque = float(np.linalg.norm(drift[:3])), float(np.linalg.norm(drift[3:]))
        if force > self.max_drift_f or torque > self.max_drift_tau:
            notes.append(
                f"the sensor's bias drifted {force:.3g} N, {torque:.3g} N m since the cached "
                f"tare (more than {self.max_drift_f:g} N or {self.max_drift_tau:g} N m): the "
                "fit absorbed it; re-tare"
            )
        return fit, observations


def vector_value(values: Mapping[str, str], key: str, scale: float = 1.0) -> list[float] | None:
    """A vector of ``Solution.diagnostic_values`` read back (its values comma-joined),
    times ``scale``; None when ``values`` has no ``key``."""
    text = values.get(key)
    return [float(v) * scale for v in text.split(",")] if text else None


def verification_lines(values: Mapping[str, str]) -> list[str]:
    """One line per verification pose of ``Solution.diagnostic_values`` read back: the
    mean compensated force (N) and torque (mN m) with their sigmas, and their distances
    from zero against what the noise allows."""
    lines = []
    for key in values:
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


def done_stamp(labels: Sequence[tuple[int, str]]) -> int | None:
    """Stamp of the first ``done`` that arrived after a window label, or None.

    ``labels`` in arrival order. A ``done`` with no window before it ends an earlier
    exploration (the latched label a late-joining subscriber or a recorder gets first),
    not this one; with a restarted clock its stamp could fall anywhere, so the order of
    arrival decides, not the stamp.
    """
    seen_window = False
    for stamp, label in labels:
        if label.startswith((TARE_PREFIX, OBJECT_PREFIX, VERIFY_PREFIX)):
            seen_window = True
        elif label == DONE and seen_window:
            return stamp
    return None


def _check_load_direction(windows: Sequence[Window], tares: Mapping[str, Window]) -> None:
    """The object's force must point the way the hand's does (both are gravity), and be
    more than ``LOAD_SIGMAS`` sigma of its own noise along it.

    No load along gravity: the object was not held (an empty grasp, or it fell). A load
    against gravity: a mass below zero, the tare was taken with the object in the hand.
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
    c, s = e.com * 1e3, e.sigma_com * 1e3
    return (
        f"mass {e.mass * 1e3:.2f} +- {e.sigma_mass * 1e3:.2f} g, COM ({c[0]:.2f}, "
        f"{c[1]:.2f}, {c[2]:.2f}) +- ({s[0]:.2f}, {s[1]:.2f}, {s[2]:.2f}) mm "
        f"from {len(e.poses)} poses"
    )


def shorten(text: str, limit: int = 40) -> str:
    """``text`` cut to ``limit`` characters, with the number of characters left out."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit} more characters)"


def format_solution(solution: Solution) -> str:
    """One line for logs and the command line."""
    name = solution.method
    if solution.information != WRENCHES:
        name += f" ({solution.information})"
    return f"[{solution.status}] {name}: {solution.reason}" + (
        ""
        if solution.estimate is None or solution.status == OK
        else f" | {_summary(solution.estimate)}"
    )
