"""The reference exploration, end to end in the pybullet sim, over many random objects.

    source ./env.sh && python bench/exploration.py [--runs 50] [--seed 0]
        [--robots panda,xarm6] [--information NAME] [--target-com-sigma M --fewer-poses]
        [--bias-drift N_PER_S] [--tare-max-age S]

docs/design.md's reference: a 0.1 kg object (the paper's), the sensor of ``--sensor-
profile`` (default realistic; the figures in bench/README.md were measured with the
white one, 0.1 N and 0.005 N m per sample at 1 kHz), tilt at most pi/6, rigid grasp. The
estimator (with ``--information``, else its default) and the sequencer run once (the
tare pass is cached per hand, so it is taken in the first run only); each run starts a
simulator with its own object (box, cylinder, mug in turn; COM offset drawn from the
run's seed) at 5x real time and calls ~/explore. Each run's bag is read back for the
ground truth (``com_core.report.run``) and replayed offline with every information model
and with the paper's method (``--method two_pose``): the models side by side on the same
windows. Per model: COM error at the 95th percentile, mass error, how honest the sigmas
are (|error / sigma| <= 2 in 95 % of runs per axis) and the COM sigma along z against
that of the wrenches alone. Targets: COM error <= 1 mm at the 95th percentile, mass
error <= 0.5 %, object pass <= 10 s of sim time (<= 5 s with the planner's shorter pass:
``--target-com-sigma 0.00035 --fewer-poses``). The verification pose (a kinematic
model's; ``verify/diagonal``, 20 deg about the sensor's diagonal, no fit uses it): the
95th percentile of the compensated force's and torque's magnitude there in units of one
object window's mean noise per axis (sigma / sqrt(samples)), and of the verification
window's own; target <= 3 for both; and how many verifications passed.

With ``--robots panda,xarm6`` the same objects (seeds) run on each arm in turn (each
arm's robot configuration given to every node) and the last arms are compared with the
first: the median object pass time and COM sigma per axis of the node's model as ratios
(target: within 20 %).
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

from com_core.contract import EXPLORE_SERVICE
from com_core.report.run import read_run
from com_core.robot.config import robot_config_path
from com_core.runtime.processes import executable, ros_args, stop
from com_core.runtime.rosenv import keep_dds_local
from com_core.sensing.sensor_profiles import DEFAULT_PROFILE, PROFILES

SHAPES = ("box", "cylinder", "mug")
MODELS = ("wrenches", "kinematics", "kinematics+mount")


def node(package: str, name: str, params: dict, log: Path, robot: str) -> subprocess.Popen:
    """A node's console script as a process, as ``ros2 run`` would start it, with
    ``robot``'s configuration."""
    with open(log, "w") as out:
        return subprocess.Popen(
            [
                str(executable(package, name)),
                *ros_args(params, params_file=robot_config_path(robot)),
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--bag-dir", type=Path, default=None, help="keep the bags here")
    parser.add_argument(
        "--robots", default="panda", help="robot configurations, comma separated, run in turn"
    )
    parser.add_argument(
        "--information",
        default=None,
        choices=MODELS,
        help="the estimator's information model (default: the estimator's default)",
    )
    parser.add_argument("--target-com-sigma", type=float, default=0.0, help="m (sequencer)")
    parser.add_argument("--fewer-poses", action="store_true", help="the planner may drop poses")
    parser.add_argument("--max-object-time", type=float, default=20.0, help="s (sequencer)")
    parser.add_argument(
        "--tare-max-age",
        type=float,
        default=3600.0,
        help="s (sequencer); 0: a tare pass in every run (independent runs)",
    )
    parser.add_argument(
        "--sensor-profile",
        default=DEFAULT_PROFILE,
        choices=sorted(PROFILES),
        help="the simulated sensor (com_core.sensing.sensor_profiles); the estimator "
        "learns its noise",
    )
    parser.add_argument(
        "--bias-drift", type=float, default=0.0, help="N/s of sensor drift per force axis (sim)"
    )
    args = parser.parse_args()
    keep_dds_local(own_domain=True)
    root = args.bag_dir or Path(tempfile.mkdtemp(prefix="exploration_bench_"))
    import rclpy

    rclpy.init()
    results = {}
    try:
        for robot in args.robots.split(","):
            print(f"\n=== {robot} ===", flush=True)
            results[robot] = run_batch(robot, args, root / robot)
            report(results[robot])
    finally:
        rclpy.try_shutdown()
    if len(results) > 1:
        compare(results)
    return 0


def run_batch(robot: str, args: argparse.Namespace, bags: Path) -> list[dict]:
    """The runs of ``args`` on ``robot``: one row per run (``evaluate``)."""
    import rclpy
    from std_srvs.srv import Trigger

    bags.mkdir(parents=True, exist_ok=True)
    cache = {"tare_cache": str(bags / "tare_cache.json")}
    client_node = rclpy.create_node("exploration_bench")
    client = client_node.create_client(Trigger, EXPLORE_SERVICE)
    sim_time = {"use_sim_time": True}
    information = {"information": args.information} if args.information else {}
    planner = {
        "target_com_sigma": args.target_com_sigma,
        "fewer_poses": args.fewer_poses,
        "max_object_time": args.max_object_time,
        "tare_max_age": args.tare_max_age,
    }
    services = [
        node(
            "com_estimator",
            "estimator_node",
            sim_time | cache | information,
            log=bags / "estimator.log",
            robot=robot,
        ),
        node(
            "exploration_sequencer",
            "sequencer_node",
            sim_time | {"bag_dir": str(bags)} | cache | planner,
            log=bags / "sequencer.log",
            robot=robot,
        ),
    ]
    drift = [args.bias_drift] * 3 + [0.0] * 3
    rows = []
    try:
        for i in range(args.runs):
            shape, seed = SHAPES[i % 3], args.seed + i
            sim = node(
                "wrench_sim",
                "sim_node",
                {
                    "object": shape,
                    "seed": seed,
                    "real_time_factor": 5.0,
                    "bias_drift": drift,
                    "sensor_profile": args.sensor_profile,
                },
                log=bags / f"sim_{i}.log",
                robot=robot,
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
            errors = "  ".join(f"{m} {r[m]['com_err']:6.3f}" for m in (*MODELS, "two_pose"))
            print(
                f"{i:3d} {shape:8} seed {seed:3d}  |COM error| mm: {errors}  mass "
                f"{r[r['node']]['mass_err']:+.3%}  pass {r['pass_s']:.1f} s  {r['status']}",
                flush=True,
            )
    finally:
        for proc in services:
            stop(proc)
        client_node.destroy_node()
    return rows


def compare(results: dict[str, list[dict]]) -> None:
    """Each arm after the first against the first: the median object pass time and COM
    sigma per axis of the node's model, as ratios; and the sigma over the planner's
    prediction for the run (the bound of the object where that arm holds it), whose
    ratio takes out where the grasp puts the COM."""
    (first, reference), *others = results.items()

    def medians(rows: list[dict]) -> np.ndarray:
        sigma = np.array([r[r["node"]]["sigma"] for r in rows])
        bound = sigma / np.array([r["predicted"] for r in rows])
        pass_s = np.nanmedian([r["pass_s"] for r in rows])
        return np.array([pass_s, *np.nanmedian(sigma, axis=0), *np.nanmedian(bound, axis=0)])

    base = medians(reference)
    print(
        f"\n{'':>8} {'object pass s':>14} {'sigma x, y, z mm':>26} {'sigma / predicted':>19}"
        f"  ratio to {first}: pass, sigma x y z, sigma / predicted x y z"
    )
    for robot, rows in [(first, reference), *others]:
        m = medians(rows)
        print(
            f"{robot:>8} {m[0]:14.2f} {' '.join(f'{v:8.3f}' for v in m[1:4]):>26} "
            f"{' '.join(f'{v:5.2f}' for v in m[4:]):>19}  "
            + " ".join(f"{v:5.2f}" for v in m / base)
        )
    print("target: object pass and sigma within 20 % of the first arm's (ratios 0.8 .. 1.2)")


def evaluate(i: int, shape: str, seed: int, message: str) -> dict:
    """Per model (and two_pose): COM error norm (mm), mass error, COM error over its sigma
    per axis and the sigmas (mm), from replays of the run's bag; the pass time and the
    node's status and information model."""
    nan = float("nan")
    row: dict = {"run": i, "shape": shape, "seed": seed, "pass_s": nan, "node": "wrenches"}
    row["predicted"] = [nan] * 3
    row["status"] = message.split("]")[0] + "]" if message.startswith("[") else message[:40]
    blank = {
        "com_err": nan,
        "mass_err": nan,
        "z": [nan] * 3,
        "sigma": [nan] * 3,
        "verify": [nan] * 5,
    }
    for model in (*MODELS, "two_pose"):
        row[model] = dict(blank)
    m = re.search(r" bag (\S+)$", message)
    if not m:
        return row
    bag = Path(m.group(1))
    t = re.search(r"object pass ([\d.]+) s", message)
    row["pass_s"] = float(t.group(1)) if t else nan
    node = re.search(
        r"predicted ml \(([a-z+]+)\): .*?COM \(([\d.]+), ([\d.]+), ([\d.]+)\)", message
    )
    row["node"] = node.group(1) if node else "wrenches"
    row["predicted"] = [float(v) for v in node.groups()[1:]] if node else [nan] * 3
    truth = read_run(bag).truth
    if truth is None:
        return row
    for model in (*MODELS, "two_pose"):
        flags = ["--method", "two_pose"] if model == "two_pose" else ["--information", model]
        replay = subprocess.run(
            [str(executable("com_estimator", "replay")), str(bag), *flags, "--json"],
            capture_output=True,
            text=True,
        )
        out = json.loads(replay.stdout) if replay.stdout else {}
        if "com" not in out:
            continue
        error = np.array(out["com"]) - truth.com
        sigma = np.array(out["sigma_com"])
        row[model] = {
            "com_err": float(np.linalg.norm(error)) * 1e3,
            "mass_err": (out["mass"] - truth.mass) / truth.mass,
            "z": (error / sigma).tolist(),
            "sigma": (sigma * 1e3).tolist(),
            "verify": verification(out),
        }
    return row


def verification(out: dict) -> list[float]:
    """The compensated force and torque magnitude at the verification pose over one
    object window's mean noise (the learnt sigma per sample / sqrt(n)), the same over the
    verification window's own mean noise, and 1 if it passed (NaN without one)."""
    wrench, noise = out.get("verify_wrench diagonal"), out.get("verify_noise diagonal")
    n_object = out.get("window_samples", {}).get("object/home")
    if wrench is None or noise is None or not n_object:
        return [float("nan")] * 5
    f, tau = np.linalg.norm(wrench[:3]), np.linalg.norm(wrench[3:])
    sigma = out.get("noise_sigma") or [0.1] * 3 + [0.005] * 3  # learnt per sample
    window = [np.mean(sigma[:3]) / np.sqrt(n_object), np.mean(sigma[3:]) / np.sqrt(n_object)]
    own = [float(np.mean(noise[:3])), float(np.mean(noise[3:]))]
    distance = out["verify_distance diagonal"]
    passed = float(max(distance[:2]) <= distance[2])
    return [f / window[0], tau / window[1], f / own[0], tau / own[1], passed]


def report(rows: list[dict]) -> None:
    ok = sum(r["status"] == "[OK]" for r in rows)
    print(f"\nruns: {len(rows)} ({ok} OK); the node's information: {rows[0]['node']}")
    print(
        f"{'model':>17} {'COM err p95 mm':>15} {'mass err p95':>13} {'|z|<=2 x, y, z':>17} "
        f"{'sigma z med mm':>15} {'sigma z / wrenches':>19}"
    )
    wrenches_z = np.array([r["wrenches"]["sigma"][2] for r in rows])
    for model in (*MODELS, "two_pose"):
        com = np.nanpercentile([r[model]["com_err"] for r in rows], 95)
        mass = np.nanpercentile([abs(r[model]["mass_err"]) for r in rows], 95)
        within = np.nanmean(np.abs(np.array([r[model]["z"] for r in rows])) <= 2.0, axis=0)
        sigma_z = np.array([r[model]["sigma"][2] for r in rows])
        print(
            f"{model:>17} {com:15.3f} {mass:13.3%} "
            f"{' '.join(f'{w:4.0%}' for w in within):>17} {np.nanmedian(sigma_z):15.3f} "
            f"{np.nanmedian(sigma_z / wrenches_z):19.2f}"
        )
    print(
        "targets: COM error p95 <= 1 mm, mass error p95 <= 0.5 %, |z| <= 2 in >= 95 % per "
        "axis; sigma z / wrenches <= 0.65 (kinematic default)"
    )
    print(
        f"\nverification pose: p95 of |compensated f|, |tau| in sigmas of one window's mean "
        f"noise\n{'model':>17} {'object window':>15} {'its own window':>16} {'passed':>9}"
    )
    for model in MODELS:
        v = np.array([r[model]["verify"] for r in rows])
        if np.all(np.isnan(v[:, 0])):
            continue
        p95 = np.nanpercentile(v[:, :4], 95, axis=0)
        passed = f"{int(np.nansum(v[:, 4]))}/{int(np.sum(~np.isnan(v[:, 4])))}"
        print(f"{model:>17} {p95[0]:7.2f} {p95[1]:7.2f} {p95[2]:8.2f} {p95[3]:7.2f} {passed:>9}")
    print("target: p95 <= 3 for the force and for the torque")
    print(
        f"object pass, sim time: median {np.nanmedian([r['pass_s'] for r in rows]):.2f} s, "
        f"max {np.nanmax([r['pass_s'] for r in rows]):.2f} s"
    )


if __name__ == "__main__":
    sys.exit(main())
