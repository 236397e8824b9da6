"""com_core.study: the Monte Carlo reproduction of the paper's tables (cells, CLI)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from com_core.study import Cell, run_cell


def test_study_cells_are_deterministic_and_reproduce_table_ii_reading():
    cell = Cell("II", "paper", math.pi / 6, 0.0, 10.0)
    a, b = run_cell(cell, 400, seed=1), run_cell(cell, 400, seed=1)
    assert a == b
    expected = 10.0e-3 / math.tan(math.pi / 6)  # the paper's reading: s cot(theta)
    assert a["two_pose"]["sd"][2] == pytest.approx(expected, rel=4 / math.sqrt(800))


def test_study_cli_json_and_figures(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "com_core.study",
            "--trials",
            "12",
            "--json",
            "--workers",
            "2",
            "--out",
            str(tmp_path),
        ],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    records = [json.loads(line) for line in out.splitlines()]
    assert len(records) == 30
    for r in records:
        assert {"theta", "noise", "samples_per_pose", "plan", "crlb"} <= r.keys()
        assert len(r["ml"]["sd"]) == 3 and len(r["two_pose"]["sd"]) == 3
    assert {r["samples_per_pose"] for r in records} == {1, 1000}
    assert len(list(tmp_path.glob("fig*_z_theta_*.png"))) == 3
