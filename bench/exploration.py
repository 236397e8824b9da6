"""The reference exploration, end to end in the pybullet sim, over many random objects.

    source ./env.sh && python bench/exploration.py [--runs 50] [--seed 0]

docs/design.md's reference: a 0.1 kg object (the paper's), sensor noise sigma_f 0.1 N and
sigma_tau 0.005 N m per sample at 1 kHz, tilt at most pi/6, rigid grasp. The estimator
and the sequencer run once (the tare pass is cached per hand, so it is taken in the
first run only); each run starts a simulator with its own object (box, cylinder, mug in
turn; COM offset drawn from the run's seed) at 5x real time and calls ~/explore. Each
run's bag is read back for the estimate and the ground truth (``com_core.bags.run``), and
replayed offline with ``--method two_pose``: the paper's method on the same windows.
Targets: COM error <= 1 mm at the 95th percentile, mass error <= 0.5 %, object pass
<= 10 s of sim time.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from com_core.bags.run import read_run
from com_core.contract import EXPLORE_SERVICE
from com_core.processes import executable, ros_args, stop
from com_core.rosenv import keep_dds_local

SHAPES = ("box", "cylinder", "mug")
NOISE = {"sigma_f": 0.1, "sigma_tau": 0.005}


def node(package: str, name: str, params: dict, log: Path) -> subprocess.Popen:
    """A node's console script as a process, as ``ros2 run`` would start it."""
    with open(log, "w") as out:
        return subprocess.Popen(
            [str(executable(package, name)), *ros_args(params)],
            stdout=out,
            stderr=subprocess.STDOUT,
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--bag-dir", type=Path, default=None, help="keep the bags here")
    parser.add_argument(
        "--information",
        default="wrenches",
        choices=("wrenches", "kinematics", "kinematics+mount"),
        help="the estimator's information model",
    )
    args = parser.parse_args()
    keep_dds_local(own_domain=True)
    bags = args.bag_dir or Path(tempfile.mkdtemp(prefix="exploration_bench_"))
    bags.mkdir(parents=True, exist_ok=True)
    cache = {"tare_cache": str(bags / "tare_cache.json")}
    import rclpy
    from std_srvs.srv import Trigger

    rclpy.init()
    client_node = rclpy.create_node("exploration_bench")
    client = client_node.create_client(Trigger, EXPLORE_SERVICE)
    sim_time = {"use_sim_time": True}
    services = [
        node(
            "com_estimator",
            "estimator_node",
            sim_time | NOISE | cache | {"information": args.information},
            log=bags / "estimator.log",
        ),
        node(
            "exploration_sequencer",
            "sequencer_node",
            sim_time | {"bag_dir": str(bags)} | cache,
            log=bags / "sequencer.log",
        ),
    ]
    rows = []
    try:
        for i in range(args.runs):
            shape, seed = SHAPES[i % 3], args.seed + i
            sim = node(
                "wrench_sim",
                "sim_node",
                {"object": shape, "seed": seed, "real_time_factor": 5.0} | NOISE,
                log=bags / f"sim_{i}.log",
            )
            try:
                if not client.wait_for_service(timeout_sec=60.0):
                    raise RuntimeError("the sequencer did not come up")
                time.sleep(1.0)  # the sim's first joint states
                future = client.call_async(Trigger.Request())
                rclpy.spin_until_future_complete(client_node, future, timeout_sec=300.0)
                message = future.result().message if future.done() else "no answer"
            finally:
                stop(sim)
            rows.append(evaluate(i, shape, seed, message))
            r = rows[-1]
            print(
                f"{i:3d} {shape:8} seed {seed:3d}  ml |e| {r['ml']:6.3f} mm  two_pose |e| "
                f"{r['two_pose']:8.3f} mm  mass {r['mass_err']:+.3%}  pass {r['pass_s']:.1f} s"
                f"  {r['status']}",
                flush=True,
            )
    finally:
        for proc in services:
            stop(proc)
        client_node.destroy_node()
        rclpy.try_shutdown()
    report(rows)
    return 0


def evaluate(i: int, shape: str, seed: int, message: str) -> dict:
    """COM error norms (mm) of both methods, mass error, object pass time of one run."""
    nan = float("nan")
    row = {
        "run": i,
        "shape": shape,
        "seed": seed,
        "ml": nan,
        "two_pose": nan,
        "mass_err": nan,
        "pass_s": nan,
        "z": [nan, nan, nan],  # COM error / its sigma per axis
        "sigma_z": nan,  # the COM sigma along z, mm
        "status": message[:40],
    }
    m = re.search(r" bag (\S+)$", message)
    if not m:
        return row
    bag = Path(m.group(1))
    run = read_run(bag)
    t = re.search(r"object pass ([\d.]+) s", message)
    row["pass_s"] = float(t.group(1)) if t else nan
    row["status"] = message.split("]")[0] + "]"
    if run.truth is None or run.estimate is None:
        return row
    row["ml"] = float(np.linalg.norm(run.estimate.com - run.truth.com)) * 1e3
    row["mass_err"] = (run.estimate.mass - run.truth.mass) / run.truth.mass
    if run.diagnostic is not None:
        sigma = np.array([float(run.diagnostic["values"][f"sigma_com_{a}"]) for a in "xyz"])
        row["z"] = ((run.estimate.com - run.truth.com) / sigma).tolist()
        row["sigma_z"] = float(sigma[2]) * 1e3
    replay = subprocess.run(
        [
            str(executable("com_estimator", "replay")),
            str(bag),
            "--method",
            "two_pose",
            "--json",
        ],
        capture_output=True,
        text=True,
    )
    paper = json.loads(replay.stdout) if replay.stdout else {}
    if "com" in paper:
        row["two_pose"] = float(np.linalg.norm(np.array(paper["com"]) - run.truth.com)) * 1e3
    return row


def report(rows: list[dict]) -> None:
    def p95(key: str) -> float:
        return float(np.nanpercentile([abs(r[key]) for r in rows], 95))

    ok = sum(r["status"] == "[OK]" for r in rows)
    print(f"\nruns: {len(rows)} ({ok} OK)")
    print(
        f"COM error, 95th percentile: ml {p95('ml'):.3f} mm, paper's two_pose "
        f"{p95('two_pose'):.3f} mm (two_pose / ml = {p95('two_pose') / p95('ml'):.1f}x); "
        f"target <= 1 mm"
    )
    print(f"mass error, 95th percentile: {p95('mass_err'):.3%}; target <= 0.5 %")
    z = np.abs(np.array([r["z"] for r in rows], dtype=float))
    within = np.nanmean(z <= 2.0, axis=0)
    print(
        f"honest sigmas: |COM error / sigma| <= 2 in {', '.join(f'{w:.0%}' for w in within)} "
        f"of runs (x, y, z; target >= 95 %); COM sigma z median "
        f"{np.nanmedian([r['sigma_z'] for r in rows]):.3f} mm"
    )
    print(
        f"object pass, sim time: median {np.nanmedian([r['pass_s'] for r in rows]):.2f} s, "
        f"max {np.nanmax([r['pass_s'] for r in rows]):.2f} s; target <= 10 s"
    )


if __name__ == "__main__":
    sys.exit(main())
