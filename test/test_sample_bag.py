"""The sample run kept in bags/sample: a real recording replays to the node's estimate."""

from __future__ import annotations

import numpy as np
from conftest import WORKSPACE, replay_json

from com_core.run_bag import read_run

SAMPLE = WORKSPACE / "bags" / "sample"


def test_replay_of_the_sample_run_is_the_recorded_estimate_to_the_bit():
    """Recorded by the sequencer from the sim (a run that reused the cached tare, which is
    kept beside it as tare.json); the estimate and diagnostics in it are the node's."""
    run = read_run(SAMPLE)
    assert run.estimate is not None and run.diagnostic is not None, run.notes
    offline = replay_json(SAMPLE)
    values = run.diagnostic["values"]
    assert offline["status"] == run.status == "OK"
    assert offline["mass"] == run.estimate.mass
    assert offline["com"] == run.estimate.com.tolist()
    assert offline["sigma_mass"] == float(values["sigma_mass"])
    assert offline["sigma_com"] == [float(values[f"sigma_com_{a}"]) for a in "xyz"]
    # and it is right: within 4 sigma of the simulator's ground truth
    sigma = np.array(offline["sigma_com"])
    assert np.all(np.abs(run.estimate.com - run.truth.com) < 4 * sigma)
    assert abs(run.estimate.mass - run.truth.mass) < 4 * offline["sigma_mass"]
