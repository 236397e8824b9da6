"""Mass, COM and inertia of the load from one wrist motion: joint states and wrenches.

The sensor reads, at each of its samples k (time t_k, s),

    w_k = Y(q, dq, ddq)(t_k - delay) pi + b + e_k            (``robot.dynamics``)

with pi the load's 10 inertial parameters (the hand's and the object's together), b the
sensor's bias (6,; constant over a few seconds of motion), e_k its noise and ``delay`` how
much later the wrench is stamped than the joint state of the same instant (the sensor's
low-pass and transport against the arm's; a first-order low-pass of time constant T
delays slow signals by T). The fit, step by step:

1. **Joint motion, zero phase.** q, dq and ddq at any instant from the joint positions
   alone: a Savitzky-Golay fit (a polynomial of ``ORDER`` over ``WINDOW`` s centred on the
   nearest joint sample; Savitzky and Golay 1964), evaluated at the instant. It is
   symmetric, so it delays nothing; it passes the excitation's harmonics (a few Hz)
   unchanged and smooths the encoders' noise out of the accelerations. The wrenches are
   not filtered: each raw sample keeps its own noise, which step 3 weighs exactly, and
   nothing has to be aligned with a filter's delay.
2. **Delay, estimated.** The weighted residual of the linear fit is minimised over the
   delay: a 3 ms grid over +-``MAX_DELAY``, then a parabola through the three best.
3. **Coloured noise, weighed.** The sensor's noise model (``sensing.noise``: per-axis AR,
   learnt from the tare's windows) whitens the rows: each axis's samples and regressor
   columns go through the model's prediction-error filter and are divided by its
   innovation's sigma, the generalised least squares of the AR model. The covariance is
   then the Cramer-Rao bound under that noise, and chi^2 tests the model.
4. **Bias eliminated, load consistent.** b enters linearly and unconstrained; it is
   projected out (variable projection), with, for a sensor of stated hysteresis, the
   state's offset where the motion starts, which fades as the load travels
   (``_with_offset``: weighed by its prior, anywhere in its band), and the 10 parameters
   are fitted physically consistent (``estimation.fits.inertial``: log-Cholesky when the
   least squares estimate is not). A known hand (its parameters from an empty-hand
   motion, ``hand``) is taken off first, so what is fitted, and made consistent, is the
   object alone. What is taken off is the hand's least squares estimate, not the
   consistent one: a misfit common to both motions along the same trajectory (an arm
   model's error in a wrench estimated from the joint torques, the hand's cables) moves
   both least squares estimates alike and cancels in their difference; the hand made
   consistent would leave the constraint's pull in the object's parameters.
5. **Error bars.** The covariance adds to the noise's share the encoders' noise through
   the accelerations (``position_sigma``), both widened when the fit's residual is
   larger than the noise model, the encoders' noise, the calibration's error and a
   misfit common to the hand's motion allow (``widening_factor``), the calibration's
   common error propagated through the fit (``sensing.calibration``), not widened, and
   the hand's share (when given) but for its calibration share, widened by the hand's
   own misfit only. What is common to the two motions cancels in
   the difference: the calibration's error on the hand's wrench (what the object's fit
   is left with is its error on the object's wrench), and a misfit along the trajectory
   that both least squares fits left, measured by how the two whitened residuals agree
   block by block along the motion (``common_misfit``: independent noise, above the
   model or not, does not agree). A misfit of the object's own (a load that moves in the
   grasp) and noise above the model widen the fits as before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.inertial import fit_whitened
from com_core.robot.dynamics import inertia_elements, load_of, sensor_regressors
from com_core.robot.model import RobotModel
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis
from com_core.sensing.noise import NoiseModel

__all__ = [
    "BLOCK",
    "MAX_DELAY",
    "MotionFit",
    "best_delay",
    "common_misfit",
    "compensated",
    "fit_motion",
    "joint_motion",
    "load_vector",
    "motion_calibration",
    "principal_moments",
    "regressors_along",
    "widening_factor",
]

WINDOW = 0.1
"""s: the span of joint samples each Savitzky-Golay polynomial is fitted to."""
ORDER = 4
"""The Savitzky-Golay polynomial's degree."""
MAX_DELAY = 0.03
"""s: the largest delay, either way, searched between wrench and joint stamps."""
BLOCK = 0.04
"""s: the spans of the motion over which a fit's whitened residual is summed
(``MotionFit.residual_blocks``): a misfit along the trajectory (the excitation's few Hz)
stays in the sums, the noise the model whitens averages out of them."""
MOVED = 0.01
"""rad: a joint this far from its first state has begun the motion (the blocks' origin)."""
_DELAY_STEP = 3e-3  # s, the delay search's grid
_SEARCH_EVERY = 5  # the delay search uses every 5th wrench sample


@dataclass(frozen=True)
class MotionFit:
    """The load's parameters from one motion (see module).

    pi : (10,) the object's (or, without a known hand, the whole load's) parameters: m
        (kg), m c (kg m), inertia about the sensor origin (kg m^2), ``ft_sensor``.
    least_squares : (10,) their least squares estimate, before it was made consistent
        (``pi`` unless ``constrained``): what an object's fit takes off as the hand's.
    cov : (10, 10) their covariance, every share included (module, step 5).
    bound : (10, 10) the share of the sensor's noise alone: the Cramer-Rao bound of this
        motion under the noise model.
    calibration_cov : (10, 10) the calibration's share (zero without a calibration). A
        fit of the object with this hand taken off does not inherit it: the calibration's
        error is common to both motions, and what is left of it in the object's fit is
        the error on the object's own wrench.
    calibration_gain : (10, 36) d pi / d vec(E): how the calibration's error E
        (``sensing.calibration``; row-major) moves ``pi`` (zero without a calibration).
    bias : (6,) the sensor's bias over the motion, N and N m.
    delay : s, the wrench stamps' delay behind the joint states' (estimated).
    chi2, dof : the whitened residual's sum of squares and its degrees of freedom.
    constrained : the least squares estimate was not a physical body; ``pi`` is the
        consistent one nearest the data.
    samples : wrench samples fitted.
    expected : the chi^2 / dof the noise model, the encoders' noise, the calibration's
        error and a misfit in common with the hand's motion explain (1: the noise alone).
    common : the chi^2 of a misfit this motion has in common with the hand's, beyond
        what the calibration's error explains (``common_misfit``; 0 without a hand): in
        ``expected``, and taken off the hand's widening (as many times over as the hand's
        motion is longer: its degrees of freedom over these).
    residual_blocks : (blocks, 6) the whitened least squares residual per axis summed
        over each ``BLOCK`` s from the motion's beginning (a joint ``MOVED`` from its
        first state), over the square root of its samples: unit variance for noise the
        model whitens, a misfit along the trajectory standing out (``common_misfit``).
    misfit, misfit_squares : the chi^2 the calibration's error is expected to add, a sum
        of squared normals sum(l_i z_i^2), as sum(l_i) and sum(l_i^2) (0: none): what its
        spread over sensors is (``_calibration_share``).
    """

    pi: NDArray[np.float64]
    least_squares: NDArray[np.float64]
    cov: NDArray[np.float64]
    bound: NDArray[np.float64]
    calibration_cov: NDArray[np.float64]
    calibration_gain: NDArray[np.float64]
    bias: NDArray[np.float64]
    delay: float
    chi2: float
    dof: int
    constrained: bool
    samples: int
    expected: float
    common: float
    residual_blocks: NDArray[np.float64]
    misfit: float = 0.0
    misfit_squares: float = 0.0

    @property
    def widening(self) -> float:
        """The factor the noise's and the encoders' shares of ``cov`` were widened by
        (``widening_factor``)."""
        return widening_factor(self.chi2, self.dof, self.expected, self.misfit + self.common)

    def load(self) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """(mass kg, COM m, inertia about the COM kg m^2 (3, 3)), ``ft_sensor``."""
        return load_of(self.pi)

    def load_vector(self) -> NDArray[np.float64]:
        """(10,): mass, COM (3) and the inertia about the COM's six elements
        (``load_vector``), whose covariance ``load_cov`` is."""
        return load_vector(self.pi)

    def load_cov(self, cov: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """(10, 10) covariance of ``load_vector``, propagated to first order from ``cov``
        (default: the fit's, ``self.cov``; ``self.bound`` for the bound's)."""
        jac = np.zeros((10, 10))
        base = load_vector(self.pi)
        for i in range(10):
            step = 1e-6 * max(abs(self.pi[i]), 1e-6)
            shifted = self.pi.copy()
            shifted[i] += step
            jac[:, i] = (load_vector(shifted) - base) / step
        return jac @ (self.cov if cov is None else cov) @ jac.T


def load_vector(pi: NDArray[np.float64]) -> NDArray[np.float64]:
    """(10,) of the parameters ``pi``: mass (kg), COM (m) and the inertia about the COM
    (kg m^2) as its ``INERTIA_ELEMENTS``."""
    mass, com, inertia = load_of(pi)
    return np.concatenate([[mass], com, inertia_elements(inertia)])


def principal_moments(
    inertia: NDArray[np.float64], cov: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(the principal moments (3,) of ``inertia`` (3, 3), ascending, their sigmas (3,)):
    kg m^2; ``cov`` (6, 6) is the covariance of the inertia's ``INERTIA_ELEMENTS``,
    propagated to first order (d lambda_k = v_k^T dI v_k)."""
    moments, axes = np.linalg.eigh(inertia)
    # d lambda_k / d element: v_a v_b, twice off the diagonal (it stands at (a, b), (b, a))
    gradient = np.array([inertia_elements(np.outer(v, v) * (2 - np.eye(3))) for v in axes.T]).T
    return moments, np.sqrt(np.einsum("ik,ij,jk->k", gradient, cov, gradient))


def joint_motion(
    times: ArrayLike, positions: ArrayLike, at: ArrayLike
) -> tuple[NDArray[np.float64], ...]:
    """(q, dq, ddq), each (len(at), joints): rad, rad/s, rad/s^2 at the instants ``at``
    (s) from joint ``positions`` (samples, joints) stamped ``times`` (s, increasing, evenly
    spaced): step 1 of the module. ValueError for an instant without ``WINDOW`` / 2 of
    samples on both sides, or stamps that are not evenly spaced (a gap of 1.5 periods)."""
    t = np.asarray(times, dtype=np.float64)
    x = np.asarray(positions, dtype=np.float64)
    at = np.asarray(at, dtype=np.float64)
    period = (t[-1] - t[0]) / (len(t) - 1)
    if not np.all(np.diff(t) < 1.5 * period) or not period > 0:
        raise ValueError("the joint states are not evenly spaced (a gap of 1.5 periods)")
    half = max(round(WINDOW / 2 / period), ORDER // 2 + 1)
    nearest = np.rint((at - t[0]) / period).astype(int)
    if nearest.min() < half or nearest.max() > len(t) - 1 - half:
        raise ValueError(
            f"joint states must cover {half * period:.3f} s before and after every wrench "
            f"fitted: they span [{t[0]:.3f}, {t[-1]:.3f}] s, the wrenches [{at.min():.3f}, "
            f"{at.max():.3f}] s"
        )
    offsets = np.arange(-half, half + 1)
    # the least squares polynomial's coefficients c = P x over each window, in periods
    P = np.linalg.pinv(offsets[:, None] ** np.arange(ORDER + 1)[None, :].astype(float))
    windows = x[nearest[:, None] + offsets[None, :]]  # (n, 2 half + 1, joints)
    c = np.einsum("pw,nwj->npj", P, windows)  # (n, ORDER + 1, joints)
    s = ((at - t[nearest]) / period)[:, None]  # where in the window, periods
    powers = np.arange(ORDER + 1)
    q = np.einsum("np,npj->nj", s**powers, c)
    dq = np.einsum("np,npj->nj", (powers * s ** np.maximum(powers - 1, 0)), c) / period
    second = powers * (powers - 1) * s ** np.maximum(powers - 2, 0)
    ddq = np.einsum("np,npj->nj", second, c) / period**2
    return q, dq, ddq


def regressors_along(
    robot: RobotModel, q: NDArray[np.float64], dq: NDArray[np.float64], ddq: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(n, 6, 10): ``sensor_regressor`` at each row of q, dq, ddq."""
    return sensor_regressors(robot, q, dq, ddq)


def fit_motion(
    robot: RobotModel,
    joint_times: ArrayLike,
    joint_positions: ArrayLike,
    wrench_times: ArrayLike,
    wrenches: ArrayLike,
    noise: NoiseModel,
    hand: MotionFit | None = None,
    calibration: Calibration | None = None,
    position_sigma: float = 0.0,
    hysteresis: Hysteresis | None = None,
) -> MotionFit:
    """The load's parameters from the ``wrenches`` (n, 6; N, N m, ``ft_sensor``, stamped
    ``wrench_times`` s, evenly spaced, one motion) and the joint positions (samples,
    ``robot.joint_names``; rad, m) stamped ``joint_times`` (s), with the sensor's ``noise``
    model (see module). ``hand``: the empty hand's fit, taken off; None: the whole load is
    fitted. ``calibration``: the sensor's stated accuracy or its calibration in place
    (None: perfect). ``position_sigma``: rad, the encoders' noise per joint sample.
    ``hysteresis``: the sensor's stated one: what its gain leaves along the loops is
    weighed with the calibration (``motion_calibration``), and the state's offset where
    the motion starts is fitted with the bias (``_with_offset``). ValueError when the
    motion does not excite the 10 parameters or the joint states do not cover it."""
    w = np.asarray(wrenches, dtype=np.float64)
    calibration = motion_calibration(calibration, hysteresis, w)
    t = np.asarray(wrench_times, dtype=np.float64)
    jt = np.asarray(joint_times, dtype=np.float64)
    jq = np.asarray(joint_positions, dtype=np.float64)
    hand_pi = np.zeros(10) if hand is None else hand.least_squares
    inner = (t - MAX_DELAY - WINDOW > jt[0]) & (t + MAX_DELAY + WINDOW < jt[-1])
    t, w = t[inner], w[inner]
    if len(t) < 100:
        raise ValueError(
            f"{len(t)} wrench samples lie within the joint states' span less "
            f"{MAX_DELAY + WINDOW:.2f} s at each end: too short a motion"
        )

    def regressors(delay: float, every: int = 1) -> NDArray[np.float64]:
        return regressors_along(robot, *joint_motion(jt, jq, t[::every] - delay))

    def residual(delay: float) -> float:
        Y = regressors(delay, _SEARCH_EVERY)
        A, b = _whitened_system(Y, w[::_SEARCH_EVERY] - Y @ hand_pi, noise, _SEARCH_EVERY)
        solution, *_ = np.linalg.lstsq(A, b, rcond=None)
        r = b - A @ solution
        return float(r @ r)

    delay = best_delay(residual)
    Y = regressors(delay)
    object_wrench = w - Y @ hand_pi
    A, b = _whitened_system(Y, object_wrench, noise, 1)
    rows = len(b)  # the samples' (the prior's pseudo-observations after them)
    A_pi, A_bias = A[:, :10], A[:, 10:]
    if hysteresis is not None:
        A_pi, A_bias, b = _with_offset(A_pi, A_bias, b, hysteresis, w, noise)
    basis, _ = np.linalg.qr(A_bias)

    def project(x: NDArray[np.float64]) -> NDArray[np.float64]:
        if len(x) < len(basis):  # the samples' rows: none of the prior's
            x = np.concatenate([x, np.zeros((len(basis) - len(x), *x.shape[1:]))])
        return x - basis @ (basis.T @ x)

    fitted, target = project(A_pi), project(b)
    fit = fit_whitened(fitted, target)
    bias = np.linalg.lstsq(A_bias, b - A_pi @ fit.pi, rcond=None)[0][:6]
    moved = np.flatnonzero(np.max(np.abs(jq - jq[0]), axis=1) > MOVED)
    began = jt[moved[0]] if len(moved) else jt[0]
    residual_rows = (target - fitted @ fit.least_squares)[:rows]
    blocks = _block_sums(residual_rows, t - delay - began, noise)
    shared = 0.0 if hand is None else common_misfit(hand.residual_blocks, blocks)
    dof = rows - 16  # the offset's columns come with as many rows of its prior
    gain, misfit, squares, explained = np.zeros((10, 36)), 0.0, 0.0, 0.0
    if calibration is not None:
        hand_wrench = None if hand is None else Y @ hand_pi
        gain, misfit, squares, explained = _calibration_share(
            calibration, Y @ fit.pi, hand_wrench, noise, project, fit.cov, fitted
        )
    calibration_cov = 0.0 if calibration is None else calibration.spread(gain)
    cov = fit.cov
    expected = 1.0  # chi^2 / dof the noise model, the encoders' noise and E explain
    if position_sigma > 0:
        load = fit.pi + hand_pi
        share, expected = _encoder_share(robot, jt, jq, t - delay, load, position_sigma,
                                         noise, fit.cov, project, fitted)  # fmt: skip
        cov = cov + share
    common = max(0.0, shared - explained)  # a misfit along the motion beyond E's
    expected += (misfit + common) / dof
    cov = cov * widening_factor(fit.chi2, dof, expected, misfit + common) + calibration_cov
    if hand is not None:  # the hand's noise and encoders' shares, widened by its own misfit
        # the common misfit adds its chi^2 at each pass: a hand's longer motion, more often
        own = widening_factor(hand.chi2 - common * hand.dof / dof, hand.dof, hand.expected,
                              hand.misfit)  # fmt: skip
        cov += (hand.cov - hand.calibration_cov) / hand.widening * own
    return MotionFit(fit.pi, fit.least_squares, cov, fit.cov, calibration_cov, gain, bias,
                     delay, fit.chi2, dof, fit.constrained, len(t), expected, common,
                     blocks, misfit, squares)  # fmt: skip


def motion_calibration(
    calibration: Calibration | None, hysteresis: Hysteresis | None, wrenches: ArrayLike
) -> Calibration | None:
    """The sensor's error a fit in motion of ``wrenches`` (n, 6; N, N m) weighs: the
    ``calibration`` term with, for a sensor of stated ``hysteresis``, what is left of its
    gain deficit once taken off the readings as a further gain error per axis, zero-mean,
    its spread the rms of the gain along the motion's loops: the slope moves evenly
    between the bounds the share of the deficit the motion's span leaves
    (``Hysteresis.residual_share``) sets on either side, so its rms is that share over
    sqrt(3)."""
    if hysteresis is None:
        return calibration
    if calibration is None:
        force, torque = hysteresis.full_scale[0], hysteresis.full_scale[3]
        calibration = Calibration(0.0, force, torque)
    share = hysteresis.residual_share(wrenches) / math.sqrt(3.0)
    return calibration.with_gain_spread(share * hysteresis.gain_deficit())


def common_misfit(hand: NDArray[np.float64], loaded: NDArray[np.float64]) -> float:
    """The chi^2 a misfit common to two fits along the same trajectory adds to each, from
    their ``residual_blocks`` (the hand's, the loaded motion's): the sum of their products
    over the blocks both have, at least 0. Noise independent between the motions adds
    nothing to it but its spread (some 20 over 450 blocks, against 20 000 dof); a misfit
    d along the trajectory adds about sum(d^2), as it does to each fit's chi^2."""
    n = min(len(hand), len(loaded))
    return max(0.0, float(np.sum(hand[:n] * loaded[:n])))


def widening_factor(chi2: float, dof: int, expected: float, explained: float = 0.0) -> float:
    """The factor the noise's and the encoders' shares of a fit's covariance are widened
    by, at least 1: the chi^2 beyond the ``explained`` misfit (the calibration's error's
    mean and a misfit in common with the hand's motion) over what the noise and the
    encoders explain (``expected`` (per dof) less ``explained`` / dof). Not the
    calibration's share: its misfit is one draw of what of the error E no load takes, a
    sum of a few squared normals that spreads about its mean by half of it, and it tells
    little of the part the load took. Widened by its chi^2/dof, a sensor whose misfit
    drew above its mean got wider error bars on the part that did not (a 2 kg object on
    a sensor of 2 % of full scale: its mass variance 1.19 times on average over 24 draws
    of E, up to 1.8, where the calibration's share is the whole of it and exact)."""
    return max(1.0, (chi2 - explained) / (dof * expected - explained))


def compensated(
    robot: RobotModel,
    pi: ArrayLike,
    bias: ArrayLike,
    delay: float,
    joint_times: ArrayLike,
    joint_positions: ArrayLike,
    wrench_times: ArrayLike,
    wrenches: ArrayLike,
) -> NDArray[np.float64]:
    """(n, 6): the ``wrenches`` (N, N m, ``ft_sensor``, stamped ``wrench_times`` s) less
    the wrench of the load ``pi`` (10,; hand and object together) along the joint motion
    (``joint_motion`` of the positions, ``delay`` s earlier) and less ``bias`` (6,): what
    the sensor reads beyond the load in motion, its noise alone when the load is right."""
    at = np.asarray(wrench_times, dtype=np.float64) - delay
    Y = regressors_along(robot, *joint_motion(joint_times, joint_positions, at))
    return np.asarray(wrenches, dtype=np.float64) - Y @ np.asarray(pi) - np.asarray(bias)


def best_delay(residual, step: float = _DELAY_STEP) -> float:
    """The delay (s) minimising ``residual(delay)`` (a function of the delay, s): a grid of
    ``step`` (s; 3 ms) over +-``MAX_DELAY``, then a parabola through the three best (step
    2)."""
    grid = np.arange(-MAX_DELAY, MAX_DELAY + step / 2, step)
    costs = np.array([residual(d) for d in grid])
    k = int(np.clip(np.argmin(costs), 1, len(grid) - 2))
    left, middle, right = costs[k - 1 : k + 2]
    curvature = left - 2 * middle + right
    shift = 0.5 * (left - right) / curvature if curvature > 0 else 0.0
    return float(grid[k] + np.clip(shift, -1.0, 1.0) * step)


def _whitened_system(
    Y: NDArray[np.float64], w: NDArray[np.float64], noise: NoiseModel, every: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(A (rows, 16), b (rows,)): the regressors (n, 6, 10) with the bias's columns, and
    the wrenches (n, 6), ``_whiten``ed."""
    columns = np.concatenate([Y, np.broadcast_to(np.eye(6), (len(Y), 6, 6))], axis=2)
    return _whiten(columns, noise, every), _whiten(w, noise, every)


def _whiten(x: NDArray[np.float64], noise: NoiseModel, every: int = 1) -> NDArray[np.float64]:
    """x (n, 6, ...) per axis through the noise model's prediction-error filter, divided
    by its innovation's sigma, the axes stacked: (rows, ...) (step 3). Samples ``every``
    > 1 apart are taken as white, each divided by its sigma (the correlation short beside
    the spacing: the delay search's subsample)."""
    out = []
    for a in range(6):
        phi = noise.ar[a] if every == 1 else ()
        sigma = np.sqrt(noise.innovation[a] if every == 1 else noise.cov[a, a])
        out.append(_prediction_errors(x[:, a], phi) / sigma)
    return np.concatenate(out)


def _block_sums(
    residual: NDArray[np.float64], since: NDArray[np.float64], noise: NoiseModel
) -> NDArray[np.float64]:
    """``MotionFit.residual_blocks`` of the whitened ``residual`` (rows as ``_whiten``
    stacks them) of samples ``since`` s (n,) after the motion began; those before it are
    left out."""
    block = np.floor(since / BLOCK).astype(int)
    out, start = np.zeros((max(block.max() + 1, 0), 6)), 0
    for a in range(6):
        index = block[len(noise.ar[a]) :]
        rows = residual[start : start + len(index)]
        start += len(index)
        after = index >= 0
        counts = np.bincount(index[after], minlength=len(out))
        sums = np.bincount(index[after], weights=rows[after], minlength=len(out))
        out[:, a] = sums / np.sqrt(np.maximum(counts, 1))
    return out


def _prediction_errors(x: NDArray[np.float64], phi: Sequence[float]) -> NDArray[np.float64]:
    """x_t - sum_i phi_i x_(t-i) for t >= len(phi), along the first axis."""
    p = len(phi)
    out = x[p:].copy()
    for i, c in enumerate(phi, start=1):
        out -= c * x[p - i : len(x) - i]
    return out


def _calibration_share(
    calibration: Calibration,
    object_wrench: NDArray[np.float64],
    hand_wrench: NDArray[np.float64] | None,
    noise: NoiseModel,
    project,
    cov: NDArray[np.float64],
    fitted: NDArray[np.float64],
) -> tuple[NDArray[np.float64], float, float, float]:
    """(d pi / d vec(E) (10, 36), the chi^2 it adds, the sum of its weights' squares, the
    part of it the hand's motion shares): the calibration's common error E on the
    object's wrench (n, 6) through the whitened least squares (``sensing.calibration``;
    its share of the covariance is ``calibration.spread(gain)``), and the expected sum of
    squares of what of it no load explains, tr(M P M^T) with M the whitened error less
    its fitted part: the misfit a heavier load's calibration error leaves, which is no
    sign of a load that moved. For one sensor that misfit is sum(l_i z_i^2), l the
    eigenvalues of (M P^1/2)^T (M P^1/2) and z standard normals: its mean sum(l), its
    variance 2 sum(l^2). The misfit is of the whole load's wrench, the
    ``hand_wrench`` (n, 6; None: no hand taken off) with the object's: what of E on the
    hand's wrench its own fit could not explain is in this motion's residual too, where
    the hand's parameters took off only what it explained. That part is in the hand's
    fit's residual as well: its expected product with this one, tr(M_hand P M^T), is what
    of ``common_misfit`` the calibration explains (0 without a hand). ``fitted``: the
    whitened regressors with the bias ``project``ed out, (rows, 10)."""

    def whitened_error(wrench: NDArray[np.float64]) -> NDArray[np.float64]:
        jacobians = calibration.stacked_jacobian(wrench).reshape(len(wrench), 6, 36)
        return project(_whiten(jacobians, noise))

    def left(whitened: NDArray[np.float64]) -> NDArray[np.float64]:
        return whitened - fitted @ (cov @ fitted.T @ whitened)

    whitened = whitened_error(object_wrench)
    gain = cov @ fitted.T @ whitened
    values, vectors = np.linalg.eigh(calibration.error_cov)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    hand = None if hand_wrench is None else whitened_error(hand_wrench)
    misfit = left(whitened if hand is None else whitened + hand) @ root  # E's is linear
    common = 0.0 if hand is None else float(np.sum((left(hand) @ root) * misfit))
    weights = np.linalg.eigvalsh(misfit.T @ misfit)
    return gain, float(np.sum(weights)), float(np.sum(weights**2)), common


def _with_offset(
    A_pi: NDArray[np.float64],
    A_bias: NDArray[np.float64],
    b: NDArray[np.float64],
    hysteresis: Hysteresis,
    wrenches: NDArray[np.float64],
    noise: NoiseModel,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The whitened system (``_whitened_system``'s, split) with the hysteresis state's
    offset h where the motion starts as a nuisance column per axis with a band beside
    the bias's: sample k of the ``wrenches`` (n, 6) still carries h m_k, m_k its memory
    after the load's travel since (``Hysteresis.path_memory``), and h is anywhere in its
    band, weighed as a pseudo-observation per column of its variance
    (``Hysteresis.start_variance``) after the samples' rows. After a contact (the grasp)
    nothing tells where in its band the state is, and along a light load's loops what
    the start's offset leaves as it fades is far more than what the gain leaves
    (``Hysteresis.residual_share``): the fit takes it off, and its covariance holds what
    the motion does not tell of it."""
    variance = hysteresis.start_variance()
    axes = np.flatnonzero(variance > 0)  # an axis without a band has no offset
    memory = hysteresis.path_memory(wrenches)
    offset = _whiten(memory[:, :, None] * np.eye(6)[:, axes], noise)  # d w_k / d h
    prior = np.diag(1.0 / np.sqrt(variance[axes]))
    return (
        np.vstack([A_pi, np.zeros((len(axes), 10))]),
        np.block([[A_bias, offset], [np.zeros((len(axes), 6)), prior]]),
        np.concatenate([b, np.zeros(len(axes))]),
    )


def _encoder_share(
    robot: RobotModel,
    jt: NDArray[np.float64],
    jq: NDArray[np.float64],
    at: NDArray[np.float64],
    pi: NDArray[np.float64],
    sigma: float,
    noise: NoiseModel,
    cov: NDArray[np.float64],
    project,
    fitted: NDArray[np.float64],
) -> tuple[NDArray[np.float64], float]:
    """(the share (10, 10), chi^2 / dof expected with it): the encoders' white noise
    ``sigma`` (rad) per joint sample, through the Savitzky-Golay fit into q, dq, ddq and
    the predicted wrench, then through the whitened least squares: the covariance of the
    fit's shift over 8 seeded draws of the noise (a small share: a Monte Carlo is exact
    enough and cheaper than the Jacobian), and 1 plus the whitened wrench error's mean
    square per row (what it adds to the residual)."""
    base = regressors_along(robot, *joint_motion(jt, jq, at)) @ pi
    shifts, added = [], []
    rng = np.random.default_rng(0)
    for _ in range(8):
        shaken = jq + sigma * rng.standard_normal(jq.shape)
        delta = _whiten(regressors_along(robot, *joint_motion(jt, shaken, at)) @ pi - base, noise)
        shifts.append(cov @ fitted.T @ project(delta))
        added.append(np.mean(delta**2))
    spread = np.array(shifts)
    return spread.T @ spread / len(shifts), 1.0 + float(np.mean(added))
