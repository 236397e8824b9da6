"""One exploration: stamped samples and stamped pose labels in, a solution with a status out.

The estimator node and the offline replay both feed an ``Exploration`` and call
``solve``: the same messages give the same numbers, to the last bit, because every
decision depends only on the messages' contents, never on arrival order across topics.
An ``Exploration`` is its inbox (``inbox.Inbox``: what is kept, dropped and counted) and
what its fits take (``fits.FitSetup``); its windows are cut by the labels' stamps
(``cutting``) and ``solve`` gives the ``solution.Solution``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.windows import Window
from com_core.estimation.runs import cutting
from com_core.estimation.runs.cutting import Segments
from com_core.estimation.runs.fit_setup import WRENCHES, FitSetup
from com_core.estimation.runs.inbox import Inbox
from com_core.estimation.runs.solution import Solution, solve
from com_core.sensing.calibration import reading_correction
from com_core.sensing.noise import NoiseModel

__all__ = ["Exploration"]


@dataclass
class Exploration(Inbox, FitSetup):
    """Collects one exploration's samples and labels (``Inbox``) and solves it with its
    ``FitSetup`` (attributes of both; ``method`` first)."""

    def samples(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """All kept samples (``Inbox.samples``), corrected by the gain of the sensor's
        stated hysteresis and its calibration in place, where it has them
        (``sensing.calibration.reading_correction``; kept as read)."""
        stamps, wrenches = Inbox.samples(self)
        correction = reading_correction(self.calibration, self.hysteresis)
        return stamps, wrenches if correction is None else wrenches @ correction.T

    def spans(self, until_ns: int | None = None) -> dict[str, list[tuple[int, int]]]:
        """[start, stop) stamps (ns) of every tare, object and verify window, per label
        (``cutting.spans``)."""
        return cutting.spans(self, until_ns)

    def segments(self, until_ns: int | None = None) -> Segments:
        """(label, samples (n, 6), N and N m) per window label (``cutting.segments``)."""
        return cutting.segments(self, until_ns)

    def window_rotation(self, label: str, until_ns: int | None = None) -> NDArray[np.float64]:
        """R_base_sensor (3, 3) over window ``label`` (``cutting.window_rotation``)."""
        assert self.robot is not None
        return cutting.window_rotation(self, self.robot, label, until_ns)

    def window_time(
        self, label: str, stamps: NDArray[np.int64], until_ns: int | None = None
    ) -> float:
        """The mean stamp (s) of window ``label``'s samples (``cutting.window_time``)."""
        return cutting.window_time(self, label, stamps, until_ns)

    def noise_model(
        self, until_ns: int | None = None, segments: Segments | None = None
    ) -> NoiseModel | None:
        """The sensor's noise learnt from the static windows, else ``noise``
        (``cutting.noise_model``)."""
        return cutting.noise_model(self, self.noise, until_ns, segments)

    def reduced_windows(
        self,
        until_ns: int | None = None,
        noise: NoiseModel | None = None,
        segments: Segments | None = None,
    ) -> tuple[dict[str, Window], list[Window], list[Window], list[str]]:
        """(tare windows by pose, object windows, verify windows, notes on the windows
        refused) of ``segments`` (default ``segments(until_ns)``) with ``noise`` (default
        ``noise_model``; ``cutting.reduced_windows``)."""
        if segments is None:
            segments = self.segments(until_ns)
        if noise is None:
            noise = self.noise_model(until_ns, segments)
        return cutting.reduced_windows(segments, self.sensor, noise)

    def lacking(self, until_ns: int) -> str:
        """What of the input up to ``until_ns`` (a run's ``done``) has not come yet: the
        wrenches, and, when the fit takes the windows' orientations from the joint states,
        those of every joint that moves the sensor (each publisher's stream comes on its
        own: an arm's may lag its gripper's and the sensor's); '' when all has."""
        latest = self.latest_stamp
        if latest is None or latest < until_ns:
            return f"the wrenches (up to {_reached(latest)})"
        if self.information_used([]) == WRENCHES:  # no joint states for the fit
            return ""
        assert self.robot is not None  # information_used: none without it
        joints = self.joint_states_until(self.robot.chain_names)
        if joints is None or joints < until_ns:
            return (
                f"the joint states of the joints that move the sensor (up to {_reached(joints)})"
            )
        return ""

    def solve(self, until_ns: int | None = None) -> Solution:
        """Windows, per-pose tare, estimate and consistency test, with a status
        (``solution.solve``)."""
        return solve(self, self, until_ns)


def _reached(stamp: int | None) -> str:
    return "none" if stamp is None else f"t={stamp * 1e-9:.3f} s"
