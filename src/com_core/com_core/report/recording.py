"""The PNG report of a recording's fit
(``com_core.estimation.recordings.recording_fit``): what the recording held and how well
one load explains it.

``write_recording_report(recording, fit, png)`` writes one figure (1600 x 1000 px):

- top: force and torque against the recording's time (s; N and N m, sensor frame), the
  samples as recorded (thin) and what the fit gives at each (its bias, drift and load
  through each sample's design; dashed), the rests shaded;
- bottom left: each window's residual against the fit, in sigmas of its noise, per axis
  (a band of +-3), the windows left out of the fit not drawn: a misfit that follows the
  orientation, beyond the band, is the calibration's error (common to every window, which
  the fit weighs as such);
- bottom right: the status and reason, the estimate, the bias, the self-check (each half
  predicting the other: its rms residual per axis in N, N m and in sigmas) and the notes.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from com_core.estimation.recordings import Recording, RecordingFit

__all__ = ["write_recording_report"]

_AXES = ("fx", "fy", "fz", "tx", "ty", "tz")
_COLOURS = ("tab:red", "tab:green", "tab:blue") * 2


def write_recording_report(recording: Recording, fit: RecordingFit, png: Path | str) -> Path:
    """Write the report of ``fit`` of ``recording`` to ``png``; returns its path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(16, 10), dpi=100)  # no pyplot: no global figure registry
    FigureCanvasAgg(fig)
    t = recording.times - recording.times[0]
    every = max(1, len(t) // 4000)  # a few thousand points per trace
    predicted = (
        fit.fit.wrenches(recording.designs[::every], recording.times[::every], not fit.whole_load)
        if fit.fit is not None
        else None
    )
    for row, (part, unit) in enumerate(((slice(0, 3), "N"), (slice(3, 6), "N m"))):
        ax = fig.add_axes((0.06, 0.72 - 0.3 * row, 0.9, 0.24))
        for a in range(part.start, part.stop):
            ax.plot(
                t[::every],
                recording.wrenches[::every, a],
                lw=0.6,
                color=_COLOURS[a],
                label=_AXES[a],
            )
            if predicted is not None:
                ax.plot(t[::every], predicted[:, a], lw=1.2, ls="--", color="black")
        rest = recording.omega < 0.005
        ax.fill_between(
            t, 0, 1, where=rest, transform=ax.get_xaxis_transform(), color="0.9", step="mid"
        )
        ax.set_ylabel(unit)
        ax.legend(loc="upper right", ncol=3, fontsize=8)
        if row == 0:
            ax.set_title("the recording (thin), the fit (dashed), rests shaded")
    ax.set_xlabel("s")
    ax = fig.add_axes((0.06, 0.06, 0.45, 0.28))
    if fit.fit is not None:
        residuals = [
            (
                o.time - recording.times[0],
                (o.mean - wrench) / np.sqrt(np.diag(o.window.cov)),
            )
            for o, wrench in _window_residuals(fit)
        ]
        for a in range(6):
            ax.plot(
                [r[0] for r in residuals],
                [r[1][a] for r in residuals],
                ls="none",
                color=_COLOURS[a],
                marker="o" if a < 3 else "^",
                ms=3,
                label=_AXES[a],
            )
        ax.axhspan(-3, 3, color="0.93")
        ax.legend(loc="upper right", ncol=6, fontsize=7)
    ax.set_title(
        "each window's residual, in sigmas of its noise (the calibration's error, common to "
        "every window, is not in it)",
        fontsize=9,
    )
    ax.set_xlabel("s")
    text = "\n".join(textwrap.fill(line, 80) for line in fit.summary().splitlines())
    fig.text(0.54, 0.34, text, va="top", family="monospace", fontsize=8)
    png = Path(png)
    fig.savefig(png, dpi=100)
    return png


def _window_residuals(fit: RecordingFit):
    """(observation, the fit's wrench there) of every window of the recording (not of
    its tare recording, another bias epoch) the fit used."""
    assert fit.fit is not None
    kinematic = fit.fit
    for o in kinematic.observations:
        if o.epoch == 0:
            yield o, kinematic.predict(o.rotation, o.time, o.load, design=o.design)[0]
