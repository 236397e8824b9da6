"""Mass, COM and the sensor's bias from any recording: wrenches and the sensor's
orientation, without pose labels, whatever the bias.

A recording is the sensor's wrenches w_k (N, N m, sensor frame, stamped t_k s) and, at
each, R_k = R_base_sensor: from joint states through the robot's kinematics
(``recording_from_joint_states``) or as logged (``recording_from_orientations``; CSV and
NumPy logs: ``read_recording_file``). Its model is the ft_calib one, the kinematic fit's
(``known_gravity``, with every window an empty-hand one: the whole load on the sensor):

    w_k = b + r (t_k - t_mean) + D_k theta + e_k,     theta = (m, c), c = m p,

b the bias, r its drift rate (a Gaussian prior of the sensor's drift specification,
``BIAS_DRIFT_RATE``), e_k the noise and D_k (6, 4) the wrench per unit of theta: A(g_k)
at rest (the paper's eqs. (1)-(2): f = m g, tau = c x g) and, with joint states, m and
c's columns of the motion's regressor (``robot.dynamics``: the load's inertial forces
from the joint velocities and accelerations, Savitzky-Golay differentiated,
``motion.joint_motion``).

1. **Rests.** Where the sensor turns slower than ``REST_SPEED`` for ``MIN_REST`` s or
   more; each rest starts once its ringing has settled (``windows.settled_start``).
2. **Noise, learnt from the recording.** The rests' samples, each less its own mean
   (``sensing.noise.learn_noise``: an AR model per axis); without enough rest, the
   residuals of a first fit, said so.
3. **Windows.** Each rest is one window; the motion between rests is cut into windows
   of ``BLOCK`` s. A window's mean has the noise model's covariance for its length, and
   its design is the mean of its samples' D_k (the model is linear: the mean of the
   wrenches is D theta at the mean design, exactly). What D leaves out is the load's
   rotational inertia. With joint states its wrench is known per unit of the inertia
   (``robot.dynamics``' last six columns): the inertia is an unknown every window
   shares, marginalised (``Observation.nuisance``: its prior mean the first fit's
   parallel-axis term, ``origin_inertia``, its spread m a^2 per element,
   ``inertia_variance``), so its torque is weighed as one error common to the windows,
   not as each window's own (which would let a systematic torque pull the COM: 2.5 sigma
   along the hanging axis in sim recordings with a perfect calibration). Without joint
   states (and the sensor's linear acceleration unknown too) it is bounded per window
   (``inertia_bound``) and weighed as a uniform error of that bound. A window whose
   bound is ``TOO_FAST`` times its noise is left out, and counted.
4. **The fit.** ``kinematic_ml`` with the calibration's common error on the load's
   wrench (the bias, which the calibration does not scale, taken off: a first fit gives
   it). The wrenches' delay behind the orientations (a sensor's filter, the transport) is
   the one that minimises its chi^2 (``motion.best_delay``: +-30 ms on a ``DELAY_STEP``
   grid; the calibration's misfit weighed too, or it would pull the delay), each window's
   design taken that much earlier (to first order, its rate of change). The covariance
   is the Cramer-Rao bound at that delay, plus the delay's own share (its sigma from the
   chi^2's curvature, times how far the fit moves with it: ``_delay_spread``), widened by
   chi^2 / dof when the residual is larger than the noise and the calibration explain.
   With a tare recording (the empty tool) its windows are fitted beside (another bias
   epoch): the object alone comes out, else the whole load beyond the sensor, said so.
   With joint states, what the fit leaves in the windows in motion gives the load's
   inertia (``_inertia``), published where the motion excites it.
5. **What the recording could not tell** (``RecordingFit.status``): a load that changed
   (the likelihood ratio of a second load from some window on, over ``CHANGE_SPLITS``
   places, at ``CHANGE_ALPHA``, scaled by the misfit the self-check sees, and large
   enough to matter: ``CHANGE_MASS``, ``CHANGE_SHIFT``: ERROR), gravity directions that
   do not resolve the fit (ERROR), that barely turned or all lie on one circle
   (rotations about one axis), or leave the COM's worst direction far behind its best
   (each WARN, naming the COM's sigma along its worst direction), a bias drift beyond
   its prior (WARN), windows left out for their motion (WARN past a quarter).
6. **Self-check.** The fit on the first half (in time) predicts the second, and the
   second the first: per axis the rms residual (N, N m) and its rms in sigmas of the
   prediction's and the window's covariance together (1 where the model holds).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.contract import ERROR, OK, WARN
from com_core.estimation.fits.errors import NonPositiveMassError, TooFewPosesError
from com_core.estimation.fits.estimators import Estimate
from com_core.estimation.fits.known_gravity import (
    BIAS_DRIFT_RATE,
    KinematicFit,
    Observation,
    kinematic_ml,
)
from com_core.estimation.fits.motion import MAX_DELAY, best_delay, principal_moments
from com_core.estimation.fits.stats import chi2_isf
from com_core.estimation.fits.windows import settled_start, window_from_mean
from com_core.estimation.recordings.recording import Recording
from com_core.robot.dynamics import load_of
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.calibration import Calibration
from com_core.sensing.noise import NoiseModel, learn_noise, white_noise

__all__ = [
    "BLOCK",
    "MIN_REST",
    "REST_SPEED",
    "LoadChange",
    "RecordingFit",
    "SelfCheck",
    "fit_recording",
    "inertia_bound",
]

REST_SPEED = 0.005
"""rad/s: the sensor turns slower than this at rest."""
MIN_REST = 0.3
"""s: the shortest rest kept as one window (before its ringing is cut off)."""
BLOCK = 0.5
"""s: the length of the windows the motion between rests is cut into."""
REACH = 0.5
"""m: how far the sensor's origin may lie from the axes it turns about, for a recording
without joint states (its linear acceleration unknown, ``inertia_bound``)."""
DELAY_STEP = 6e-3
"""s: the delay search's grid (a parabola through its three best points refines it; chi^2
is a parabola in the delay where the designs change linearly, to first order)."""
CHANGE_SPLITS = 12
"""Places (quantiles of the windows in time) a change of load is looked for at."""
CHANGE_ALPHA = 1e-3
"""False-alarm rate of the load-change test over all its places."""
CHANGE_SHIFT = 1e-3
"""m: a change of load that leaves the mass within its noise must move the COM this far to
be named (a grasp that flexes by less is one load to the user)."""
CHANGE_MASS = 0.01
"""A change of mass under this fraction of the load is not named (the two parts of a
recording see other orientations, so a sensor's calibration error moves their masses
apart by a few tenths of a percent: 2.2 g of 1.2 kg, 3 sigma, in 1 of 50 sim recordings
of bench/recording.py)."""
ONE_AXIS = math.radians(0.1)
"""rad: gravity directions (unit) spread less than this off one plane lie on one circle:
the wrist turned about one axis (a cap of directions deviates from its plane by its
curvature, 1 - cos of its radius: more than this past 5 deg)."""
MIN_SPAN = math.radians(2.0)
"""rad: gravity directions spread less than this (1 sigma) barely tell load from bias."""
WEAK_DIRECTION = 5.0
WEAK_SIGMA = 1e-3
"""A COM direction whose sigma exceeds the best resolved one's ``WEAK_DIRECTION`` times and
``WEAK_SIGMA`` (m) is named."""
TOO_FAST = 10.0
"""A window in motion whose ``inertia_bound`` exceeds its noise this many times on every
axis is left out."""
LEFT_OUT_SHARE = 0.25
"""Of the motion's windows: left out for their motion beyond this share is a warning."""


@dataclass(frozen=True)
class SelfCheck:
    """Each half of the recording (in time) predicting the other: per axis the rms
    residual (6,; N, N m) and its rms in sigmas (6,), over ``windows`` windows."""

    rms: NDArray[np.float64]
    sigmas: NDArray[np.float64]
    windows: int

    def summary(self) -> str:
        f, t = self.rms[:3], self.rms[3:]
        return (
            f"self-check (each half predicts the other, {self.windows} windows): rms "
            f"residual f {_triple(f * 1e3)} mN, tau {_triple(t * 1e3)} mN m; in sigmas "
            f"{_triple(self.sigmas, '.2f')} (1 where the model holds)"
        )


@dataclass(frozen=True)
class LoadChange:
    """The likeliest change of load: at ``time`` (s), by ``mass`` (kg) with its sigma and
    the COM by ``shift`` (m), the likelihood ratio ``statistic`` against ``threshold``."""

    time: float
    mass: float
    sigma_mass: float
    shift: float
    statistic: float
    threshold: float
    load: float = 0.0

    @property
    def found(self) -> bool:
        """Significant, and large enough to matter: the mass by 3 sigma and
        ``CHANGE_MASS`` of the ``load`` (kg) before, or the COM by ``CHANGE_SHIFT``."""
        floor = max(3 * self.sigma_mass, CHANGE_MASS * abs(self.load))
        large = abs(self.mass) > floor or self.shift > CHANGE_SHIFT
        return self.statistic > self.threshold and large


@dataclass(frozen=True)
class RecordingFit:
    """The estimate of a recording and what it could not tell (module).

    estimate : the object's mass and COM with a tare recording, else the whole load's
        (``whole_load``); cov the CRLB widened by chi^2/dof (``widened``). None on ERROR.
    bias : (6,) the sensor's bias (N, N m) at the middle of the recording, ``bias_sigma``
        its sigma; ``drift`` (6,) how much it moved over the recording, ``drift_sigma``.
    noise : the noise model learnt (``noise_from``: where from).
    delay : s, how much later the wrenches are stamped than the orientations (estimated),
        ``delay_sigma`` its sigma (its share is in every covariance above).
    inertia : (3, 3) the whole load's inertia about its COM (kg m^2, sensor axes) where the
        motion excites it (``_inertia``), its principal ``moments`` (3,) and their
        ``moments_sigma``; None where it does not (a note says why).
    """

    status: str
    reason: str
    estimate: Estimate | None = None
    whole_load: bool = True
    bias: NDArray[np.float64] | None = None
    bias_sigma: NDArray[np.float64] | None = None
    drift: NDArray[np.float64] | None = None
    drift_sigma: NDArray[np.float64] | None = None
    widened: float = 1.0
    rests: int = 0
    windows: int = 0
    left_out: int = 0
    samples: int = 0
    duration: float = 0.0
    noise: NoiseModel | None = None
    noise_from: str = ""
    delay: float = 0.0
    delay_sigma: float = 0.0
    inertia: NDArray[np.float64] | None = None
    moments: NDArray[np.float64] | None = None
    moments_sigma: NDArray[np.float64] | None = None
    check: SelfCheck | None = None
    change: LoadChange | None = None
    notes: tuple[str, ...] = ()
    fit: KinematicFit | None = None

    def summary(self) -> str:
        """Lines for the command line: status and reason, the estimate, the bias, the
        self-check, the notes."""
        lines = [f"[{self.status}] recording: {self.reason}"]
        e = self.estimate
        if e is not None:
            what = "the whole load on the sensor" if self.whole_load else "the object"
            lines.append(
                f"{what}: mass {e.mass * 1e3:.2f} +- {e.sigma_mass * 1e3:.2f} g, COM "
                f"{_triple(e.com * 1e3)} +- {_triple(e.sigma_com * 1e3)} mm (sensor frame)"
            )
        if self.bias is not None and self.bias_sigma is not None:
            lines.append(
                f"bias f {_triple(self.bias[:3])} +- {_triple(self.bias_sigma[:3], '.3f')} N, "
                f"tau {_triple(self.bias[3:] * 1e3)} +- "
                f"{_triple(self.bias_sigma[3:] * 1e3, '.2f')} mN m"
            )
        lines.append(
            f"{self.samples} samples over {self.duration:.1f} s: {self.rests} rests and "
            f"{self.windows - self.rests} windows in motion used, {self.left_out} left out; "
            f"noise from {self.noise_from}; wrenches {self.delay * 1e3:.1f} +- "
            f"{self.delay_sigma * 1e3:.1f} ms behind the orientations"
        )
        if self.moments is not None and self.moments_sigma is not None:
            lines.append(
                f"inertia about the COM: principal moments {_triple(self.moments * 1e4)} +- "
                f"{_triple(self.moments_sigma * 1e4)} kg cm^2"
            )
        if self.check is not None:
            lines.append(self.check.summary())
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """JSON-ready: status, reason, the estimate (kg, m, sensor frame), the bias and its
        drift (N, N m), the self-check, the counts and the notes."""
        out: dict = {
            "status": self.status,
            "reason": self.reason,
            "whole_load": self.whole_load,
            "rests": self.rests,
            "windows": self.windows,
            "left_out": self.left_out,
            "samples": self.samples,
            "duration": self.duration,
            "noise_from": self.noise_from,
            "delay": self.delay,
            "delay_sigma": self.delay_sigma,
            "widened": self.widened,
            "notes": list(self.notes),
        }
        if (e := self.estimate) is not None:
            out |= {
                "mass": e.mass,
                "com": e.com.tolist(),
                "sigma_mass": e.sigma_mass,
                "sigma_com": e.sigma_com.tolist(),
                "cov": e.cov.ravel().tolist(),
                "chi2": e.chi2,
                "dof": e.dof,
            }
        for name in (
            "bias",
            "bias_sigma",
            "drift",
            "drift_sigma",
            "inertia",
            "moments",
            "moments_sigma",
        ):
            if (value := getattr(self, name)) is not None:
                out[name] = value.tolist()
        if self.check is not None:
            out["check_rms"] = self.check.rms.tolist()
            out["check_sigmas"] = self.check.sigmas.tolist()
        if self.change is not None:
            out["change"] = {
                "time": self.change.time,
                "mass": self.change.mass,
                "sigma_mass": self.change.sigma_mass,
                "shift": self.change.shift,
                "statistic": self.change.statistic,
                "threshold": self.change.threshold,
            }
        return out


def _triple(v: ArrayLike, fmt: str = ".2f") -> str:
    return "(" + ", ".join(format(float(x), fmt) for x in np.asarray(v)) + ")"


# ---------------------------------------------------------------------------- windows


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, stop) of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _rests(recording: Recording) -> list[tuple[int, int]]:
    """[start, stop) of each rest: slower than ``REST_SPEED`` for ``MIN_REST`` s."""
    t = recording.times
    return [(a, b) for a, b in _runs(recording.omega < REST_SPEED) if t[b - 1] - t[a] >= MIN_REST]


def _learn_noise(parts: Sequence[tuple[Recording, list[tuple[int, int]]]]) -> NoiseModel | None:
    """The noise of the rests of each (recording, its rests), each rest from where its
    ringing settled (a first model from their second halves says where); None without
    enough rest."""
    rate = 1.0 / float(np.median(np.diff(parts[0][0].times)))
    first = learn_noise(
        [r.wrenches[(a + b) // 2 : b] for r, rests in parts for a, b in rests], rate
    )
    if first is None:
        return None
    return learn_noise(
        [
            r.wrenches[a + settled_start(r.wrenches[a:b], first) : b]
            for r, rests in parts
            for a, b in rests
        ],
        rate,
    )


@dataclass(frozen=True)
class _Block:
    start: int
    stop: int
    rest: bool


def _blocks(recording: Recording, rests: list[tuple[int, int]], noise: NoiseModel) -> list[_Block]:
    """The rests (from where they settled) and the motion between cut into ``BLOCK`` s
    windows (a gap in the stamps of 3 periods ends one)."""
    t, w = recording.times, recording.wrenches
    period = float(np.median(np.diff(t)))
    per_block = max(2, round(BLOCK / period))
    out, moving = [], np.ones(len(t), dtype=bool)
    for a, b in rests:
        out.append(_Block(a + settled_start(w[a:b], noise), b, True))
        moving[a:b] = False
    gaps = np.flatnonzero(np.diff(t) > 3 * period) + 1
    for a, b in _runs(moving):
        cuts = [a, *[g for g in gaps if a < g < b], b]
        for lo, hi in itertools.pairwise(cuts):
            n_blocks = max(1, (hi - lo) // per_block)
            edges = np.linspace(lo, hi, n_blocks + 1).round().astype(int)
            out += [
                _Block(int(x), int(y), False) for x, y in itertools.pairwise(edges) if y - x >= 2
            ]
    return sorted(out, key=lambda block: block.start)


def inertia_bound(recording: Recording, block: _Block, mass: float, com: NDArray) -> NDArray:
    """(6,) N, N m: what the motion over ``block`` could add to its mean wrench beyond the
    designs, for a load of ``mass`` (kg) and COM ``com`` (m): the rotational inertia's
    torque (I (|alpha| + |omega|^2), I = m max(|p|, 5 cm)^2) and, without joint states, the
    inertial force of the sensor's unknown linear acceleration (m ``REACH`` (|alpha| +
    |omega|^2)) and its torque about the COM."""
    s = slice(block.start, block.stop)
    rate = float(np.mean(recording.alpha[s] + recording.omega[s] ** 2))
    arm = max(float(np.linalg.norm(com)), 0.05)
    torque = mass * arm**2 * rate
    force = 0.0 if recording.dynamic else mass * REACH * rate
    return np.array([force] * 3 + [torque + force * arm] * 3)


def _observations(
    recording: Recording,
    blocks: Sequence[_Block],
    mean_cov: Callable[[int], NDArray[np.float64]],
    load: bool,
    epoch: int,
    inertia: tuple[float, NDArray[np.float64]] | None = None,
    delay: float = 0.0,
    rates: NDArray[np.float64] | None = None,
    parts: int = 1,
) -> list[Observation]:
    """The windows of ``blocks`` (``mean_cov(n)``: the noise's covariance of the mean of
    n samples, ``NoiseModel.mean_cov``), their designs those of ``delay`` s earlier (the
    wrenches stamped that much later than the orientations; first order, with the
    designs' ``rates``). With ``inertia`` (mass kg, COM m), what the designs leave out:
    with joint states, the load's inertia about the sensor origin, a nuisance of this
    recording's (``Observation.nuisance``: columns 6 ``epoch`` on of 6 ``parts``) whose
    prior mean, the COM's parallel-axis term (``origin_inertia``), is taken off each
    window's mean; without, each window's ``inertia_bound`` as a uniform error's variance
    (bound^2 / 3)."""
    w, t = recording.wrenches, recording.times
    dynamic = inertia is not None and recording.inertia_designs is not None
    out = []
    for k, b in enumerate(blocks):
        s = slice(b.start, b.stop)
        middle = (b.start + b.stop) // 2
        cov, mean, nuisance = mean_cov(b.stop - b.start), w[s].mean(axis=0), None
        if dynamic:
            part = recording.inertia_designs[s].mean(axis=0)  # type: ignore[index]
            mean = mean - part @ origin_inertia(*inertia)  # type: ignore[misc]
            nuisance = np.zeros((6, 6 * parts))
            nuisance[:, 6 * epoch : 6 * epoch + 6] = part
        elif inertia is not None and not b.rest:
            cov = cov + np.diag(inertia_bound(recording, b, *inertia) ** 2 / 3.0)
        name = f"{'rest' if b.rest else 'motion'} {k} at {t[middle]:.2f} s"
        window = window_from_mean(name, mean, cov, b.stop - b.start)
        out.append(
            Observation(
                window,
                recording.rotations[middle],
                load,
                epoch,
                float(t[s].mean()),
                design=recording.designs[s].mean(axis=0)
                - (delay * rates[s].mean(axis=0) if rates is not None else 0.0),
                nuisance=nuisance,
            )
        )
    return out


def _loads(
    first: KinematicFit, recording: Recording, tare: Recording | None
) -> dict[int, tuple[float, NDArray[np.float64]]]:
    """(mass kg, COM m) of the whole load each recording's sensor held, by recording, from
    a ``first`` fit: without a tare recording its estimate, with one the hand and the
    object together for the recording and the hand for the tare."""
    e, hand = first.estimate, first.hand
    if tare is None or hand is None:
        return {id(recording): (abs(e.mass), e.com)}
    mass = hand.mass + e.mass
    whole = (abs(mass), (hand.mass * hand.com + e.mass * e.com) / mass)
    return {id(recording): whole, id(tare): (abs(hand.mass), hand.com)}


def origin_inertia(mass: float, com: NDArray[np.float64]) -> NDArray[np.float64]:
    """(6,) kg m^2: the inertia about the sensor origin of a point ``mass`` (kg) at ``com``
    (m), m (|c|^2 I - c c^T), as ``robot.dynamics`` orders it (xx, xy, yy, xz, yz, zz)."""
    c = np.asarray(com, dtype=np.float64)
    full = mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return full[[0, 0, 1, 0, 1, 2], [0, 1, 1, 2, 2, 2]]


def inertia_variance(mass: float, com: NDArray[np.float64]) -> float:
    """(kg m^2)^2: the prior variance of each element of the load's inertia about its COM
    (its departure from ``origin_inertia``): m a^2 at one sigma, a = max(|c|, 5 cm), the
    scale ``inertia_bound`` takes."""
    arm = max(float(np.linalg.norm(com)), 0.05)
    return (abs(mass) * arm**2) ** 2


# ---------------------------------------------------------------------------- the fit


@dataclass
class _Setup:
    """What every fit of one recording shares."""

    gravity: NDArray[np.float64]
    calibration: Calibration | None
    drift_rate_sigma: tuple[float, float]
    uncalibrated: NDArray[np.float64] | None = None
    nuisance_cov: NDArray[np.float64] | None = None

    def fit(
        self,
        observations: Sequence[Observation],
        positive: bool = True,
        whitening: NDArray[np.float64] | None = None,
    ) -> KinematicFit:
        return kinematic_ml(
            observations,
            self.gravity,
            drift_rate_sigma=self.drift_rate_sigma,
            calibration=self.calibration,
            uncalibrated=self.uncalibrated,
            positive_object=positive,
            whitening=whitening,
            nuisance_cov=self.nuisance_cov,
        )


def fit_recording(
    recording: Recording,
    tare: Recording | None = None,
    calibration: Calibration | None = None,
    gravity: ArrayLike = DEFAULT_GRAVITY,
    drift_rate_sigma: tuple[float, float] = BIAS_DRIFT_RATE,
    motion: bool = True,
) -> RecordingFit:
    """Mass, COM and the bias of ``recording`` (module); with ``tare``, a recording of the
    empty tool, the object alone. ``calibration``: the sensor's stated accuracy (None:
    perfect); ``gravity`` m/s^2 in the base frame; ``drift_rate_sigma`` (N/s, N m/s) the
    bias drift's prior; ``motion`` False: the rests alone (the static fit, as a
    reference). Never raises for what a recording holds: ERROR with the reason."""
    parts = [(recording, True)] + ([(tare, False)] if tare is not None else [])
    samples = sum(len(r.times) for r, _ in parts)
    duration = float(recording.times[-1] - recording.times[0]) if len(recording.times) else 0.0
    base = RecordingFit(
        ERROR,
        "",
        samples=samples,
        duration=duration,
        notes=tuple(n for r, _ in parts for n in r.notes),
    )
    if any(len(r.times) < 100 for r, _ in parts):
        return replace(base, reason="fewer than 100 samples")
    rests = {id(r): _rests(r) for r, _ in parts}
    middle = float(recording.times[0] + recording.times[-1]) / 2
    setup = _Setup(np.asarray(gravity, dtype=np.float64).reshape(3), None, drift_rate_sigma)
    noise = _learn_noise([(r, rests[id(r)]) for r, _ in parts])
    noise_from = f"{sum(map(len, rests.values()))} rests"
    if noise is None:
        noise = _residual_noise(recording, setup)
        noise_from = "the residual of a first fit (too little rest)"
    blocks = {
        id(r): [b for b in _blocks(r, rests[id(r)], noise) if motion or b.rest] for r, _ in parts
    }
    with_object = tare is not None

    rates = {id(r): r.rates for r, _ in parts}
    mean_cov = functools.lru_cache(maxsize=None)(noise.mean_cov)  # per window length

    def observations(
        kept: dict[int, list[_Block]], is_object: bool, loads=None, delay: float = 0.0
    ) -> list[Observation]:
        """The windows of the recording (``is_object``) or of the tare recording, with
        ``loads`` (by recording: mass kg, COM m) what their inertia scales with."""
        return [
            o
            for k, (r, obj) in enumerate(parts)
            if obj == is_object
            for o in _observations(
                r,
                kept[id(r)],
                mean_cov,
                obj and with_object,
                k,
                None if loads is None else loads[id(r)],
                delay,
                rates[id(r)],
                len(parts),
            )
        ]

    def both(kept: dict[int, list[_Block]], load=None, delay: float = 0.0):
        """(the recording's windows, the tare recording's)."""
        return observations(kept, True, load, delay), observations(kept, False, load, delay)

    def every(kept: dict[int, list[_Block]], load=None, delay: float = 0.0) -> list[Observation]:
        """``both`` in one list: the windows of a fit."""
        loaded, empty = both(kept, load, delay)
        return loaded + empty

    try:
        first = setup.fit(every(blocks))
        if calibration is not None:  # on the load's wrench: less the bias a first fit gives
            setup.uncalibrated, setup.calibration = first.bias[0], calibration
            first = setup.fit(every(blocks))
        if motion:  # the delay's windows differ in their designs only: the same whitening

            def chi2_at(delay: float) -> float:
                fit = setup.fit(every(blocks, None, delay), whitening=first.whitening)
                return fit.estimate.chi2

            delay = best_delay(chi2_at, DELAY_STEP)
            first = setup.fit(every(blocks, None, delay), whitening=first.whitening)
        else:
            delay = 0.0
        load = _loads(first, recording, tare)  # what the inertia scales with
        variances = [inertia_variance(*load[id(r)]) for r, _ in parts]
        setup.nuisance_cov = np.diag(np.repeat(variances, 6))  # each recording's inertia
        kept = {
            key: [b for b in bs if b.rest or not _too_fast(r, b, noise, *load[key])]
            for (r, _), (key, bs) in zip(parts, blocks.items(), strict=True)
        }
        obs, fixed = both(kept, load, delay)
        fit = setup.fit(obs + fixed)
        spread = (
            _delay_spread(setup, fit, lambda d: every(kept, load, d), delay, middle)
            if motion
            else _DelaySpread(0.0, np.zeros(4), np.zeros(6), np.zeros(6))
        )
    except TooFewPosesError as error:
        return replace(base, reason=f"the orientations do not resolve the load: {error}")
    except NonPositiveMassError as error:
        return replace(base, reason=f"no load on the sensor: {error}")
    moving = sum(not b.rest for bs in blocks.values() for b in bs)
    left_out = sum(len(blocks[k]) - len(kept[k]) for k in blocks)
    n_rests = sum(b.rest for bs in kept.values() for b in bs)
    e = fit.estimate
    widened = max(1.0, e.chi2 / e.dof) if e.dof > 0 else 1.0
    delay_var = spread.sigma**2
    estimate = replace(e, cov=(e.cov + delay_var * np.outer(spread.load, spread.load)) * widened)
    bias, bias_cov = fit.bias_at(middle)
    bias_sigma = np.sqrt((np.diag(bias_cov) + delay_var * spread.bias**2) * widened)
    span = recording.times[-1] - recording.times[0]
    drift = fit.bias_rate[0] * span
    rate_cov = np.diag(fit.cov)[6:12] if max(drift_rate_sigma) > 0 else np.zeros(6)
    rate_cov = rate_cov + delay_var * spread.rate**2
    drift_sigma = np.sqrt(rate_cov * widened) * span  # the rate follows the bias (stride 12)
    out = replace(
        base,
        status=OK,
        estimate=estimate,
        whole_load=not with_object,
        bias=bias,
        bias_sigma=bias_sigma,
        drift=drift,
        drift_sigma=drift_sigma,
        widened=widened,
        rests=n_rests,
        windows=len(obs) + len(fixed),
        left_out=left_out,
        noise=noise,
        noise_from=noise_from,
        delay=delay,
        delay_sigma=spread.sigma * np.sqrt(widened),
        fit=fit,
    )
    warnings, errors = [], []
    if recording.inertia_designs is not None and not with_object:
        inertia, why = _inertia(recording, kept[id(recording)], fit, noise, widened)
        out = replace(out, **inertia)
        notes_extra = [why] if why else []
    else:
        notes_extra = []
    check = _self_check(setup, obs, fixed)
    misfit = float(np.mean(check.sigmas**2)) if check is not None else 1.0
    change = _load_change(setup, obs, fit, misfit) if not with_object else None
    if change is not None and change.found:
        errors.append(
            f"the load changed at {change.time:.1f} s by {change.mass * 1e3:+.1f} +- "
            f"{change.sigma_mass * 1e3:.1f} g and its COM by {change.shift * 1e3:.1f} mm "
            f"(likelihood ratio {change.statistic:.0f}, "
            f"allowed {change.threshold:.0f}): two loads, not one; fit each part on its own"
        )
    warnings += _geometry(recording, kept[id(recording)], estimate)
    rate_limit = 3 * np.repeat(np.asarray(drift_rate_sigma, dtype=float), 3) * span
    if np.any(np.abs(drift) > rate_limit):
        warnings.append(
            f"the bias drifted f {_triple(drift[:3], '.3f')} N, tau "
            f"{_triple(drift[3:] * 1e3)} mN m over the recording: beyond 3x the drift "
            "its prior allows"
        )
    if moving and left_out > LEFT_OUT_SHARE * moving:
        warnings.append(
            f"{left_out} of {moving} windows in motion left out: the motion is too fast for "
            "the load's inertia to be left out of them"
        )
    notes = list(base.notes) + notes_extra
    if not with_object:
        notes.append("no tare recording: the estimate is the whole load beyond the sensor")
    if check is None:
        notes.append("no self-check: a half of the recording does not resolve the fit alone")
    status = ERROR if errors else WARN if warnings else OK
    reason = "; ".join(errors + warnings) or (
        f"{e.mass * 1e3:.1f} g from {n_rests} rests and {out.windows - n_rests} windows in motion"
    )
    return replace(
        out,
        status=status,
        reason=reason,
        check=check,
        change=change,
        estimate=None if errors else estimate,
        notes=tuple(notes),
    )


@dataclass(frozen=True)
class _DelaySpread:
    """What the delay's uncertainty adds: its ``sigma`` (s) and the derivatives by the
    delay (per s) of the ``load``'s (mass, COM) (4,), the ``bias`` (6,) and its ``rate``
    (6,)."""

    sigma: float
    load: NDArray[np.float64]
    bias: NDArray[np.float64]
    rate: NDArray[np.float64]


def _delay_spread(
    setup: _Setup,
    fit: KinematicFit,
    at: Callable[[float], list[Observation]],
    delay: float,
    middle: float,
) -> _DelaySpread:
    """The delay's sigma from the curvature of the fit's chi^2 in it (chi^2 grows by 1 at
    one sigma; the search range's uniform sigma where it does not grow), and what the fit
    moves by per second of it, from the fits ``DELAY_STEP`` / 2 to either side of
    ``delay`` (s; ``at``: the windows at a delay, in ``fit``'s order); the bias at
    ``middle`` (s)."""
    h = DELAY_STEP / 2
    plus, minus = (setup.fit(at(delay + s), whitening=fit.whitening) for s in (h, -h))
    curvature = plus.estimate.chi2 + minus.estimate.chi2 - 2 * fit.estimate.chi2
    searched = 2 * MAX_DELAY / math.sqrt(12)
    sigma = min(math.sqrt(2.0 * h * h / curvature), searched) if curvature > 0 else searched

    def load(f: KinematicFit) -> NDArray[np.float64]:
        return np.array([f.estimate.mass, *f.estimate.com])

    return _DelaySpread(
        sigma,
        (load(plus) - load(minus)) / (2 * h),
        (plus.bias_at(middle)[0] - minus.bias_at(middle)[0]) / (2 * h),
        (plus.bias_rate[0] - minus.bias_rate[0]) / (2 * h),
    )


def _inertia(
    recording: Recording,
    blocks: Sequence[_Block],
    fit: KinematicFit,
    noise: NoiseModel,
    widened: float,
) -> tuple[dict, str]:
    """The whole load's inertia from what the fit of (m, c) leaves in the windows in
    motion: weighted least squares of the windows' mean residuals on the mean of their
    inertia designs, each window weighed by its noise (``RecordingFit`` fields, '') where
    every principal moment exceeds 3 sigma and they make a body (the triangle inequality);
    else ({}, why)."""
    assert recording.inertia_designs is not None
    info, rhs = np.zeros((6, 6)), np.zeros(6)
    for b in blocks:
        if b.rest:
            continue
        s = slice(b.start, b.stop)
        predicted = fit.wrenches(recording.designs[s], recording.times[s], load=False)
        residual = (recording.wrenches[s] - predicted).mean(axis=0)
        design = recording.inertia_designs[s].mean(axis=0)
        weight = np.linalg.inv(noise.mean_cov(b.stop - b.start))
        info += design.T @ weight @ design
        rhs += design.T @ weight @ residual
    if not np.all(np.isfinite(info)) or np.linalg.cond(info) > 1e12:
        return {}, "the inertia: the motion does not excite it"
    cov_origin = np.linalg.inv(info) * widened
    load = fit.estimate
    pi = np.concatenate([[load.mass], load.mass * load.com, np.linalg.solve(info, rhs)])
    _, _, inertia = load_of(pi)
    order = [0, 1, 3, 2, 4, 5]  # pinocchio's (xx, xy, yy, xz, yz, zz) as INERTIA_ELEMENTS
    moments, sigma = principal_moments(inertia, cov_origin[np.ix_(order, order)])
    found = f"principal moments {_triple(moments * 1e4)} +- {_triple(sigma * 1e4)} kg cm^2"
    body = moments[0] > 0 and moments[0] + moments[1] >= moments[2]  # the triangle
    if not body and np.any(np.abs(moments) > 3 * sigma):  # what is left is another misfit
        return {}, (
            f"the inertia: not published, what the motion leaves is no body's ({found}): "
            "another misfit (the calibration's error) outweighs the inertia's"
        )
    if not np.all(moments > 3 * sigma):
        return {}, f"the inertia: not published, the motion excites it too little ({found})"
    return {"inertia": inertia, "moments": moments, "moments_sigma": sigma}, ""


def _too_fast(
    recording: Recording, block: _Block, noise: NoiseModel, mass: float, com: NDArray
) -> bool:
    """Whether ``inertia_bound`` exceeds ``TOO_FAST`` times the block's noise on every
    axis: a window that would tell next to nothing."""
    sigma = np.sqrt(np.diag(noise.mean_cov(block.stop - block.start)))
    return bool(np.all(inertia_bound(recording, block, abs(mass), com) > TOO_FAST * sigma))


def _residual_noise(recording: Recording, setup: _Setup) -> NoiseModel:
    """The noise of the residual of a first fit on ``BLOCK`` s windows weighed with a
    white guess (the spread of the sample-to-sample differences)."""
    rate = 1.0 / float(np.median(np.diff(recording.times)))
    guess = white_noise(np.diag(np.var(np.diff(recording.wrenches, axis=0), axis=0) / 2), rate)
    blocks = _blocks(recording, [], guess)
    fit = setup.fit(_observations(recording, blocks, guess.mean_cov, False, 0))
    residual = recording.wrenches - fit.wrenches(recording.designs, recording.times)
    learnt = learn_noise([residual[b.start : b.stop] for b in blocks], rate, min_samples=50)
    return learnt or guess


def _load_change(
    setup: _Setup, obs: list[Observation], fit: KinematicFit, misfit: float
) -> LoadChange | None:
    """The likeliest change of load: a second load from one of ``CHANGE_SPLITS`` places on
    (windows in time order), its likelihood ratio scaled by the larger of the split fit's
    chi^2/dof and ``misfit``, the self-check's mean square in sigmas (a misfit that
    persists in time, which chi^2 of independent windows underrates)."""
    order = sorted(range(len(obs)), key=lambda i: obs[i].time)
    if len(order) < 8:
        return None
    quantiles = np.linspace(0.1, 0.9, CHANGE_SPLITS) * len(order)
    places = sorted({min(max(int(q), 1), len(order) - 1) for q in quantiles})
    threshold = chi2_isf(CHANGE_ALPHA / len(places), 4)
    best = None
    for k in places:
        after = set(order[k:])
        split = [replace(o, load=i in after) for i, o in enumerate(obs)]
        try:
            alt = setup.fit(split, positive=False, whitening=fit.whitening)  # same windows
        except TooFewPosesError:
            continue
        scale = max(1.0, alt.estimate.chi2 / alt.estimate.dof, misfit)
        statistic = (fit.estimate.chi2 - alt.estimate.chi2) / scale
        mass, sigma = alt.estimate.mass, alt.estimate.sigma_mass * math.sqrt(scale)
        assert alt.hand is not None  # windows before the place: the first load
        before = alt.hand.mass * alt.hand.com
        after = (before + mass * alt.estimate.com) / (alt.hand.mass + mass)
        shift = float(np.linalg.norm(after - alt.hand.com))
        candidate = LoadChange(
            obs[order[k]].time, mass, sigma, shift, statistic, threshold, alt.hand.mass
        )
        if best is None or candidate.statistic > best.statistic:
            best = candidate
    return best


def _geometry(recording: Recording, blocks: Sequence[_Block], estimate: Estimate) -> list[str]:
    """Warnings on the gravity directions the windows saw (unit vectors in the sensor
    frame, their spread's principal axes): within ``MIN_SPAN`` of one direction; exactly on
    one circle, within ``ONE_AXIS`` of a plane (the wrist turned about one axis); else the
    COM's worst resolved direction when far behind its best (``WEAK_DIRECTION``,
    ``WEAK_SIGMA``). Each names the COM's sigma along its worst direction."""
    middles = [(b.start + b.stop) // 2 for b in blocks]
    g = np.einsum("kji,j->ki", recording.rotations[middles], np.array([0.0, 0.0, -1.0]))
    spread = np.cov((g - g.mean(axis=0)).T) if len(g) > 2 else np.zeros((3, 3))
    values, vectors = np.linalg.eigh(spread)
    spreads = np.sqrt(np.maximum(values, 0.0))
    com_values, com_vectors = np.linalg.eigh(estimate.cov[1:, 1:])
    worst = math.sqrt(max(com_values[-1], 0.0))
    best = math.sqrt(max(com_values[0], 0.0))
    sigma = f"the COM along {_triple(com_vectors[:, -1])} has sigma {worst * 1e3:.2f} mm"
    if spreads[-1] < MIN_SPAN:
        return [
            f"the sensor barely turned (gravity directions spread {math.degrees(spreads[-1]):.1f}"
            f" deg): the load is hardly told from the bias; {sigma}"
        ]
    if spreads[0] < ONE_AXIS:
        return [
            f"the orientations all turn about one axis ({_triple(vectors[:, 0])} in the "
            f"sensor frame): the load is told from the bias by the arc's curvature alone; "
            f"{sigma}"
        ]
    if worst > WEAK_DIRECTION * best and worst > WEAK_SIGMA:
        return [
            f"the orientations span too little for the COM along {_triple(com_vectors[:, -1])}"
            f" (sensor frame): sigma {worst * 1e3:.2f} mm, {worst / best:.0f}x its best "
            "direction's"
        ]
    return []


def _self_check(
    setup: _Setup, obs: list[Observation], fixed: list[Observation]
) -> SelfCheck | None:
    """Each half (in time) of the windows ``obs``, with the ``fixed`` ones (a tare
    recording's), fitted alone predicting the other half."""
    order = sorted(range(len(obs)), key=lambda i: obs[i].time)
    halves = [order[: len(order) // 2], order[len(order) // 2 :]]
    residuals, sigmas = [], []
    for fitted, predicted in (halves, halves[::-1]):
        try:
            fit = setup.fit([obs[i] for i in fitted] + fixed)
        except (TooFewPosesError, NonPositiveMassError):
            return None
        for i in predicted:
            o = obs[i]
            wrench, cov = fit.predict(o.rotation, o.time, o.load, o.mean, o.design)
            r = o.mean - wrench
            residuals.append(r)
            sigmas.append(r / np.sqrt(np.diag(cov + o.window.cov)))
    return SelfCheck(
        np.sqrt(np.mean(np.square(residuals), axis=0)),
        np.sqrt(np.mean(np.square(sigmas), axis=0)),
        len(residuals),
    )
