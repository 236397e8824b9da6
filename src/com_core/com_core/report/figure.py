"""A PNG report of one exploration run, read from its bag: what happened, and how well.

``write_report(bag)`` writes ``<bag>/report.png`` (one figure, 1600 x 1100 px):

- left: force and torque against sim time (s, the wrenches' header stamps; N and N m,
  ``ft_sensor``), under a strip of the labelled windows: ``tare/<pose>`` and
  ``object/<pose>`` static windows shaded in two colours, ``moving`` unshaded, ``done``
  marked (label semantics as in ``com_core.contract``);
- right: the estimate against the ground truth, estimate minus truth (0 = truth) for
  the mass (g) and each COM axis (mm, ``ft_sensor``) with 1-sigma (thick) and 3-sigma
  (thin) error bars; without ground truth the estimate itself with its error bars; for a
  run in motion, under them, the inertia's six elements about the COM (kg cm^2) the
  same way (marked "not published" when the motion did not identify it); with no
  estimate (ERROR) the reason, large; under it a table of every number, the status,
  reason, method, chi-square, poses, and which topics the bag lacks;
- bottom left: the sensor's noise, the autocorrelation of the empty hand's windows (all
  static windows when there are none) per axis, each window less its mean, against the
  AR model the estimator learns from them (``com_core.sensing.noise``); for a run in
  motion instead, the measured wrench along the object's motions against the one the
  fit gives (``motion_solution.fitted_wrenches``).

Any topic may be missing: the report is still written and says what is missing.

The ground truth shown is the one ``run`` chooses (the last while held, before done).

The core never imports rclpy: messages are decoded from their CDR bytes with
``com_core.bags.cdr`` (wrenches, labels) and the rosbags type store (the rest).
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.contract import (
    DIAGNOSTICS_TOPIC,
    DONE,
    ESTIMATE_TOPIC,
    MOTION_PREFIX,
    MOTION_TARE,
    MOTION_VERIFY,
    OBJECT_PREFIX,
    POSE_TOPIC,
    STATIC_PREFIXES,
    TARE_PREFIX,
    VERIFY_PREFIX,
    WINDOW_PREFIXES,
    WRENCH_TOPIC,
)
from com_core.estimation.runs.motion_solution import MAX_CHI2_PER_DOF, MOTION
from com_core.estimation.runs.solution import (
    inertia_value,
    noise_line,
    vector_value,
    verification_lines,
)
from com_core.report.run import RunData, motion_fitted, read_run
from com_core.robot.dynamics import INERTIA_ELEMENTS
from com_core.sensing.noise import learn_noise

__all__ = ["write_report"]

_STATUS_COLOURS = {
    "OK": "#2e7d32",
    "WARN": "#ef6c00",
    "ERROR": "#c62828",
    "STALE": "#616161",
    "UNKNOWN": "#616161",
}
_TARE_COLOUR, _OBJECT_COLOUR, _VERIFY_COLOUR = "#6baed6", "#fd8d3c", "#74c476"
_AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z
_SIGMA = "\u03c3"
_MAX_TRACE_POINTS = 4000  # per trace; min/max envelope beyond (about 2 points per pixel)


# --- the numbers --------------------------------------------------------------------------


def _value(values: dict, key: str) -> float | None:
    try:
        v = float(values[key])
    except (KeyError, ValueError):
        return None
    return v if math.isfinite(v) else None


@dataclass(frozen=True)
class _Row:
    """One estimated quantity in display units (g or mm)."""

    name: str
    unit: str
    estimate: float
    sigma: float | None
    truth: float | None

    @property
    def error(self) -> float | None:
        return None if self.truth is None else self.estimate - self.truth


def _rows(run: RunData) -> list[_Row]:
    """Mass (g) and COM x, y, z (mm) of the estimate, with sigma and truth when known."""
    values = run.diagnostic["values"] if run.diagnostic else {}
    if run.estimate is not None:
        mass, com = run.estimate.mass, run.estimate.com.tolist()
    else:
        parts = [_value(values, k) for k in ("mass", "com_x", "com_y", "com_z")]
        if any(p is None for p in parts):
            return []
        mass, com = parts[0], parts[1:]
    truth = run.truth
    rows = [
        _Row(
            "mass",
            "g",
            mass * 1e3,
            _scaled(_value(values, "sigma_mass"), 1e3),
            None if truth is None else truth.mass * 1e3,
        )
    ]
    for i, axis in enumerate("xyz"):
        rows.append(
            _Row(
                f"COM {axis}",
                "mm",
                com[i] * 1e3,
                _scaled(_value(values, f"sigma_com_{axis}"), 1e3),
                None if truth is None else float(truth.com[i]) * 1e3,
            )
        )
    return rows


def _inertia_rows(run: RunData) -> list[_Row]:
    """A run in motion's six inertia elements about the COM (kg cm^2, ``ft_sensor``) with
    sigma, and truth when known, published or only fitted (``inertia_value``); [] for a
    run without them."""
    values = run.diagnostic["values"] if run.diagnostic else {}
    estimate = inertia_value(values)[0] or []
    sigma = vector_value(values, "sigma_inertia") or []
    if not len(estimate) == len(sigma) == len(INERTIA_ELEMENTS):
        return []
    truth = [None] * len(estimate) if run.truth is None else (1e4 * run.truth.inertia).tolist()
    return [
        _Row(f"I{name[1:]}", "kg cm2", 1e4 * e, 1e4 * s, t)
        for name, e, s, t in zip(INERTIA_ELEMENTS, estimate, sigma, truth, strict=True)
    ]


def _scaled(v: float | None, k: float) -> float | None:
    return None if v is None else v * k


def _windows(run: RunData) -> list[tuple[float, float, str]]:
    """(start s, stop s, label) of every static window and motion; each ends at the next
    label."""
    end = run.stamps[-1] if run.stamps.size else (run.labels[-1][0] if run.labels else 0)
    out = []
    for k, (start, label) in enumerate(run.labels):
        if label.startswith(WINDOW_PREFIXES):
            stop = run.labels[k + 1][0] if k + 1 < len(run.labels) else max(end, start)
            out.append((start * 1e-9, stop * 1e-9, label))
    return out


# --- drawing ------------------------------------------------------------------------------


def _envelope(
    t: NDArray[np.float64], y: NDArray[np.float64], max_points: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Min/max envelope of ``y`` (n, k) in buckets: looks like every sample, plots fast."""
    n = len(t)
    if n <= max_points:
        return t, y
    size = math.ceil(2 * n / max_points)
    m = n // size
    tb = t[: m * size].reshape(m, size)
    yb = y[: m * size].reshape(m, size, -1)
    t_out = np.column_stack([tb[:, 0], tb[:, -1]]).ravel()
    y_out = np.stack([yb.min(axis=1), yb.max(axis=1)], axis=1).reshape(2 * m, -1)
    return np.concatenate([t_out, t[m * size :]]), np.concatenate([y_out, y[m * size :]])


def _draw_traces(fig, run: RunData, rect: tuple[float, float, float, float]) -> None:
    """Window strip, force panel and torque panel in ``rect`` (left, bottom, width, height)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    left, bottom, width, height = rect
    strip_h = 0.055
    gap = 0.012
    panel_h = (height - strip_h - 2 * gap) / 2
    ax_strip = fig.add_axes((left, bottom + height - strip_h, width, strip_h))
    ax_f = fig.add_axes((left, bottom + panel_h + gap, width, panel_h), sharex=ax_strip)
    ax_t = fig.add_axes((left, bottom, width, panel_h), sharex=ax_strip)

    windows = _windows(run)
    t = run.stamps * 1e-9
    times = [*t[:1], *t[-1:], *(s * 1e-9 for s, _ in run.labels)]
    t0, t1 = (min(times), max(times)) if times else (0.0, 1.0)
    if t1 <= t0:
        t1 = t0 + 1.0
    pad = 0.005 * (t1 - t0)
    ax_strip.set_xlim(t0 - pad, t1 + pad)

    suspect = run.diagnostic["values"].get("suspect_pose") if run.diagnostic else None
    px_per_s = width * fig.get_figwidth() * fig.dpi / (t1 - t0 + 2 * pad)
    for start, stop, label in windows:
        tare = label.startswith(TARE_PREFIX) or label == MOTION_TARE
        verify = label.startswith(VERIFY_PREFIX) or label == MOTION_VERIFY
        colour = _TARE_COLOUR if tare else _VERIFY_COLOUR if verify else _OBJECT_COLOUR
        for ax in (ax_f, ax_t):
            ax.axvspan(start, stop, color=colour, alpha=0.18, lw=0)
        bad = not tare and suspect not in (None, "", "None") and label == OBJECT_PREFIX + suspect
        ax_strip.axvspan(
            start,
            stop,
            facecolor=colour,
            alpha=0.8,
            edgecolor="#b71c1c" if bad else "white",
            lw=2.5 if bad else 0.8,
        )
        pose = "motion" if label.startswith(MOTION_PREFIX) else label.split("/", 1)[1]
        fits = (stop - start) * px_per_s > 7.0 * len(pose) + 6
        ax_strip.text(
            (start + stop) / 2,
            0.5,
            pose + (" (!)" if bad else ""),
            ha="center",
            va="center",
            rotation=0 if fits else 90,
            fontsize=9 if fits else 7.5,
            color="#b71c1c" if bad else "black",
            clip_on=True,
        )
    done_lines = [s * 1e-9 for s, lbl in run.labels if lbl == DONE]
    for done in done_lines:
        for ax in (ax_strip, ax_f, ax_t):
            ax.axvline(done, color="black", ls="--", lw=1.4)
    ax_strip.set_ylim(0, 1)
    ax_strip.set_yticks([])
    ax_strip.tick_params(labelbottom=False, bottom=False)
    ax_strip.set_title(
        "Wrench on the sensor (ft_sensor frame), the static windows and the motions",
        loc="left",
        fontsize=12,
        fontweight="bold",
        pad=24,
    )
    handles = [
        Patch(color=_TARE_COLOUR, label="empty hand"),
        Patch(color=_OBJECT_COLOUR, label="object"),
        Patch(color=_VERIFY_COLOUR, label="verification (no fit)"),
        Line2D([], [], color="black", ls="--", label="done"),
    ]
    ax_strip.legend(
        handles=handles,
        loc="lower right",
        bbox_to_anchor=(1.0, 1.0),
        ncol=4,
        fontsize=9,
        frameon=False,
        borderaxespad=0.1,
    )
    if not run.labels:
        _centred_text(ax_strip, f"no labels ({POSE_TOPIC} missing)", 10)

    if run.stamps.size:
        tt, ww = _envelope(t, run.wrenches, _MAX_TRACE_POINTS)
        for ax, cols, names, unit in (
            (ax_f, slice(0, 3), ("$f_x$", "$f_y$", "$f_z$"), "force (N)"),
            (ax_t, slice(3, 6), (r"$\tau_x$", r"$\tau_y$", r"$\tau_z$"), "torque (N m)"),
        ):
            for k, (colour, name) in enumerate(zip(_AXIS_COLOURS, names, strict=True)):
                ax.plot(tt, ww[:, cols][:, k], color=colour, lw=0.8, label=name)
            ax.set_ylabel(unit)
            ax.legend(loc="upper left", ncol=3, fontsize=9, framealpha=0.85)
    else:
        for ax in (ax_f, ax_t):
            ax.set_yticks([])
            _centred_text(ax, f"no wrench messages ({WRENCH_TOPIC} missing)", 12)
    for ax in (ax_f, ax_t):
        ax.grid(True, color="#dddddd", lw=0.6)
        ax.margins(x=0)
    ax_f.tick_params(labelbottom=False)
    ax_t.set_xlabel("sim time (s, header stamps)")
    if not times:
        ax_t.tick_params(labelbottom=False)


_NOISE_LAGS = 60  # samples shown in the autocorrelation


def _noise_segments(run: RunData) -> list[NDArray[np.float64]]:
    """The second halves (settled) of the empty hand's windows, else of every static
    window: (n, 6) each, N and N m."""
    windows = [w for w in _windows(run) if w[2].startswith(STATIC_PREFIXES)]
    tares = [w for w in windows if w[2].startswith(TARE_PREFIX)] or windows
    t = run.stamps * 1e-9
    out = []
    for start, stop, _ in tares:
        x = run.wrenches[(t >= start) & (t < stop)]
        out.append(x[len(x) // 2 :])
    return out


def _draw_noise(fig, run: RunData, rect: tuple[float, float, float, float]) -> None:
    """The measured autocorrelation of ``_noise_segments`` per axis against the learnt
    model's (dashed), lags in ms."""
    ax = fig.add_axes(rect)
    ax.set_title(
        "Sensor noise: autocorrelation of the empty hand's windows (dashed: the model learnt)",
        loc="left",
        fontsize=11,
        fontweight="bold",
    )
    segments = [x for x in _noise_segments(run) if len(x) > _NOISE_LAGS]
    steps = np.diff(run.stamps)
    rate = 1e9 / float(np.median(steps[steps > 0])) if steps.size and (steps > 0).any() else 1e3
    model = learn_noise(segments, rate) if segments else None
    if model is None or not np.any(model.variance > 0):
        _centred_text(ax, "too few static samples to show the noise's correlation", 10)
        ax.set_xticks([])
        ax.set_yticks([])
        return
    products = np.zeros((_NOISE_LAGS + 1, 6))
    counts = np.zeros(_NOISE_LAGS + 1)
    for x in segments:
        y = x - x.mean(axis=0)
        for k in range(_NOISE_LAGS + 1):
            products[k] += (y[: len(y) - k] * y[k:]).sum(axis=0)
            counts[k] += len(y) - k
    gamma = products / counts[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        measured = np.where(gamma[0] > 0, gamma / gamma[0], 0.0)
    lags = np.arange(_NOISE_LAGS + 1) / rate * 1e3
    names = ("$f_x$", "$f_y$", "$f_z$", r"$\tau_x$", r"$\tau_y$", r"$\tau_z$")
    learnt = model.autocorrelation(_NOISE_LAGS)
    for a, name in enumerate(names):
        colour = _AXIS_COLOURS[a % 3]
        style = "-" if a < 3 else ":"
        ax.plot(lags, measured[:, a], color=colour, ls=style, lw=1.1, label=name)
        ax.plot(lags, learnt[:, a], color=colour, ls="--", lw=0.8, alpha=0.7)
    ax.axhline(0.0, color="#999999", lw=0.6)
    ax.set_xlabel("lag (ms)")
    ax.set_ylabel("autocorrelation")
    ax.set_xlim(0, lags[-1])
    ax.grid(True, color="#dddddd", lw=0.6)
    ax.legend(loc="upper right", ncol=6, fontsize=8.5, framealpha=0.85)


def _draw_motion_fit(
    fig,
    run: RunData,
    fitted: list[tuple[str, NDArray[np.float64], NDArray[np.float64]]],
    rect: tuple[float, float, float, float],
) -> None:
    """The measured wrench along the object's motions against the one the fit gives
    (black; ``report.run.motion_fitted``): forces left, torques right, the motions one
    after the other (s from each one's start)."""
    left, bottom, width, height = rect
    t = run.stamps * 1e-9
    for k, (cols, unit) in enumerate(((slice(0, 3), "force (N)"), (slice(3, 6), "torque (N m)"))):
        ax = fig.add_axes((left + k * (width / 2 + 0.02), bottom, width / 2 - 0.02, height))
        offset = 0.0
        for label, at, wrench in fitted:
            inside = (t >= at[0]) & (t <= at[-1])
            x = t[inside] - at[0] + offset
            for a, colour in enumerate(_AXIS_COLOURS):
                ax.plot(x, run.wrenches[inside][:, cols][:, a], color=colour, lw=0.6, alpha=0.6)
                ax.plot(at - at[0] + offset, wrench[:, cols][:, a], color="black", lw=0.8)
            ax.axvline(offset, color="#999999", lw=0.6)
            ax.text(offset, 1.0, f" {label}", transform=ax.get_xaxis_transform(),
                    fontsize=8.5, va="bottom")  # fmt: skip
            offset += at[-1] - at[0]
        ax.set_ylabel(unit)
        ax.set_xlabel("s from each motion's start")
        ax.grid(True, color="#dddddd", lw=0.6)
        ax.margins(x=0)
        if k == 0:
            ax.set_title(
                "Along the object's motions: measured (colours: x, y, z) and fitted (black)",
                loc="left", fontsize=11, fontweight="bold", pad=14,
            )  # fmt: skip


def _right_edge(fig, artist, renderer) -> float:
    """Right edge of a drawn artist, in figure coordinates."""
    return fig.transFigure.inverted().transform(artist.get_window_extent(renderer).p1)[0]


def _bottom_edge(fig, artist, renderer) -> float:
    """Bottom edge of a drawn artist, in figure coordinates."""
    return fig.transFigure.inverted().transform(artist.get_window_extent(renderer).p0)[1]


def _error_bar(ax, x: float, y: float, sigma: float | None, colour: str) -> None:
    """A point at (``x``, ``y``) with its 1-sigma (thick) and 3-sigma (thin) bars."""
    if sigma is not None:
        ax.errorbar(x, y, yerr=3 * sigma, fmt="none", ecolor=colour, elinewidth=1.2,
                    capsize=12, capthick=1.2, alpha=0.6)  # fmt: skip
        ax.errorbar(x, y, yerr=sigma, fmt="none", ecolor=colour, elinewidth=9, capsize=0,
                    alpha=0.85)  # fmt: skip
    ax.plot(x, y, "o", color="black", ms=6, zorder=5)


def _draw_inertia(
    fig, rows: list[_Row], rect: tuple[float, float, float, float], published: bool
) -> None:
    """The inertia's six elements (kg cm^2) on one scale, as ``_draw_bars`` draws a row:
    estimate minus truth (or the estimate) with 1- and 3-sigma bars, in ``rect``; marked
    when it was not ``published``."""
    from matplotlib.ticker import MaxNLocator

    with_truth = rows[0].truth is not None
    ax = fig.add_axes(rect)
    for k, row in enumerate(rows):
        _error_bar(ax, k, row.error if with_truth else row.estimate, row.sigma, "#7b1fa2")
    if with_truth:
        ax.axhline(0.0, color="#2e7d32", lw=1.5, zorder=1)
    ax.set_xlim(-0.6, len(rows) - 0.4)
    ax.set_xticks(range(len(rows)), [row.name for row in rows], fontsize=10)
    ax.yaxis.set_major_locator(MaxNLocator(4))
    ax.grid(True, axis="y", color="#dddddd", lw=0.6)
    what = "estimate - truth" if with_truth else "estimate"
    ax.set_title(f"inertia about the COM, {what} (kg cm$^2$, ft_sensor)", fontsize=10)
    if not published:
        ax.text(0.01, 0.96, "not published: a principal moment within its sigma", fontsize=8,
                color="#b71c1c", transform=ax.transAxes, va="top", zorder=5,
                bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.85})  # fmt: skip


def _draw_bars(fig, rows: list[_Row], rect: tuple[float, float, float, float]) -> None:
    """Mass and COM panels: error (or value) with 1-sigma and 3-sigma bars, in ``rect``."""
    from matplotlib.ticker import MaxNLocator

    left, bottom, width, height = rect
    with_truth = rows[0].truth is not None
    title = "Estimate minus ground truth (0 = truth)" if with_truth else "Estimate"
    fig.text(left - 0.03, bottom + height + 0.06, title, fontsize=12, fontweight="bold")
    if not with_truth:
        fig.text(
            left + 0.045,
            bottom + height + 0.06,
            "no ground truth",
            fontsize=12,
            color="#c62828",
            fontweight="bold",
        )
    fig.text(
        left - 0.03,
        bottom + height + 0.043,
        ("point: estimate - truth" if with_truth else "point: estimate")
        + (
            ";  thick bar: 1 sigma;  thin bar: 3 sigma"
            if rows[0].sigma is not None
            else ";  no sigmas (no diagnostics)"
        ),
        fontsize=9,
        color="#444444",
    )
    # the mass, then the COM axes (one shared scale when they are errors)
    gaps = [0.05, 0.012, 0.012] if with_truth else [0.045, 0.04, 0.04]
    w = (width - sum(gaps)) / 4
    x = left
    axes = []
    for k, row in enumerate(rows):
        share = axes[1] if (with_truth and k >= 2) else None
        ax = fig.add_axes((x, bottom, w, height), sharey=share)
        axes.append(ax)
        x += w + (gaps[k] if k < 3 else 0.0)
        colour = "#555555" if k == 0 else _AXIS_COLOURS[k - 1]
        y = row.error if with_truth else row.estimate
        _error_bar(ax, 0, y, row.sigma, colour)
        if with_truth:
            ax.axhline(0.0, color="#2e7d32", lw=1.5, zorder=1)
        ax.set_xlim(-1, 1)
        ax.set_xticks([0], [f"{row.name}\n({row.unit})"], fontsize=10)
        ax.yaxis.set_major_locator(MaxNLocator(6))
        ax.grid(True, axis="y", color="#dddddd", lw=0.6)
        value = f"{y:+.3f}" if with_truth else f"{y:.2f}"
        sigma = "" if row.sigma is None else f"\n1{_SIGMA} {row.sigma:.3f}"
        ax.set_title(value + sigma, fontsize=9.5, color=colour if k else "black")
    for ax in axes:
        lo, hi = ax.get_ylim()
        if with_truth:  # keep the truth line in view
            lo, hi = min(lo, 0.0), max(hi, 0.0)
        span = hi - lo or 1.0
        ax.set_ylim(lo - 0.04 * span, hi + 0.04 * span)
    axes[0].set_ylabel("estimate - truth (g)" if with_truth else "mass (g)")
    axes[1].set_ylabel("estimate - truth (mm)" if with_truth else "COM (mm, ft_sensor)")
    if with_truth:
        for ax in axes[2:]:
            ax.tick_params(labelleft=False)


def _draw_no_estimate(fig, run: RunData, rect: tuple[float, float, float, float]) -> None:
    """The reason there is no estimate, prominently, in ``rect``."""
    from matplotlib.patches import FancyBboxPatch

    ax = fig.add_axes(rect)
    ax.set_axis_off()
    colour = _STATUS_COLOURS["ERROR"]
    if run.diagnostic is not None:
        reason = run.diagnostic["message"] or "(the estimator gave no reason)"
    else:
        reason = "no estimate and no diagnostics in the bag: did com_estimator run?"
    ax.add_patch(
        FancyBboxPatch(
            (0.02, 0.04),
            0.96,
            0.92,
            boxstyle="round,pad=0.01",
            transform=ax.transAxes,
            fc="#ffebee",
            ec=colour,
            lw=2,
        )
    )
    _centred_text(ax, "NO ESTIMATE", 26, y=0.8, colour=colour, fontweight="bold")
    _centred_text(ax, "reason:", 11, y=0.6, colour="#3e0000")
    _centred_text(ax, textwrap.fill(reason, 50), 13, y=0.56, colour="#3e0000", va="top")


def _centred_text(
    ax, text: str, fontsize: float, y: float = 0.5, colour: str = "#c62828", **style
) -> None:
    """``text`` centred across ``ax`` at height ``y`` (axes coordinates; ``style``: more
    matplotlib text properties)."""
    style.setdefault("va", "center")
    ax.text(
        0.5, y, text, transform=ax.transAxes, ha="center", color=colour, fontsize=fontsize, **style
    )


def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _summary_lines(run: RunData, rows: list[_Row]) -> list[str]:
    """The numbers, as monospace lines (<= 64 characters)."""
    values = run.diagnostic["values"] if run.diagnostic else {}
    lines = []
    if rows:
        lines.append(
            f"{'':11}{'estimate':>10}{'1' + _SIGMA:>8}{'truth':>10}{'error':>9}"
            f"{'err/' + _SIGMA:>7}"
        )
        for r in rows:
            ratio = r.error / r.sigma if r.error is not None and r.sigma else None
            lines.append(
                f"{r.name + ' ' + r.unit:<11}{r.estimate:>10.3f}{_fmt(r.sigma, '.3f'):>8}"
                f"{_fmt(r.truth, '.3f'):>10}{_fmt(r.error, '+.3f'):>9}{_fmt(ratio, '+.2f'):>7}"
            )
        lines.append("")
    if quality := _fit_quality(values):
        lines.append(f"chi2/dof   {quality}")
    lines += _kinematic_lines(values)
    suspect = values.get("suspect_pose")
    if suspect not in (None, "", "None"):
        lines.append(f"suspect    {suspect} (the object moved in the grasp?)")
    poses = [p for p in values.get("poses", "").split(",") if p]
    if poses:
        lines += textwrap.wrap(
            f"poses      {len(poses)}: {', '.join(poses)}", 64, subsequent_indent=" " * 11
        )
    samples = values.get("samples")
    n_wrench = run.counts.get(WRENCH_TOPIC, 0)
    span = (run.stamps[-1] - run.stamps[0]) * 1e-9 if run.stamps.size > 1 else 0.0
    lines.append(f"wrenches   {n_wrench} messages over {span:.1f} s")
    if samples:
        lines.append(f"           {samples} samples used by the estimator")
    lines.append(f"labels     {len(run.labels)}, windows and motions {len(_windows(run))}")
    lines.append("")
    lines += textwrap.wrap(f"truth      {run.truth_note}", 64, subsequent_indent=" " * 11)
    if run.truth is not None and not rows:
        c = run.truth.com * 1e3
        lines.append(
            f"           {run.truth.mass * 1e3:.3f} g, COM ({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}) mm"
        )
    if run.object_text:
        lines += textwrap.wrap(f"object     {run.object_text}", 64, subsequent_indent=" " * 11)
    if run.hand is not None:
        c = run.hand.com * 1e3
        lines.append(
            f"hand       {run.hand.mass:.3f} kg, COM ({c[0]:.1f}, {c[1]:.1f}, {c[2]:.1f}) mm"
        )
    if run.estimate is None and rows:
        lines.append(f"estimate   from {DIAGNOSTICS_TOPIC} ({ESTIMATE_TOPIC} missing)")
    return lines


def _fit_quality(values: dict) -> str | None:
    """The fit's chi^2 over its degrees of freedom and its test, after "chi2/dof": at rest
    the chi-square's p-value; in motion chi^2/dof against what the run's one-rigid-load
    test allowed (no p-value: ``motion_solution.allowed_chi2_per_dof``; a run recorded
    before the allowance was kept: ``MAX_CHI2_PER_DOF`` times what is explained); None
    without them."""
    chi2, dof = _value(values, "chi2"), _value(values, "dof")
    if chi2 is None or not dof:
        return None
    if values.get("excitation") == MOTION:
        allowed = _value(values, "chi2_allowed_per_dof")
        if allowed is None:
            allowed = MAX_CHI2_PER_DOF * (_value(values, "chi2_expected_per_dof") or math.nan)
        return f"{chi2 / dof:.3f} (one rigid load up to {allowed:.3f})"
    return f"{chi2:.2f} / {dof:.0f},  p = {_fmt(_value(values, 'p_value'), '.3g')}"


def _kinematic_lines(values: dict) -> list[str]:
    """The kinematic fit's own numbers from the diagnostic values: the COM sigma the
    wrenches alone give on the same windows, the bias drift since the tare, the hand
    fitted, the mounting, the base tilt and the verification (none for the wrenches
    alone)."""

    lines = []
    alone = vector_value(values, "wrenches_sigma_com", 1e3)
    if alone:
        lines.append(
            f"wrenches   alone: COM 1{_SIGMA} ({', '.join(f'{v:.3f}' for v in alone)}) mm"
        )
    drift = vector_value(values, "bias_drift")
    if drift:
        lines.append(
            f"bias drift {math.hypot(*drift[:3]):.3f} N, {math.hypot(*drift[3:]) * 1e3:.2f} mN m"
            " since the cached tare"
        )
    if "hand_mass" in values and (com := vector_value(values, "hand_com", 1e3)):
        lines.append(
            f"hand fit   {float(values['hand_mass']):.3f} kg, COM "
            f"({', '.join(f'{v:.1f}' for v in com)}) mm"
        )
    for key, name in (("mount_rpy", "mounting   rpy"), ("base_tilt", "base tilt ")):
        if angles := vector_value(values, key):
            lines.append(f"{name} ({', '.join(f'{math.degrees(v):.2f}' for v in angles)}) deg")
    for line in verification_lines(values):
        lines += textwrap.wrap(line, 64, subsequent_indent=" " * 11)
    if noise := noise_line(values):
        lines += textwrap.wrap(noise, 64, subsequent_indent=" " * 11)
    return lines


def _draw_summary(fig, run: RunData, rows: list[_Row], left: float, top: float) -> None:
    """The numbers table from (``left``, ``top``) down, then what the bag lacks."""
    renderer = fig.canvas.get_renderer()
    fig.text(left, top, "Numbers", fontsize=12, fontweight="bold", va="top")
    table = fig.text(
        left,
        top - 0.025,
        "\n".join(_summary_lines(run, rows)),
        va="top",
        ha="left",
        family="monospace",
        fontsize=9.5,
        linespacing=1.4,
    )
    problems = []
    if run.missing:
        problems.append("missing topics: " + ", ".join(run.missing))
    problems += run.notes + run.incomplete + run.commands
    if problems:
        text = "\n".join(textwrap.fill(p, 72, subsequent_indent="    ") for p in problems)
        fig.text(
            left + 0.003,
            _bottom_edge(fig, table, renderer) - 0.025,
            text,
            va="top",
            ha="left",
            fontsize=9.5,
            color="#8a4b00",
            linespacing=1.4,
            bbox={"boxstyle": "round,pad=0.5", "fc": "#fff8e1", "ec": "#ffb300"},
        )


def _draw_banner(fig, run: RunData) -> None:
    """Run id, status, method and fit quality on one line; the reason under it."""
    renderer = fig.canvas.get_renderer()
    status = run.status
    colour = _STATUS_COLOURS.get(status, "#616161")
    values = run.diagnostic["values"] if run.diagnostic else {}
    y = 0.965
    title = fig.text(0.02, y, f"Run {run.name}", fontsize=17, fontweight="bold", va="center")
    badge = fig.text(
        _right_edge(fig, title, renderer) + 0.015,
        y,
        status,
        fontsize=15,
        fontweight="bold",
        color="white",
        va="center",
        bbox={"boxstyle": "round,pad=0.35", "fc": colour, "ec": "none"},
    )
    poses = [p for p in values.get("poses", "").split(",") if p]
    facts = [
        f"method {values['method']}" if "method" in values else None,
        f"information {values['information']}" if "information" in values else None,
        f"{len(poses)} poses" if poses else None,
        f"chi2/dof {quality}" if (quality := _fit_quality(values)) else None,
    ]
    line = fig.text(
        _right_edge(fig, badge, renderer) + 0.02,
        y,
        "    |    ".join(f for f in facts if f),
        fontsize=12.5,
        va="center",
    )
    start, stop = line.get_position()[0], _right_edge(fig, line, renderer)
    if stop > 0.985:  # a long run id: shrink the line to fit
        line.set_fontsize(max(7.0, 12.5 * (0.985 - start) / (stop - start)))
    if run.diagnostic is not None:
        reason = run.diagnostic["message"] or "(no reason given)"
    else:
        reason = f"no com_estimator status on {DIAGNOSTICS_TOPIC}"
    fig.text(
        0.02,
        0.925,
        textwrap.shorten("reason: " + reason, 210),
        fontsize=11.5,
        va="center",
        color="#333333" if status == "OK" else colour,
    )


def write_report(
    bag: Path | str, png: Path | str | None = None, run: RunData | None = None
) -> Path:
    """Read the run's bag and write its PNG report (default: <bag>/report.png); return the path.

    Parameters
    ----------
    bag : rosbag2 directory (MCAP) of one run.
    png : output file; its directory is created if needed.
    run : the bag already read (``read_run``), if it was.

    Returns
    -------
    The PNG's path (1600 x 1100 px).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    bag = Path(bag)
    if not bag.is_dir():
        raise FileNotFoundError(f"{bag} is not a rosbag2 directory")
    png = bag / "report.png" if png is None else Path(png)
    run = read_run(bag) if run is None else run
    rows = _rows(run)

    fig = Figure(figsize=(16, 11), dpi=100)  # no pyplot: no global figure registry
    FigureCanvasAgg(fig)  # the Agg backend, for this figure only
    _draw_banner(fig, run)
    _draw_traces(fig, run, (0.055, 0.3, 0.54, 0.56))
    values = run.diagnostic["values"] if run.diagnostic else {}
    fitted = motion_fitted(bag, values)
    if fitted:
        _draw_motion_fit(fig, run, fitted, (0.055, 0.06, 0.54, 0.16))
    else:
        _draw_noise(fig, run, (0.055, 0.06, 0.54, 0.16))
    inertia = _inertia_rows(run)
    if rows and inertia:
        _draw_bars(fig, rows, (0.69, 0.645, 0.295, 0.155))
        _draw_inertia(fig, inertia, (0.69, 0.485, 0.295, 0.09), inertia_value(values)[1])
    elif rows:
        _draw_bars(fig, rows, (0.69, 0.5, 0.295, 0.3))
    else:
        _draw_no_estimate(fig, run, (0.655, 0.5, 0.335, 0.36))
    _draw_summary(fig, run, rows, 0.66, 0.43)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=100)
    fig.clear()
    return png
