"""A run's progress against its planned phases (no ROS): the time it has left, as the
Explore action's feedback reports it (``com_core.planning.run_time``).

The run's time counts from when it first read the clock (its planning is time done); the
time left is the current phase's plan from its start and every later phase's, at the sim's
rate (sim s per wall s) measured since the run's start. A phase that ran over its
sim plan keeps the wall time it took beyond it for the next run's plan (``wall_seen``).
"""

from __future__ import annotations

import math
import time

from com_core.planning.run_time import PhaseTime, time_left
from com_core.sequencing.ports import RunClock

__all__ = ["RunProgress"]


class RunProgress:
    """The progress of one run timed by ``clock``; ``wall_seen`` (s of the sequencer's own
    work per phase, wall) is shared from run to run: what a phase took beyond its plan."""

    def __init__(self, clock: RunClock, wall_seen: dict[str, float]) -> None:
        self._clock, self.wall_seen = clock, wall_seen
        self.phase = ""  # as the feedback names it
        self._phases: tuple[PhaseTime, ...] = ()  # the run's phases as planned
        self._current, self._phase_ns = -1, 0  # the phase under way (index), its start (ns)
        self._mark = (0.0, 0)  # (wall s, sim ns) when the run first read the clock
        self._start_ns, self._planned_s = 0, math.inf  # the recording's start, its plan

    def start(self) -> None:
        """The run reads the clock for the first time: its time counts from now."""
        self._mark = (time.monotonic(), self._clock.now_ns())

    def recording(self, planned_s: float) -> None:
        """The run's recording starts now, ``planned_s`` s (sim) before the run ends."""
        self._start_ns, self._planned_s = self._clock.now_ns(), planned_s

    def _marked(self) -> tuple[float, int]:
        """(wall s, sim ns) the run's time counts from: when it first read the clock, or
        when the sim's clock was first heard if it was not yet then (it read 0)."""
        if not self._mark[1] and (now := self._clock.now_ns()):
            self._mark = (time.monotonic(), now)
        return self._mark

    def elapsed(self, now_ns: int) -> float:
        """s (sim) of the run done at ``now_ns``, its planning included; 0 before its
        recording starts (no plan yet)."""
        return (now_ns - self._marked()[1]) * 1e-9 if self._start_ns else 0.0

    def left(self, now_ns: int) -> float:
        """s (sim) the run has left at ``now_ns``: ``time_left`` of its phases from the
        current one's start at the sim's rate measured so far (a run plans within its
        first 0.5 s, before the rate is known; before it has phases, what ``recording``
        planned; inf before that)."""
        if not self._phases:
            return self._planned_s - (now_ns - self._start_ns) * 1e-9
        in_phase = (now_ns - self._phase_ns) * 1e-9 if self._current >= 0 else 0.0
        return time_left(self._phases, self._current, in_phase, self.measured_rate())

    def plan(self, phases: tuple[PhaseTime, ...]) -> float:
        """Count the progress on ``phases`` from now, none of them under way yet; returns
        the s (sim) they take at the sim's rate measured so far."""
        self._phases, self._current = phases, -1
        return time_left(phases, -1, 0.0, self.measured_rate())

    def measured_rate(self) -> float:
        """sim s per wall s since the run's time counts (``_marked``); 1 within its first
        0.5 s (wall) or when the sim's clock went back."""
        wall, sim = self._marked()
        spent = time.monotonic() - wall
        rate = (self._clock.now_ns() - sim) * 1e-9 / spent if sim and spent >= 0.5 else 1.0
        return rate if rate > 0 else 1.0

    def enter(self, phase: str) -> None:
        """``phase`` starts now: when it is a planned phase after the current one, the
        current one ends (``ended``) and the time left counts from here."""
        names, now = [p.phase for p in self._phases], self._clock.now_ns()
        if phase in names[self._current + 1 :]:
            self.ended(now)
            self._phase_ns, self._current = now, names.index(phase, self._current + 1)
        self.phase = phase

    def ended(self, now_ns: int) -> None:
        """The phase under way ended at ``now_ns``: the time it took beyond its sim plan,
        in wall s at the sim's rate, is its ``wall_seen`` from the next run on."""
        if 0 <= self._current < len(self._phases):
            phase = self._phases[self._current]
            over = (now_ns - self._phase_ns) * 1e-9 - phase.sim
            self.wall_seen[phase.phase] = max(over, 0.0) / self.measured_rate()
