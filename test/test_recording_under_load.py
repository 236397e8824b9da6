"""A run's bag under stress: both cores loaded by busy processes while the sensor streams
at 2 kHz (wall), and a bag directory whose disk fills in the middle of a run."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import replay_json, spin_until
from test_sequencer_node import client, start_system  # noqa: F401 - the fixture

from com_core.bags.reader import read_raw
from com_core.contract import WRENCH_TOPIC
from com_core.estimation.runs.cutting import window_sample_counts
from com_core.estimation.runs.solution import missing_samples, window_counts
from com_core.report.run import read_run

pytestmark = pytest.mark.system

BAG = re.compile(r"; bag (\S+)$")


@pytest.fixture
def busy_cores() -> Iterator[None]:
    """A busy process per core, ended at teardown."""
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    yield
    for process in busy:
        process.kill()
        process.wait()


def test_every_sample_the_estimator_used_is_in_the_bag_with_both_cores_loaded(
    busy_cores,
    start_node,
    client,  # noqa: F811
    tmp_path,
    ros_env,
):
    """The node's window counts against the bag's, window by window, and the replay of
    the bag gives the node's mass and COM to the bit."""
    start_system(start_node, tmp_path, {"real_time_factor": 2.0, "rate": 1000.0, "seed": 4})
    result = client.wait(client.call(), timeout=300.0)
    assert result.success, result.message
    bag = Path(BAG.search(result.message).group(1))
    run = read_run(bag)
    used = window_counts(run.diagnostic["values"])
    held = window_sample_counts(run.stamps, run.labels, run.done_ns)
    assert used and missing_samples(used, held) == [], run.incomplete
    assert held == used  # the estimator lost none that the bag holds either
    assert "incomplete" not in result.message
    offline = replay_json(bag, ros_env)
    values = run.diagnostic["values"]
    assert offline["mass"] == float(values["mass"])
    assert offline["com"] == [float(values[f"com_{axis}"]) for axis in "xyz"]


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 64 MB tmpfs (skipped where mounting is not allowed), unmounted at teardown."""
    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", str(mount)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


def test_a_disk_that_fills_mid_run_ends_it_by_name_with_the_arm_home(
    small_disk,
    start_node,
    client,  # noqa: F811
    tmp_path,
):
    """The bag directory has room when the run starts; another file then fills its disk.
    The run ends ERROR naming the recording's path and the room left, goes back home, and
    the bag so far is readable; no node logs a traceback (the fixture checks)."""
    bags = small_disk / "bags"
    start_system(start_node, tmp_path, {"seed": 2}, {"bag_dir": str(bags)})
    log = next(tmp_path.glob("sequencer_node-*.log"))
    future = client.call()
    started = re.compile(r"recording \d+ topics")
    assert spin_until(client.node, lambda: started.search(log.read_text()) is not None, 60.0)
    filler = small_disk / "filler"
    with open(filler, "wb") as out:  # all but 1 MB: the bag fills it in seconds
        out.write(b"\0" * max(shutil.disk_usage(small_disk).free - 2**20, 0))
    result = client.wait(future, timeout=180.0)
    assert not result.success
    message = result.message
    assert re.search(r"failed: recording to \S+ stopped: .*No space left on device", message)
    assert re.search(r"\d+\.\d MB free on \S*small", message), message
    text = log.read_text()
    assert "not back home" not in text, text
    bag = next(bags.glob("2*"))
    assert len(list(read_raw(bag, [WRENCH_TOPIC]))) > 1000  # those before the disk filled
    filler.unlink()
    again = client.wait(client.call(), timeout=180.0)  # the next run starts from home
    assert again.success, again.message
    assert "before the run" not in log.read_text()  # no arm away from home, no object held
