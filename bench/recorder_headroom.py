"""The recorder's headroom: the highest wrench rate it records whole, cores loaded or not.

    source ./env.sh && python bench/recorder_headroom.py [--busy 2] [--rates 2000,5000,10000]

The sequencer's recorder (``exploration_sequencer.recorder_process``, a process of its
own) records while ``synthetic_exploration`` publishes a synthetic run at each rate
(wall, msg/s; reliable, depth 1000, as the simulator's sensor); ``--busy`` processes spin
beside it (one per core loads both). Per rate: the wrenches recorded against those
published (the ratio is the reference: 1.000 is whole), the ones DDS reported lost, and
the recorder's CPU share. The headroom is the highest rate recorded whole.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from com_core.bags.reader import read_raw
from com_core.contract import WRENCH_TOPIC
from com_core.runtime.processes import executable
from com_core.runtime.rosenv import keep_dds_local


def record_once(rate: int, work: Path) -> tuple[int, int, int, float]:
    """(wrenches published, recorded, reported lost, the rate achieved msg/s) of one
    synthetic run asked for at ``rate``."""
    from exploration_sequencer.recorder_process import RecorderProcess

    recorder = RecorderProcess()
    try:
        time.sleep(1.0)  # discovery
        bag, sent = work / f"recorded-{rate}", work / f"published-{rate}"
        recorder.start(bag)
        command = [str(executable("com_estimator", "synthetic_exploration")),
                   "--speed", str(rate), "--dwell", "1.0", "--bag", str(sent),
                   "--estimator-timeout", "0"]  # fmt: skip
        out = subprocess.run(command, check=True, capture_output=True, text=True, timeout=300)
        done = re.search(r"published (\d+) wrenches .* in ([\d.]+) s", out.stdout + out.stderr)
        achieved = int(done[1]) / float(done[2]) if done else float("nan")
        time.sleep(1.0)  # the last messages through the recorder
        recorder.stop()
        lost = recorder.lost.get(WRENCH_TOPIC, 0)
    finally:
        recorder.close()
    published = sum(1 for _ in read_raw(sent, [WRENCH_TOPIC]))
    recorded = sum(1 for _ in read_raw(bag, [WRENCH_TOPIC]))
    return published, recorded, lost, achieved


def main() -> int:
    keep_dds_local(own_domain=True)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--busy", type=int, default=2, help="busy processes beside the recorder")
    p.add_argument("--rates", default="2000,5000,10000,20000", help="msg/s (wall)")
    args = p.parse_args()
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
            for _ in range(args.busy)]  # fmt: skip
    headroom = 0
    try:
        with tempfile.TemporaryDirectory() as work:
            for rate in (int(r) for r in args.rates.split(",")):
                published, recorded, lost, achieved = record_once(rate, Path(work))
                print(f"{rate:6d} msg/s asked, {achieved:6.0f} published: recorded {recorded} "
                      f"of {published} ({recorded / published:.4f}), DDS lost {lost}",
                      flush=True)  # fmt: skip
                if recorded == published:
                    headroom = max(headroom, round(achieved))
    finally:
        for process in busy:
            process.kill()
            process.wait()
    print(f"headroom with {args.busy} busy processes: {headroom} msg/s recorded whole")
    return 0


if __name__ == "__main__":
    sys.exit(main())
