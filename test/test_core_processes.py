"""com_core.runtime.processes and the packages' console scripts: nodes start as ``ros2 run``
would start them, with parameters as ``--ros-args`` reads them, and stop on SIGINT."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import WORKSPACE

from com_core.runtime.processes import STOP_SEQUENCE, executable, parameter_text, ros_args, stop

PACKAGES = ("com_estimator", "wrench_sim", "exploration_sequencer")


def console_scripts(package: str) -> list[str]:
    """Console script names declared in the package's setup.py."""
    text = (WORKSPACE / package / "setup.py").read_text()
    return re.findall(r'"(\w+) = [\w.]+:main"', text)


def test_ament_index_resolves_every_console_script_as_ros2_run_does():
    """``ros2 run <pkg> <exe>`` takes <prefix>/lib/<pkg>/<exe> with the prefix from the
    ament index (ros2pkg.api.get_executable_paths); every script must be found there."""
    from ament_index_python.packages import get_packages_with_prefixes

    indexed = get_packages_with_prefixes()
    for package in (*PACKAGES, "com_core"):
        assert package in indexed, f"{package} is not in the ament index"
    for package in PACKAGES:
        scripts = console_scripts(package)
        assert scripts, package
        for name in scripts:
            path = executable(package, name)
            assert os.access(path, os.X_OK), path
            shebang = path.read_text().splitlines()[0]
            interpreter = Path(shebang.removeprefix("#!").split()[0])
            assert shebang.startswith("#!") and os.access(interpreter, os.X_OK), shebang
    with pytest.raises(FileNotFoundError, match="make setup"):
        executable("com_estimator", "no_such_node")


def test_parameters_are_written_as_ros_args_reads_them():
    """Strings are quoted, or YAML would read y, no and on as bools."""
    assert parameter_text(["x", "y"]) == "['x', 'y']"
    assert parameter_text("it's") == "'it''s'"
    assert parameter_text(True) == "true" and parameter_text(0.1) == "0.1"
    assert parameter_text([0.0, 1]) == "[0.0, 1]"
    assert ros_args({"tilt_axes": ["y"]}, {"/a": "/b"}) == [
        "--ros-args",
        "-r",
        "/a:=/b",
        "-p",
        "tilt_axes:=['y']",
    ]


def test_stop_ends_with_sigint_first_then_harder():
    ignore = "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    wait = "print('ready', flush=True); time.sleep(60)"
    obstinate = subprocess.Popen([sys.executable, "-c", ignore + wait], stdout=subprocess.PIPE)
    polite = subprocess.Popen(
        [sys.executable, "-c", "import time; " + wait], stdout=subprocess.PIPE
    )
    try:
        for process in (polite, obstinate):  # the handlers are in place
            assert process.stdout.readline() == b"ready\n"
        assert stop(polite) == signal.SIGINT
        assert stop(polite) is None  # already ended
        quick = [(sig, 1.0) for sig, _ in STOP_SEQUENCE]
        assert stop(obstinate, quick) == signal.SIGTERM
    finally:
        for process in (polite, obstinate):
            if process.poll() is None:
                process.kill()
            process.stdout.close()
