"""What each phase of an exploration run takes, and the time a run has left (no ROS).

A run goes through its phases in order, each named as the Explore action's feedback names
it: the empty hand's tare (a pass of every tare pose, or a check window at home when a
cached tare may serve), the grasp and lift (home, down to the object, the fingers, lift
and weigh), the object pass (or the object's motion), the verification, the return (the
object put back and the empty hand's window after it, or home holding it) and the
estimate (the estimator's answer, the payload files, the bag closed, the report).

Each phase is planned from the joints it moves through (``PhaseTime``): every move takes
the choreography's ``motion_time`` at the run's speed and then ``settle`` (none when the
arm is already at its goal), every window its dwell, the fingers ``GRIPPER_TIME``. Beside
that sim time, a phase holds the wall time of the sequencer's own work in it (reducing a
tare pass's windows, the estimator's answer, the report): the sim clock runs on through
it, at the rate the run measures (sim s per wall s). The time left at any instant is
what the current phase has left of its plan and every later phase's (``time_left``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise

from com_core.planning.decisions import GRIPPER_TIME, Poses
from com_core.planning.planner import Plan
from com_core.robot.choreography import Choreography

__all__ = [
    "ESTIMATE",
    "GRASP",
    "OBJECT_MOTION",
    "OBJECT_PASS",
    "OVERRUN_LEFT",
    "RETURN",
    "TARE",
    "VERIFICATION",
    "WALL",
    "PhaseTime",
    "motion_run_phases",
    "static_run_phases",
    "time_left",
]

TARE, GRASP, OBJECT_PASS, OBJECT_MOTION = "tare", "grasp and lift", "object pass", "object motion"
VERIFICATION, RETURN, ESTIMATE = "verification", "return", "estimate and report"

WALL = {TARE: 0.8, GRASP: 0.06, OBJECT_PASS: 0.13, OBJECT_MOTION: 0.1, VERIFICATION: 0.03,
        RETURN: 0.07, ESTIMATE: 6.0}  # fmt: skip
"""s (wall) of the sequencer's own work in each phase until a run has measured it: the
tare pass's reduction, the waits for the wrenches, the labels' acknowledgements, and after
the last window the estimator's answer, the payload files, the bag read back and the
report. Measured for a node's first default run on 2 cores beside the sim, the estimator
and the recorder, the sim at 1.7-2x real time and the Panda's joint states at 1 kHz (the
report's first drawing included), over four runs: 0.72-0.84, 0.04-0.08, 0.11-0.15,
0.03-0.04, 0.06-0.08 and 5.7-7.7 s."""
OVERRUN_LEFT = 0.5
"""A phase that has run over its plan is not over: its moves and windows are, its own
work is not; it has this share of its planned wall time left."""

Move = Callable[[Sequence[float], Sequence[float]], float]
"""s (sim) the arm takes from one set of joints (rad) to another."""


@dataclass(frozen=True)
class PhaseTime:
    """A phase of a run (``phase``, as the feedback names it) and what it is planned to
    take: ``sim`` s (sim) of moves, settles, windows and the fingers, and ``wall`` s
    (wall) of the sequencer's own work, over which the sim clock runs on."""

    phase: str
    sim: float
    wall: float = 0.0

    def seconds(self, rate: float) -> float:
        """s (sim) the phase takes when the sim runs ``rate`` sim s per wall s."""
        return self.sim + self.wall * rate


def _mover(motion: Choreography, speed: float, settle: float) -> Move:
    """s (sim) of the move from ``start`` to ``goal`` (rad) and its settle, as the arm
    makes it: ``motion_time`` at ``speed`` rad/s, then ``settle`` s; 0 when the arm is
    already at its goal (it does not move)."""

    def move(start: Sequence[float], goal: Sequence[float]) -> float:
        if all(abs(a - b) < 1e-9 for a, b in zip(start, goal, strict=True)):
            return 0.0
        return motion.motion_time(start, goal, speed) + settle

    return move


def _pass_time(move: Move, start: Sequence[float], poses: Poses, dwell: float) -> float:
    """s (sim) of a pass from ``start`` through ``poses``: a window of ``dwell`` s at
    each, a move to each."""
    joints = [list(start), *(j for _, j in poses)]
    return len(poses) * dwell + sum(move(a, b) for a, b in pairwise(joints))


def static_run_phases(
    plan: Plan,
    tare_poses: Poses,
    poses: Poses,
    *,
    motion: Choreography,
    speed: float,
    home: Sequence[float],
    pick: Sequence[float],
    verify: Sequence[float] | None,
    tare_check: bool,
    bias_dwell: float,
    grasp_check_dwell: float,
    verify_dwell: float,
    bracket: bool,
    release: bool,
    wall: Mapping[str, float] = WALL,
) -> tuple[PhaseTime, ...]:
    """The phases of a static run of ``plan`` from the empty hand at ``home`` (rad), in
    order: the tare (``tare_check``: one ``bias_dwell`` window at home, else a pass of
    ``tare_poses`` at the plan's tare dwell), the grasp (home, ``pick``, the fingers, lift
    home and ``grasp_check_dwell``), the object pass through ``poses`` at the plan's
    dwell, the verification at ``verify`` for ``verify_dwell`` (with ``bracket``,
    kinematic information, and ``verify`` not None), the return (with ``release`` the
    object put back, then with ``bracket`` the empty hand's ``bias_dwell`` window at home;
    without, home holding it) and the estimate. Moves at ``speed`` rad/s and the plan's
    settle; ``wall`` s (wall) of the sequencer's work per phase."""
    move = _mover(motion, speed, plan.settle)

    def down_and_up(start: Sequence[float]) -> float:  # home, the stand, the fingers, home
        return move(start, home) + move(home, pick) + GRIPPER_TIME + move(pick, home)

    if tare_check:
        tare, after_tare = bias_dwell, list(home)
    else:
        tare_dwell = plan.tare_dwell or plan.dwell
        tare, after_tare = _pass_time(move, home, tare_poses, tare_dwell), tare_poses[-1][1]
    phases = [
        PhaseTime(TARE, tare, wall.get(TARE, 0.0)),
        PhaseTime(GRASP, down_and_up(after_tare) + grasp_check_dwell, wall.get(GRASP, 0.0)),
        PhaseTime(
            OBJECT_PASS, _pass_time(move, home, poses, plan.dwell), wall.get(OBJECT_PASS, 0.0)
        ),
    ]
    last = poses[-1][1]
    if bracket and verify_dwell > 0 and verify is not None:
        phases.append(
            PhaseTime(VERIFICATION, move(last, verify) + verify_dwell, wall.get(VERIFICATION, 0.0))
        )
        last = verify
    if not release:
        back = move(last, home)
    else:
        back = down_and_up(last) + (bias_dwell if bracket else 0.0)
    phases.append(PhaseTime(RETURN, back, wall.get(RETURN, 0.0)))
    phases.append(PhaseTime(ESTIMATE, 0.0, wall.get(ESTIMATE, 0.0)))
    return tuple(phases)


def motion_run_phases(
    *,
    motion: Choreography,
    speed: float,
    settle: float,
    home: Sequence[float],
    pick: Sequence[float],
    period: float,
    cycles: int,
    lead: float,
    rest: float,
    hand_moves: bool,
    hand_cycles: int,
    bias_dwell: float,
    grasp_check_dwell: float,
    release: bool,
    wall: Mapping[str, float] = WALL,
) -> tuple[PhaseTime, ...]:
    """The phases of a run in motion from the empty hand at ``home`` (rad), in order: the
    tare (a ``bias_dwell`` window at home and, with ``hand_moves``, the empty hand along
    the excitation, ``hand_cycles`` times its period), the grasp
    (``pick``, the fingers, lift home and ``grasp_check_dwell``), the object along the
    excitation, along the verification's motion, the return (with ``release`` the object
    put back) and the estimate. Each motion starts ``lead`` s after it is sent, lasts
    ``period`` s (the object's ``cycles`` times that) and rests ``rest`` s; moves at
    ``speed`` rad/s and ``settle`` s; ``wall`` s (wall) of the sequencer's work per
    phase."""
    move = _mover(motion, speed, settle)
    excite, verify = lead + cycles * period + rest, lead + period + rest
    hand = lead + hand_cycles * period + rest
    down_and_up = move(home, pick) + GRIPPER_TIME + move(pick, home)
    return (
        PhaseTime(TARE, bias_dwell + (hand if hand_moves else 0.0), wall.get(TARE, 0.0)),
        PhaseTime(GRASP, down_and_up + grasp_check_dwell, wall.get(GRASP, 0.0)),
        PhaseTime(OBJECT_MOTION, excite, wall.get(OBJECT_MOTION, 0.0)),
        PhaseTime(VERIFICATION, verify, wall.get(VERIFICATION, 0.0)),
        PhaseTime(RETURN, down_and_up if release else 0.0, wall.get(RETURN, 0.0)),
        PhaseTime(ESTIMATE, 0.0, wall.get(ESTIMATE, 0.0)),
    )


def time_left(phases: Sequence[PhaseTime], current: int, in_phase: float, rate: float) -> float:
    """s (sim) a run of ``phases`` has left ``in_phase`` s (sim) into its phase
    ``current`` (an index; -1: before the first), the sim running ``rate`` sim s per wall
    s: what the current phase has left of its plan (past it, ``OVERRUN_LEFT`` of its wall
    time) and every later phase's plan."""
    later = sum(p.seconds(rate) for p in phases[current + 1 :])
    if current < 0:
        return later
    phase = phases[current]
    return later + max(phase.seconds(rate) - in_phase, OVERRUN_LEFT * phase.wall * rate)
