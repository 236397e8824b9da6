"""The sample run kept in bags/sample: a real recording replays to the node's estimate."""

from __future__ import annotations

import numpy as np
from conftest import WORKSPACE, replay_json

from com_core.report.run import read_run

SAMPLE = WORKSPACE / "bags" / "sample"


CROSS_MACHINE_RTOL = 1e-9
"""Relative tolerance for numbers recorded on another machine: numpy's BLAS kernels are
chosen per CPU, so the last bits of a fit may differ (seen: 5e-16); bit-identity holds
on one machine (test_estimator_node, test_sequencer_node)."""


def test_replay_of_the_sample_run_is_the_recorded_estimate():
    """Recorded by the sequencer from the sim on another machine (a run that reused the
    cached tare, kept beside it as tare.json); the estimate and diagnostics in it are the
    node's. The replay here reproduces them to CROSS_MACHINE_RTOL."""
    run = read_run(SAMPLE)
    assert run.estimate is not None and run.diagnostic is not None, run.notes
    offline = replay_json(SAMPLE)
    values = run.diagnostic["values"]
    assert offline["status"] == run.status == "OK"
    recorded = {
        "mass": run.estimate.mass,
        "com": run.estimate.com.tolist(),
        "sigma_mass": float(values["sigma_mass"]),
        "sigma_com": [float(values[f"sigma_com_{a}"]) for a in "xyz"],
    }
    for key, value in recorded.items():
        np.testing.assert_allclose(offline[key], value, rtol=CROSS_MACHINE_RTOL, err_msg=key)
    # and it is right: within 4 sigma of the simulator's ground truth
    sigma = np.array(offline["sigma_com"])
    assert np.all(np.abs(run.estimate.com - run.truth.com) < 4 * sigma)
    assert abs(run.estimate.mass - run.truth.mass) < 4 * offline["sigma_mass"]
