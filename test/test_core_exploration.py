"""com_core.exploration: what an Exploration keeps, drops and says about its input."""

from __future__ import annotations

import numpy as np

from com_core.exploration import (
    ERROR,
    MAX_LABEL_GAP,
    MAX_LABEL_LENGTH,
    OK,
    Exploration,
)
from com_core.planner import Plan
from com_core.synthetic import Load, exploration_stream

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))
PLAN = Plan(dwell=0.3, gravity_home=(0, 0, 1))


def fed(stream, exploration: Exploration | None = None, shift_ns: int = 0) -> Exploration:
    """``exploration`` (a new one by default) fed ``stream`` with its stamps shifted."""
    ex = Exploration() if exploration is None else exploration
    ex.add_samples(stream.stamps + shift_ns, stream.wrenches, "ft_sensor")
    for stamp, label in stream.labels:
        ex.add_label(stamp + shift_ns, label)
    return ex


def test_duplicate_stamps_are_named_apart_from_samples_out_of_order():
    ex = Exploration()
    ex.add_samples([10, 20, 20, 30, 15, 30, 40], np.zeros((7, 6)), "ft_sensor")
    assert ex.dropped == {"with a duplicate stamp": 2, "out of time order": 1}
    assert ex.samples()[0].tolist() == [10, 20, 30, 40]


def test_a_run_whose_labels_stopped_is_dropped_when_a_new_one_starts():
    """A sequencer killed mid-run leaves labels and samples behind; a new run's windows
    of the same names must not merge with them (they would look like motion of ~m g)."""
    rng = np.random.default_rng(5)
    aborted = exploration_stream(PLAN, Load(0.5, (0.0, 0.03, 0.12)), HAND, rng)
    cut = next(s for s, lbl in aborted.labels if lbl == "object/tilt_y+")
    keep = aborted.stamps < cut
    ex = Exploration()
    ex.add_samples(aborted.stamps[keep], aborted.wrenches[keep], "ft_sensor")
    for stamp, label in aborted.labels:
        if stamp <= cut:
            ex.add_label(stamp, label)
    clean = exploration_stream(PLAN, LOAD, HAND, rng)
    later = round((MAX_LABEL_GAP + 1.0) * 1e9) + int(aborted.stamps[-1])
    solution = fed(clean, ex, later).solve()
    assert ex.stale_drops == 1
    assert solution.status == OK, solution.reason
    assert abs(solution.estimate.mass - LOAD.mass) < 4 * solution.estimate.sigma_mass
    # the same two runs within the gap are one exploration: its windows merge and fail
    ex = Exploration()
    for stamp, label in aborted.labels:
        if stamp <= cut:
            ex.add_label(stamp, label)
    ex.add_samples(aborted.stamps[keep], aborted.wrenches[keep], "ft_sensor")
    merged = fed(clean, ex, round(5e9) + int(aborted.stamps[-1])).solve()
    assert ex.stale_drops == 0 and merged.status != OK


def test_an_overlong_label_is_refused_and_never_copied_whole():
    stream = exploration_stream(PLAN, LOAD, HAND, np.random.default_rng(6))
    ex = fed(stream)
    ex.add_label(int(stream.stamps[-1]), "object/" + "x" * 10_000)
    solution = ex.solve()
    assert f"dropped 1 labels longer than {MAX_LABEL_LENGTH} characters" in solution.reason
    assert len(solution.reason) < 400 and "xxxx" in solution.reason


def test_an_empty_grasp_is_named_as_such_not_as_a_tare_with_the_object():
    """Object windows that weigh what the tare does: the object was not held."""
    empty = Load(1e-9, (0.0, 0.0, 0.1))
    stream = exploration_stream(PLAN, empty, HAND, np.random.default_rng(7))
    solution = fed(stream).solve()
    assert solution.status == ERROR
    assert "no load beyond the hand" in solution.reason and "not held" in solution.reason
    assert "tare taken with the object" not in solution.reason


def test_late_samples_are_dropped_but_a_restarted_clock_is_not():
    ex = Exploration()
    ex.add_samples([1, 2, 3, 8_000_000_000, 8_000_000_001], np.zeros((5, 6)), "ft_sensor")
    late_and_restarted = [1_000_000_000, 1_000_000_001, 999_000_000, 1_000_000_002]
    assert ex.add_samples(late_and_restarted, np.zeros((4, 6)), "ft_sensor") == 3
    assert ex.dropped == {"out of time order": 1}
    assert ex.time_resets == 1
    assert ex.sample_count == 3  # the old timeline is gone
