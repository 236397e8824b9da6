"""A strain-gauge sensor's hysteresis: the model the simulator reads through
(``wrench_sim.gauges``) and what of it the estimator takes off and weighs.

Per axis a (N or N m) of range r_a, a state h_a moves toward -b_a while the load x_a
rises and +b_a while it falls by the fraction 1 - exp(-|dx_a| / (``SATURATION`` r_a)) of
the way with each change dx_a (a Dahl model, rate-independent); b_a is set so that a loop
over the whole range opens the datasheet's band H_a at no load (``edge``). A change dx_a
moves a state from the middle of its band by b_a |dx_a| / (SATURATION r_a) (at most
b_a), toward the side the load came from; from the far edge, after the load turned, by up
to twice that, and from the near edge not at all.

So for loads that stay well within SATURATION r_a of one another, h_a = -d_a x_a + c_a to
first order, d_a = b_a / (SATURATION r_a) (``Hysteresis.gain_deficit``): the gauges read
the load with a gain 1 - d_a below one, the same sign on every sensor, and c_a, set by the
load's history, is a constant the fits' bias takes up. The estimator takes the gain off
every reading (``gain``; ``sensing.calibration.reading_correction``) and weighs what the
first order leaves. Along a motion, ``residual_share``: from the middle of the band the
slope of h_a moves by d_a u / 2 over an excursion u = span / (SATURATION r_a), and a
state off the middle by h moves it by d_a h / b_a, h within +-d_a span / 2 once the loads
have swung over their span; the share min(1, u / 2) of d_a bounds either. Along a loop
the slope moves evenly between those bounds, so the fit in motion weighs the rms, the
share over sqrt(3), as a spread of each axis's own gain
(``fits.motion.motion_calibration``, ``Calibration.with_gain_spread``). The state's
offset where a motion starts fades along it as at rest (next; ``path_memory``), and the
fit in motion takes it off beside its bias (``fits.motion``).

At rest the share weighs the state's move along the path between two windows
(``Hysteresis.window_sigma``): what the first order leaves moves by h_a |dx_a| /
(SATURATION r_a) with every change dx_a, whichever way it goes (h_a the state's offset
from the middle of its band, within the share of b_a), and by at most h_a, as a path that
turns again and again pulls the state to the middle. The offset h_a is not known, only
its bound: it is weighed anywhere within it, a rectangle's sigma (the bound over
sqrt(3), GUM 4.3.7), as the fit in motion weighs the slope's rms along a loop. So what
counts is the path's whole travel, not its net change (``travel``): the grasp's fingers
press on the table and the lift overshoots, the arm rings, a tilt from one side to the
other passes upright, and a net change of zero can hide a travel of newtons. The share
is of every load the path reached, the presses and overshoots between the windows
included (``reach``): the state's offset is set by them as by the windows. The state
keeps what it moved (``FitSetup.with_hysteresis`` sums the increments so far, a
persistent nuisance). Most of that move is not unknown, though: its second order, d /
(SATURATION r_a) times the integral of x_a |dx_a| from the first window, has the load's
sign on every sensor, and the readings tell it (``Hysteresis.beyond_first_order``, the
model's steps along the readings' path less their first order). The fit takes it off
each window's mean (``Observation.beyond``) and weighs ``BEYOND_LEFT`` of the share for
what the model's loop shape and the readings' path leave. What a way did (its travel,
reach and move beyond the first order: ``Way``, ``Hysteresis.ways``) is kept with a
cached tare pass's windows, whose samples are gone, so a run that reuses the pass weighs
them as the pass's own run did.

Where a run starts, the state is wherever the loads before it left it, anywhere within
+-b_a (``Hysteresis.start_variance``); not in the middle of its band, which only a sensor
never loaded is. The model is linear in the state for a given path, so two states the same
path moves close in by exp(-T_a / (SATURATION r_a)) over a travel T_a: the offset at the
first window is a nuisance common to all of them, each carrying that share of it
(``start_memory``). Not weighed, it reads as the object moving in the grasp. A way
through contact (the grasp, the release) chatters within the noise far beyond what
``travel`` sees and leaves the state anywhere in its band again: the windows after it
carry a fresh offset so (``FitSetup.with_hysteresis``). A window no fit used (a
verification's) carries the increments and the offsets the fit's windows share, as the
fit left them, and its own way's increment (``FitSetup.carried``): not weighed, the
sensor's offset reads there as the estimate's error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BEYOND_LEFT",
    "SATURATION",
    "TRAVEL_BLOCK",
    "TRAVEL_DEADBAND",
    "Hysteresis",
    "Way",
    "dahl_step",
    "edge",
    "follow",
    "reach",
    "travel",
]

SATURATION = 0.5
"""The load change, as a fraction of the range, over which the hysteresis state moves
1 - 1/e of its way to the band's edge."""


BEYOND_LEFT = (0.25,) * 3 + (0.5,) * 3
"""The share of ``Hysteresis.window_sigma``'s bound weighed per axis (fx fy fz tx ty tz)
on a way whose state's move beyond its first order was taken off
(``Hysteresis.beyond_first_order``): that move's shape is the model's loop fitted to the
stated band, and its path the readings', which miss what the gauges see under the
blocks' means and the sensor's low-pass (the arm's vibration: at 2 kg 10-40 % of the
forces' travel) and carry the calibration's error. Through the sim's gauges the
correction leaves 0.06-0.18 of the bound rms in the forces and 0.04-0.36 in the torques,
at most 0.51 and 1.3 (tz, whose loads are the smallest): over the sigma so weighed, rms
0.08-0.72 per axis, at most 2.0 and 2.6, at 0.5 and 2 kg (``bench/hysteresis_ways.py``)."""

TRAVEL_BLOCK = 10
"""Samples averaged into one point of a path before its ``travel`` is taken."""

TRAVEL_DEADBAND = 5.0
"""The half-width of ``travel``'s deadband, in standard deviations of a block's mean: at
three, a quantised sensor's coloured noise (the xArm's: 0.1 N steps at 0.1 N, 5 ms) read
as 0.3-1 N of travel over a 5 s window at rest, as the noise learnt from its blocks'
second differences is short a quarter of their spread."""


def _loop_opening(saturation: float) -> float:
    """The band at no load of a steady loop over the whole range, per unit of b: the state
    falls from -a to +a over 2 r (a = b tanh(1 / saturation)), and at no load it has come
    r of that way, so the opening is 2 (b - (b + a) exp(-1 / saturation))."""
    decay = math.exp(-1.0 / saturation)
    return 2.0 * (1.0 - (1.0 + math.tanh(1.0 / saturation)) * decay)


def edge(band: ArrayLike) -> NDArray[np.float64]:
    """b per axis (6,): the state's bound for a full-range loop's ``band`` H (6,)."""
    return np.asarray(band, dtype=np.float64) / _loop_opening(SATURATION)


@dataclass(frozen=True)
class Way:
    """What a window's way from the window before it did to the hysteresis state, as the
    readings tell it (``Hysteresis.ways``): the load's ``travel`` (6,; N, N m) and ``reach``
    (2, 6), None for the first window of its run or pass, and ``beyond`` (6,), the state's
    move beyond its first order since that first window or the last way through contact
    (``Hysteresis.beyond_first_order``). A cached tare pass keeps its windows' ways as read
    (``corrected`` takes them through what corrects a reading)."""

    travel: NDArray[np.float64] | None
    reach: NDArray[np.float64] | None
    beyond: NDArray[np.float64]

    def corrected(self, correction: ArrayLike) -> Way:
        """The way of the readings times ``correction`` (6, 6)'s transpose: its ``reach``'s
        ends and ``beyond`` so mapped, its ``travel`` bounded by |correction| times it
        (a total variation's bound under a linear map)."""
        m = np.asarray(correction, dtype=np.float64)
        travel = None if self.travel is None else np.abs(m) @ self.travel
        reach = None if self.reach is None else np.sort(self.reach @ m.T, axis=0)
        return Way(travel, reach, m @ self.beyond)


@dataclass(frozen=True)
class Hysteresis:
    """A sensor's hysteresis as the estimator weighs it: the ``band`` H (6,; N, N m) a
    full-range loop opens per axis (a datasheet's "hysteresis, % FS" times the range) and
    the ``full_scale`` r (6,)."""

    band: tuple[float, ...]
    full_scale: tuple[float, ...]

    @classmethod
    def stated(cls, band: Sequence[float], force: float, torque: float) -> Hysteresis | None:
        """The hysteresis of a stated ``band`` (6,) over a sensor's full scales in
        ``force`` (N, the three forces') and ``torque`` (N m); None for a band of zeros."""
        if not any(band):
            return None
        return cls(tuple(band), (force,) * 3 + (torque,) * 3)

    def gain_deficit(self) -> NDArray[np.float64]:
        """(6,): d = b / (``SATURATION`` r) per axis, how much short of the load's change a
        small excursion reads when the state starts from the middle of its band (module;
        from the far edge, after a turn, up to twice it; from the near edge, none)."""
        return edge(self.band) / (SATURATION * np.asarray(self.full_scale, dtype=np.float64))

    def gain(self) -> NDArray[np.float64]:
        """(6,): 1 - d, the gain the gauges read a load's changes with (module)."""
        return 1.0 - self.gain_deficit()

    def residual_share(self, loads: ArrayLike) -> NDArray[np.float64]:
        """(6,): the share of d left uncertain once the gain is taken off, for loads
        (n, 6; N, N m) spanning what ``loads`` span: min(1, u / 2), u = span /
        (``SATURATION`` r) (module)."""
        x = np.asarray(loads, dtype=np.float64).reshape(-1, 6)
        span = np.ptp(x, axis=0) if len(x) else np.zeros(6)
        return np.minimum(span / (2.0 * SATURATION * np.asarray(self.full_scale)), 1.0)

    def window_sigma(
        self,
        means: ArrayLike,
        travels: ArrayLike | None = None,
        reaches: ArrayLike | None = None,
        beyond: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """(n, 6): each window's sigma (N, N m) for windows whose ``means`` (n, 6) follow
        one another in time: the ``residual_share`` of the state's whole move min(d V, b)
        over the load's travel V since the window before (``travels`` (n, 6), from the
        samples between them, at least the change of the means; NaN, or none given: a
        straight path, the change of the means; inf: a path not known, the most it can
        move), b the band's edge, over sqrt(3): the share bounds the state's offset, which
        is anywhere within it (module). The share is of the loads the means span with
        no load and the ways between them reach (``reaches`` (n, 2, 6), from the samples
        between them, ``reach``; NaN, or none given: the means); the first window's path
        is from no load. A window whose state's move beyond its first order was taken off
        (``beyond`` (n,), true; ``beyond_first_order``) weighs ``BEYOND_LEFT`` of it on a
        way of known travel."""
        path, moved = _moves(means, travels)
        if reaches is not None:
            ends = np.asarray(reaches, dtype=np.float64).reshape(-1, 6)
            path = np.vstack([path, ends[np.isfinite(ends).all(axis=1)]])
        b = edge(self.band)
        whole = np.where(np.isinf(moved), b, np.minimum(self.gain_deficit() * moved, b))
        sigma = self.residual_share(path) * whole / math.sqrt(3.0)
        if beyond is None:
            return sigma
        left = np.asarray(beyond, dtype=bool)[:, None] & np.isfinite(moved)
        return np.where(left, np.asarray(BEYOND_LEFT) * sigma, sigma)

    def start_variance(self) -> NDArray[np.float64]:
        """(6,): the variance (N^2, N^2 m^2) of the state's offset from the middle of
        its band at the first window: anywhere within +-b, a rectangle's (module)."""
        return edge(self.band) ** 2 / 3.0

    def start_memory(
        self, means: ArrayLike, travels: ArrayLike | None = None, start: int = 0
    ) -> NDArray[np.float64]:
        """(n, 6): for windows as ``window_sigma`` takes them, the share each still
        carries of the state's offset at window ``start``, exp(-T / (``SATURATION`` r))
        after the load's travel T since (two states the same path moves close in so: the
        model is linear in the state; module); none after a way not known (inf), as
        ``window_sigma`` takes it, the most it can move, and none before ``start``."""
        _, moved = _moves(means, travels)
        scale = SATURATION * np.asarray(self.full_scale, dtype=np.float64)
        decay = np.exp(-moved / scale)
        decay[: start + 1] = 1.0
        memory = np.cumprod(decay, axis=0)
        memory[:start] = 0.0
        return memory

    def path_memory(self, loads: ArrayLike) -> NDArray[np.float64]:
        """(n, 6): for a path sampled as ``loads`` (n, 6; N, N m) in time order, the share
        each sample still carries of the state's offset at the first, exp(-T /
        (``SATURATION`` r)) after the load's travel T since (``travel``'s deadband
        follower, its turns' half-widths not put back: a share never smaller than the
        truth's; ones for a path shorter than three blocks), as ``start_memory`` for
        windows (module)."""
        x = np.asarray(loads, dtype=np.float64).reshape(-1, 6)
        follower, _ = follow(x)
        if not len(follower):
            return np.ones_like(x)
        moved = np.vstack([np.zeros(6), np.cumsum(np.abs(np.diff(follower, axis=0)), axis=0)])
        scale = SATURATION * np.asarray(self.full_scale, dtype=np.float64)
        return _per_sample(np.exp(-moved / scale), len(x))

    def beyond_first_order(self, loads: ArrayLike) -> NDArray[np.float64]:
        """(n, 6): for a path sampled as ``loads`` (n, 6; N, N m) in time order, what the
        state moves from the first sample to each beyond its first order -d dx, from the
        middle of its band (N, N m): the model's own steps along ``travel``'s deadband
        follower, plus d times the follower's change (its lag behind the path cancels
        between the two to first order). To second order d / (``SATURATION`` r) times the
        integral of x |dx|, x the load from the first sample: the deficit of the gain's
        slope grows with the load's excursion, the same way on every sensor, and the
        readings tell it. An offset of the state at the first sample moves as
        ``path_memory`` says, the model being linear in it (module). Zeros for a path
        shorter than three blocks."""
        x = np.asarray(loads, dtype=np.float64).reshape(-1, 6)
        follower, _ = follow(x)
        if not len(follower):
            return np.zeros_like(x)
        b, scale = edge(self.band), SATURATION * np.asarray(self.full_scale, dtype=np.float64)
        state = np.zeros_like(follower)
        for i, step in enumerate(np.diff(follower, axis=0), start=1):
            state[i] = dahl_step(state[i - 1], step, b, scale)
        moved = state + self.gain_deficit() * (follower - follower[0])
        return _per_sample(moved, len(x))

    def ways(
        self,
        times: Sequence[float],
        contacts: Sequence[int],
        stamps: NDArray[np.float64],
        loads: NDArray[np.float64],
    ) -> list[Way]:
        """Each window's ``Way``, for windows whose middles are at ``times`` (s, ascending)
        read along the samples at ``stamps`` (s, ascending) of ``loads`` (n, 6; N, N m):
        the samples from the middle of one window to the middle of the next give its
        ``travel`` and ``reach``, and those from the first window, or from the first after
        each way through contact (``contacts``: those windows' indices), its ``beyond``;
        a window alone between contacts, with no samples on its way, moved nothing."""

        def at(time: float, side: str) -> int:
            return int(np.searchsorted(stamps, time, side=side))

        beyond = np.zeros((len(times), 6))
        for segment in np.split(np.arange(len(times)), sorted(set(contacts) - {0})):
            start = at(times[segment[0]], "left")
            path = loads[start : at(times[segment[-1]], "right")]
            moved = np.vstack([np.zeros(6), self.beyond_first_order(path)])
            for k in segment:
                beyond[k] = moved[min(max(at(times[k], "right") - start, 0), len(moved) - 1)]
        out = [Way(None, None, beyond[0])]
        for k in range(1, len(times)):
            way = loads[at(times[k - 1], "left") : at(times[k], "right")]
            out.append(Way(travel(way), reach(way), beyond[k]))
        return out


def dahl_step(
    state: NDArray[np.float64],
    step: NDArray[np.float64],
    b: NDArray[np.float64],
    scale: ArrayLike,
) -> NDArray[np.float64]:
    """(6,): the state (N, N m) after a change ``step`` (6,) of the load: it moves toward
    -b while the load rises, +b while it falls, by 1 - exp(-|step| / ``scale``) of the
    way (``scale`` = ``SATURATION`` r; module)."""
    return state - (np.sign(step) * b + state) * -np.expm1(-np.abs(step) / scale)


def _per_sample(blocks: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """(n, 6): a value per ``TRAVEL_BLOCK`` samples (k, 6) at each of n samples, the last
    block's past the blocks'."""
    each = np.repeat(blocks, TRAVEL_BLOCK, axis=0)
    return np.vstack([each, np.repeat(each[-1:], n - len(each), axis=0)])


def _moves(
    means: ArrayLike, travels: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(path (n + 1, 6): no load, then the ``means``; moved (n, 6): each window's travel
    since the one before, at least the change of the means; ``Hysteresis.window_sigma``)."""
    m = np.asarray(means, dtype=np.float64).reshape(-1, 6)
    path = np.vstack([np.zeros((1, 6)), m])
    moved = np.abs(np.diff(path, axis=0))
    if travels is not None:
        t = np.asarray(travels, dtype=np.float64).reshape(-1, 6)
        moved = np.where(np.isnan(t), moved, np.maximum(t, moved))
    return path, moved


def travel(loads: ArrayLike) -> NDArray[np.float64]:
    """(6,): the total variation (N, N m) of a load's path sampled as ``loads`` (n, 6), in
    time order, its noise left out: means of ``TRAVEL_BLOCK`` samples followed by a
    deadband (a play operator) of ``TRAVEL_DEADBAND`` times their noise, learnt from the
    path itself (the median of its second differences, which a smooth move leaves near
    zero), with what the deadband cuts at the turns put back: the follower trails each
    leg of the path by the deadband's half-width, so it travels two half-widths short at
    every turn (and one over its first leg, left short: a lone excursion of the noise
    past the deadband makes such a leg); NaN when the path is shorter than three blocks.
    The hysteresis is rate-independent: the state moves with what the deadband follows,
    the electrical noise added after it does not."""
    follower, half = follow(loads)
    if not len(follower):
        return half
    steps = np.diff(follower, axis=0)
    way = np.sign(steps)
    heading, legs = np.zeros(6), np.zeros(6)
    for w in way:
        legs += (w != 0) & (w != heading)
        heading = np.where(w != 0, w, heading)
    return np.abs(steps).sum(axis=0) + np.maximum(2.0 * legs - 2.0, 0.0) * half


def reach(loads: ArrayLike) -> NDArray[np.float64]:
    """(2, 6): the lowest and the highest (N, N m) of a load's path sampled as ``loads``
    (n, 6), in time order, as ``travel``'s deadband follows it (a press or an overshoot
    between two windows, beyond what the windows read; its noise left out); NaN when the
    path is shorter than three blocks."""
    follower, half = follow(loads)
    if not len(follower):
        return np.stack([half, half])
    return np.stack([follower.min(axis=0), follower.max(axis=0)])


def follow(loads: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(the path (N, N m) of ``travel``'s deadband follower (k, 6) over the means of
    ``TRAVEL_BLOCK`` samples of a load's path sampled as ``loads`` (n, 6); the deadband's
    half-width (6,): ``TRAVEL_DEADBAND`` sigmas of a block's noise, learnt from the median
    of the blocks' second differences); no points and NaN when there are fewer than
    three blocks."""
    x = np.asarray(loads, dtype=np.float64).reshape(-1, 6)
    n = len(x) // TRAVEL_BLOCK
    if n < 3:
        return np.empty((0, 6)), np.full(6, np.nan)
    blocks = x[: n * TRAVEL_BLOCK].reshape(n, TRAVEL_BLOCK, 6).mean(axis=1)
    bends = np.abs(np.diff(blocks, n=2, axis=0))
    sigma = np.median(bends, axis=0) / (0.6745 * math.sqrt(6.0))  # |N(0, 6 s^2)|'s median
    half = TRAVEL_DEADBAND * sigma
    follower = np.empty_like(blocks)
    follower[0] = blocks[0]
    for i in range(1, n):
        follower[i] = np.clip(follower[i - 1], blocks[i] - half, blocks[i] + half)
    return follower, half
