"""The core never imports rclpy (docs/design.md, Architecture): every com_core module
imports in a fresh interpreter without pulling it in."""

from __future__ import annotations

import json
import subprocess
import sys

IMPORT_EVERY_MODULE = """
import importlib, json, pkgutil, sys
import com_core

names = sorted(m.name for m in pkgutil.walk_packages(com_core.__path__, "com_core."))
for name in names:
    importlib.import_module(name)
    if "rclpy" in sys.modules:
        sys.exit(f"{name} imports rclpy")
print(json.dumps(names))
"""


def test_core_never_imports_rclpy():
    done = subprocess.run(
        [sys.executable, "-c", IMPORT_EVERY_MODULE], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    imported = set(json.loads(done.stdout))
    # the walk found the modules (not an empty package path): the ones the nodes, the
    # replay and the study call
    assert {
        "com_core.contract",
        "com_core.sensing.wrench_model",
        "com_core.estimation.fits.windows",
        "com_core.estimation.fits.estimators",
        "com_core.estimation.runs.exploration",
        "com_core.estimation.runs.inbox",
        "com_core.estimation.runs.cutting",
        "com_core.estimation.runs.fit_setup",
        "com_core.estimation.runs.solution",
        "com_core.estimation.recordings.static_windows",
        "com_core.planning.planner",
        "com_core.estimation.runs.tare_cache",
        "com_core.paper.synthetic",
        "com_core.paper.study",
        "com_core.runtime.processes",
        "com_core.bags.cdr",
        "com_core.bags.reader",
        "com_core.bags.writer",
        "com_core.report.run",
        "com_core.report.figure",
    } <= imported
