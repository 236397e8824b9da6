"""com_core.planning.run_time: what each phase of a run takes, from the joints it moves
through at the run's speed, and the time a run has left (no ROS); measured against the
phases of a recorded run (the sample bag's labels)."""

from __future__ import annotations

import math
from dataclasses import replace
from itertools import pairwise
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import PANDA as PANDA_CONFIG
from conftest import WORKSPACE, choreography

from com_core.bags.cdr import decode_header
from com_core.bags.reader import read_raw
from com_core.contract import DONE, MOVING, POSE_TOPIC
from com_core.planning.decisions import GRIPPER_TIME, RunSettings, plan_within_reach
from com_core.planning.run_time import (
    ESTIMATE,
    GRASP,
    OBJECT_MOTION,
    OBJECT_PASS,
    OVERRUN_LEFT,
    RETURN,
    TARE,
    VERIFICATION,
    PhaseTime,
    motion_run_phases,
    static_run_phases,
    time_left,
)
from com_core.sensing.noise import ar1_noise
from com_core.sequencing.progress import RunProgress

PANDA = choreography("panda")
HOME, PICK = list(PANDA_CONFIG.home_joints), list(PANDA_CONFIG.pick_joints)
VERIFY = PANDA.verify_joints()[0]
SETTINGS = RunSettings(  # the sequencer's parameter defaults
    tilt=math.pi / 6, tilt_axes=("y", "x"), both_directions=True, dwell=0.9, tare_dwell=5.0,
    settle=0.3, speed=1.35, max_tilt=math.pi / 6, raise_tilt=False, target_com_sigma=0.0,
    fewer_poses=False, max_object_time=20.0, sigma_f=0.1, sigma_tau=0.005,
    correlation_time=0.005, rate=1000.0, mass_guess=0.1, com_guess=(0.0,), bias_dwell=3.0,
)  # fmt: skip
RUN = plan_within_reach(SETTINGS, PANDA, ar1_noise([0.1] * 3 + [0.005] * 3, 0.005, 1000.0))
TARE_POSES = PANDA.pose_joints(RUN.plan.tare_plan())
NO_WALL: dict[str, float] = {}


def move(start, goal, speed: float = 1.35) -> float:
    """s (sim) of a move and its settle, as the arm makes it."""
    return PANDA.motion_time(start, goal, speed) + 0.3


def static(**changes) -> tuple[PhaseTime, ...]:
    """The phases of the default static run (kinematic information, a fresh tare pass,
    the object put back), ``changes`` over its arguments."""
    arguments = dict(
        motion=PANDA, speed=1.35, home=HOME, pick=PICK, verify=VERIFY, tare_check=False,
        bias_dwell=3.0, grasp_check_dwell=0.2, verify_dwell=2.0, bracket=True, release=True,
        wall=NO_WALL,
    )  # fmt: skip
    plan = changes.pop("plan", RUN.plan)
    return static_run_phases(plan, TARE_POSES, RUN.poses, **(arguments | changes))


def seconds(phases: tuple[PhaseTime, ...]) -> dict[str, float]:
    return {p.phase: p.sim for p in phases}


def test_a_static_run_goes_through_every_phase_each_from_the_joints_it_moves_through():
    phases = static()
    assert [p.phase for p in phases] == [TARE, GRASP, OBJECT_PASS, VERIFICATION, RETURN, ESTIMATE]
    tare_joints = [j for _, j in TARE_POSES]
    object_joints = [j for _, j in RUN.poses]
    last_tare, last_object = tare_joints[-1], object_joints[-1]
    expected = {
        # from home, at home already: a window at each pose, a move to each but the first
        TARE: 5 * 5.0 + sum(move(a, b) for a, b in pairwise(tare_joints)),
        # home, down to the object, the fingers, lift and weigh
        GRASP: move(last_tare, HOME) + move(HOME, PICK) + GRIPPER_TIME + move(PICK, HOME) + 0.2,
        OBJECT_PASS: 5 * 0.9 + sum(move(a, b) for a, b in pairwise(object_joints)),
        VERIFICATION: move(last_object, VERIFY) + 2.0,
        # the object put back, then the empty hand's window at home
        RETURN: move(VERIFY, HOME) + move(HOME, PICK) + GRIPPER_TIME + move(PICK, HOME) + 3.0,
        ESTIMATE: 0.0,
    }
    for phase, value in seconds(phases).items():
        assert value == pytest.approx(expected[phase], abs=1e-9), phase
    assert seconds(phases)[TARE] > 5 * 5.0 + 4 * 0.3  # the tare dwell, not the object's


def test_a_cached_tare_is_checked_at_home_and_the_grasp_starts_there():
    check, fresh = seconds(static(tare_check=True)), seconds(static())
    assert check[TARE] == 3.0  # one bias_dwell window, the arm at home
    assert check[GRASP] == pytest.approx(fresh[GRASP] - move(TARE_POSES[-1][1], HOME))
    assert {k: v for k, v in check.items() if k not in (TARE, GRASP)} == {
        k: v for k, v in fresh.items() if k not in (TARE, GRASP)
    }


def test_the_wrenches_alone_or_holding_drop_the_phases_the_run_does_not_go_through():
    alone = seconds(static(bracket=False))  # no verification, no empty-hand window after
    assert VERIFICATION not in alone
    put_back = move(RUN.poses[-1][1], HOME) + move(HOME, PICK) + GRIPPER_TIME + move(PICK, HOME)
    assert alone[RETURN] == pytest.approx(put_back)
    holding = seconds(static(release=False))  # home with the object
    assert holding[RETURN] == pytest.approx(move(VERIFY, HOME))
    unreachable = seconds(static(verify=None))  # a verification pose out of reach
    assert VERIFICATION not in unreachable and unreachable[RETURN] > 3.0
    assert VERIFICATION not in seconds(static(verify_dwell=0.0))


def test_moves_take_their_time_at_the_runs_speed_and_settle():
    slow, fast = seconds(static(speed=0.5)), seconds(static(speed=2.0))
    assert slow[OBJECT_PASS] > fast[OBJECT_PASS] and slow[TARE] > fast[TARE]
    settled = seconds(static(plan=replace(RUN.plan, settle=1.3)))
    # four moves between the five poses, each settling a second longer
    assert settled[OBJECT_PASS] == pytest.approx(seconds(static())[OBJECT_PASS] + 4.0)


def test_a_run_in_motion_plans_each_excitation_with_its_lead_and_rest():
    def run(**changes) -> dict[str, float]:
        arguments = dict(
            motion=PANDA, speed=1.35, settle=0.3, home=HOME, pick=PICK, period=3.0, cycles=1,
            lead=0.2, rest=0.3, hand_moves=True, hand_cycles=1, bias_dwell=3.0,
            grasp_check_dwell=0.2, release=True, wall=NO_WALL,
        )  # fmt: skip
        return seconds(motion_run_phases(**(arguments | changes)))

    moving = run()
    assert list(moving) == [TARE, GRASP, OBJECT_MOTION, VERIFICATION, RETURN, ESTIMATE]
    assert moving[TARE] == pytest.approx(3.0 + 3.5)  # at rest, then along the excitation
    assert run(hand_moves=False)[TARE] == 3.0  # the hand's motion fit of an earlier run
    down_and_up = move(HOME, PICK) + GRIPPER_TIME + move(PICK, HOME)
    assert moving[GRASP] == pytest.approx(down_and_up + 0.2)
    assert moving[OBJECT_MOTION] == moving[VERIFICATION] == pytest.approx(3.5)
    assert moving[RETURN] == pytest.approx(down_and_up) and run(release=False)[RETURN] == 0.0
    assert run(period=10.0)[OBJECT_MOTION] == pytest.approx(10.5)
    cycled = run(cycles=3, hand_cycles=3)  # the hand's and the object's, not the verification's
    assert cycled[TARE] == pytest.approx(3.0 + 9.5) and cycled[OBJECT_MOTION] == 9.5
    assert cycled[VERIFICATION] == pytest.approx(3.5)
    longer = run(hand_cycles=4)  # the empty hand's motion alone runs longer
    assert longer[TARE] == pytest.approx(3.0 + 12.5) and longer[OBJECT_MOTION] == 3.5


def test_the_time_left_is_the_current_phases_plan_left_and_every_later_phases():
    phases = (PhaseTime("a", 10.0), PhaseTime("b", 4.0, wall=1.0), PhaseTime("c", 0.0, 3.0))
    assert phases[1].seconds(2.0) == 6.0  # the sim runs on through the wall time
    assert time_left(phases, -1, 0.0, 2.0) == 10.0 + 6.0 + 6.0  # before the first phase
    assert time_left(phases, 0, 4.0, 2.0) == 6.0 + 12.0
    assert time_left(phases, 1, 1.0, 1.0) == 4.0 + 3.0
    # past its plan a phase's moves and windows are done, its own work is not
    assert time_left(phases, 0, 15.0, 1.0) == 8.0
    assert time_left(phases, 1, 9.0, 1.0) == OVERRUN_LEFT * 1.0 + 3.0
    assert time_left(phases, 2, 100.0, 2.0) == OVERRUN_LEFT * 6.0 > 0


def test_progress_from_the_time_left_never_goes_back_however_the_phases_run():
    rng = np.random.default_rng(3)
    phases = tuple(
        PhaseTime(str(k), float(s), float(w))
        for k, (s, w) in enumerate(zip(rng.uniform(0, 10, 6), rng.uniform(0, 2, 6), strict=True))
    )
    for _ in range(20):  # each phase over or under its plan
        actual = [p.seconds(1.0) * rng.uniform(0.5, 3.0) for p in phases]
        progress, elapsed = [], 0.0
        for k, length in enumerate(actual):
            for t in np.linspace(0.0, length, 7):
                left = time_left(phases, k, t, 1.0)
                progress.append((elapsed + t) / (elapsed + t + left) if elapsed + t else 0.0)
            elapsed += length
        assert all(b >= a - 1e-12 for a, b in pairwise(progress))
        assert progress[-1] < 1.0


def sample_phase_starts() -> tuple[dict[str, float], float]:
    """(each phase's start, the end of the last), s (sim), of the sample run (a static run
    of the defaults with a cached tare checked) from its labels: the tare's window, the
    grasp at its end, the object pass at its first window, the verification at the pass's
    end, the return at the verification's end, the end at ``done``."""
    labels = [
        decode_header(raw) for *_, raw in read_raw(WORKSPACE / "bags" / "sample", (POSE_TOPIC,))
    ]
    stamps = [(stamp * 1e-9, label) for stamp, label in labels]
    first = {label: stamp for stamp, label in reversed(stamps)}
    end_of = {a: t for (_, a), (t, b) in pairwise(stamps) if b == MOVING}  # window -> end
    objects = [label for _, label in stamps if label.startswith("object/")]
    starts = {
        TARE: first["tare/home_check"],
        GRASP: end_of["tare/home_check"],
        OBJECT_PASS: first["object/home"],
        VERIFICATION: end_of[objects[-1]],
        RETURN: end_of["verify/diagonal"],
    }
    return starts, first[DONE]


def test_the_time_left_at_each_phase_start_is_within_a_tenth_of_what_a_recorded_run_had_left():
    starts, end = sample_phase_starts()
    phases = static(tare_check=True)[:-1]  # to the done label: no estimate
    assert [p.phase for p in phases] == list(starts)
    for k, (phase, start) in enumerate(starts.items()):
        planned, actual = time_left(phases, k, 0.0, 1.0), end - start
        assert abs(planned / actual - 1) < 0.10, (phase, planned, actual)


def test_a_run_started_before_the_sims_clock_is_heard_measures_its_rate_from_the_first_reading(
    monkeypatch,
):
    """A run that reads the clock before the sim's first /clock (it reads 0) times itself
    from the first reading that is not 0: the sim's rate is measured, not taken as 1."""
    wall = [100.0]
    monkeypatch.setattr("com_core.sequencing.progress.time.monotonic", lambda: wall[0])
    clock = SimpleNamespace(ns=0)
    progress = RunProgress(SimpleNamespace(now_ns=lambda: clock.ns), {})
    progress.start()  # no /clock heard yet
    clock.ns, wall[0] = 4_000_000_000, 101.0
    assert progress.measured_rate() == 1.0  # the first reading: no rate yet
    clock.ns, wall[0] = 10_000_000_000, 104.0  # 6 s (sim) in 3 s (wall)
    assert progress.measured_rate() == pytest.approx(2.0)
