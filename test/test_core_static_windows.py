"""com_core.estimation.recordings.static_windows: an unlabelled stream cut into its static
windows, sorted by load level into tare and object windows."""

from __future__ import annotations

import numpy as np
from conftest import write_stream_bag

from com_core.contract import WARN
from com_core.estimation.recordings.static_windows import (
    find_static_windows,
    label_static_windows,
    split_load_levels,
)
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.feed import feed_bag
from com_core.paper.synthetic import Load, exploration_stream
from com_core.planning.planner import Plan

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))


def test_unlabelled_stream_is_cut_into_its_static_windows(tmp_path):
    stream = exploration_stream(
        Plan(dwell=0.5, gravity_home=(0, 0, 1)), LOAD, HAND, np.random.default_rng(3)
    )
    found = label_static_windows(stream.stamps, stream.wrenches)
    starts = [s for s, lbl in found if lbl != "moving"]
    truth = [s for s, lbl in stream.labels if "/" in lbl]
    assert len(starts) == len(truth) == 10
    # each found window starts within 0.1 s after a true window start (the stream begins
    # at rest, so the first one starts earlier)
    assert starts[0] < truth[0]
    assert all(0 <= s - t <= 100_000_000 for s, t in zip(starts[1:], truth[1:], strict=True))

    write_stream_bag(tmp_path / "unlabelled", stream, labels=False)
    ex = Exploration(untared=True)
    assert feed_bag(tmp_path / "unlabelled", ex)[1] == 0
    for stamp, label in label_static_windows(*ex.samples()):
        ex.add_label(stamp, label)
    solution = ex.solve()
    # tare and object windows together are not one rigid load: flagged, not silent
    assert solution.status == WARN and "no tare" in " ".join(solution.notes)


def test_load_levels_split_a_synthetic_exploration_into_tare_and_object():
    """A tare pass and an object pass in one unlabelled stream: five windows at each load
    level, each object window paired with the tare window of its pose, and the tared fit
    finds the object (not hand + object, 830 g)."""
    rng = np.random.default_rng(5)
    stream = exploration_stream(Plan(dwell=0.5, gravity_home=(0, 0, 1)), LOAD, HAND, rng)
    labels = label_static_windows(stream.stamps, stream.wrenches)
    windows = [label for _, label in labels if label != "moving"]
    assert windows == [f"tare/static_{k}" for k in range(1, 6)] + [
        f"object/static_{k}" for k in range(1, 6)
    ]
    ex = Exploration()
    ex.add_samples(stream.stamps, stream.wrenches, "ft_sensor")
    for stamp, label in labels:
        ex.add_label(stamp, label)
    solution = ex.solve()
    assert solution.status == "OK", solution.reason
    e = solution.estimate
    assert abs(e.mass - LOAD.mass) < 4 * e.sigma_mass
    assert np.all(np.abs(e.com - LOAD.com) < 4 * e.sigma_com)

    found = find_static_windows(stream.stamps, stream.wrenches)
    # one load level (the object pass alone): untared, as before, and said so
    levels = split_load_levels(found[5:])
    assert levels.untared and levels.object_windows == 5
    assert "5 static windows at one load level" in levels.describe()
    # a tare of home alone: the tilted object windows have no tare of their direction
    levels = split_load_levels(found[:1] + found[5:])
    assert (levels.tare_windows, levels.object_windows, levels.unpaired) == (1, 1, 4)
    assert levels.max_angle < np.radians(0.5)
