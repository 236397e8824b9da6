"""The demo: simulator, estimator and sequencer as processes, one exploration, a summary.

    python -m exploration_sequencer.demo [--robot xarm6] [--object mug] [...]   (make demo)

Finds each node's executable the way ``ros2 run`` does (ament_index: <prefix>/lib/<pkg>/),
starts the three with the robot's configuration (``--params-file``; ``com_core``'s
``config/<robot>.yaml`` or a file of your own) and matching parameters (no launch files), calls
/exploration_sequencer/explore, prints the sequencer's progress and a final summary
(estimate, sigma, truth, error, time, bag and report paths), and stops the nodes with
SIGINT, the sequencer first: Ctrl-C cancels a running exploration (the object put back,
the arm home, the bag closed with a ``cancelled`` label) before the simulator stops;
SIGTERM and SIGHUP (a ``timeout``, a closed terminal) do the same, and the demo exits
with 128 + the signal's number. A demo that dies without that (SIGKILL) leaves no node
running either: each node watches a lifeline from the demo (``com_core.runtime.lifeline``)
and stops as on Ctrl-C once the demo is gone, the simulator and the estimator only once
the sequencer is gone too. Each node's output goes to <bag-dir>/logs/<package>.log (the
sequencer's to the terminal as well).
A node that ends on its own (a parameter it refuses, a crash) ends the wait at once: the
summary names it, with its exit code and its last error line, and the demo exits with 1.
"""

from __future__ import annotations

import argparse
import math
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from com_core.bags.cdr import decode_wrench
from com_core.contract import (
    ARM_COMMAND_TOPIC,
    COMPENSATED_TOPIC,
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    ESTIMATE_TOPIC,
    EXPLORE_SERVICE,
    ROBOT_DESCRIPTION_TOPIC,
    TRUTH_TOPIC,
)
from com_core.estimation.runs.fit_setup import INFORMATION
from com_core.estimation.runs.motion_solution import EXCITATIONS, MOTION
from com_core.estimation.runs.settings import SETTINGS
from com_core.estimation.runs.solution import (
    inertia_value,
    noise_line,
    vector_value,
    verification_lines,
)
from com_core.inputs import Input, InputError
from com_core.payload.files import PAYLOAD_FILE
from com_core.planning.sensor_accuracy import FIXTURE_COM_SIGMA
from com_core.robot.config import ROBOTS, RobotConfigError, read_robot_config, robot_config_path
from com_core.robot.dynamics import INERTIA_ELEMENTS, inertia_matrix
from com_core.runtime.lifeline import Lifeline
from com_core.runtime.processes import executable, last_error_line, ros_args, stop
from com_core.runtime.rosenv import keep_dds_local
from com_core.sensing.sensor_profiles import DEFAULT_PROFILE, PROFILES, file_profile
from exploration_sequencer.parameters import PARAMETERS as SEQUENCER

CANCEL_WAIT = 8.0  # s for a cancelled goal's result before the nodes are stopped
POLL = 0.2  # s between checks that the nodes still run, while waiting on the sequencer
CANCEL_REQUEST_WAIT = 1.0  # s for the sequencer to take a cancel when another node ended
ECHO_POLL = 0.05  # s between looks at the sequencer's log for lines to echo
THIRD_MOTION_SEED = 7  # the motion the demo runs while holding, after a run in motion
COMPENSATED_DEPTH = 20000  # messages the demo's reader of the compensated stream queues:
# 4 s of wall time at 1 kHz and 5x real time, so that a reader slower than the stream
# still reads from the whole motion
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that end the demo as Ctrl-C does: the run cancelled, then the nodes stopped."""
NO_SIMULATOR = (
    "the demo runs the simulator, and the wrench_sim package is not installed: it is an"
    " optional dependency of exploration_sequencer (a real arm needs none); build it beside"
    " this package with its dependencies (rosdep install --from-paths wrench_sim --ignore-src)"
)
"""Why the demo cannot start: ``wrench_sim`` (and so pybullet) is not installed."""


class Child(NamedTuple):
    """A node process the demo started: its package, the file that holds its output, and
    the thread that echoes that output to the terminal (None: not echoed)."""

    package: str
    process: subprocess.Popen
    log: Path
    copier: threading.Thread | None = None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="demo", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--robot",
        default="panda",
        help=f"the arm: {', '.join(ROBOTS)}, or a robot configuration file of your own",
    )
    p.add_argument("--object", choices=("box", "cylinder", "mug"), default="box")
    p.add_argument("--mass", type=float, default=0.1, help="kg")
    p.add_argument("--seed", type=int, default=0, help="draws the COM offset and the noise")
    p.add_argument("--grasp-mode", choices=("rigid", "friction"), default="rigid")
    p.add_argument(
        "--slip-sigma",
        type=float,
        default=0.0,
        help="m; random COM shift at each tilt (the paper's reconfiguration)",
    )
    p.add_argument(
        "--sensor-profile",
        choices=sorted(PROFILES),
        default=None,
        help="the simulated sensor's parts (com_core.sensing.sensor_profiles; default: the "
        f"robot file's sensor_profile, else {DEFAULT_PROFILE})",
    )
    p.add_argument(
        "--sensor-serial",
        type=int,
        default=0,
        help="which sensor of the profile: its calibration error and gauges are drawn from "
        "it, the same whatever --seed (another serial: another sensor, its own tare cache)",
    )
    p.add_argument("--sigma-f", type=float, help="N per published sample (default: the profile's)")
    p.add_argument("--sigma-tau", type=float, help="N m per published sample (as --sigma-f)")
    p.add_argument("--tilt", type=float, help="rad (default: the sequencer's, pi/6)")
    p.add_argument(
        "--max-tilt", type=float, help="rad; the largest tilt the object allows (default: pi/6)"
    )
    p.add_argument("--axes", default="y,x", help="tilt axes, e.g. 'x' for the paper's one")
    p.add_argument("--one-way", action="store_true", help="tilt one direction only (paper)")
    p.add_argument("--dwell", type=float, help="s per window (default: the sequencer's)")
    p.add_argument("--target-sigma", type=float, help="m; adaptive dwell to meet it")
    p.add_argument(
        "--raise-tilt",
        action="store_true",
        help="with --target-sigma: the tilt may be raised up to --max-tilt (else it is kept)",
    )
    p.add_argument("--method", choices=("ml", "two_pose"), default="ml")
    p.add_argument(
        "--information",
        choices=INFORMATION,
        default=None,
        help="what the estimator fits (default: its own, kinematics+mount): the wrenches, or "
        "also each window's orientation from the URDF (with the hand and the bias)",
    )
    p.add_argument(
        "--calibrate",
        action="store_true",
        help="the object is a reference weight of --mass (the sim's is off it within OIML "
        "class M1's tolerance): the run calibrates the sensor in place (kept beside the tare "
        "cache; the next runs in --bag-dir read through it)",
    )
    p.add_argument(
        "--reference-com",
        type=float,
        nargs=3,
        default=None,
        metavar=("X", "Y", "Z"),
        help="m; with --calibrate: the reference's COM in the sensor frame, as a fixture's "
        "drawing gives it (to 0.05 mm; the estimator's reference_com): the calibration then "
        "also takes off the torque's error a COM offset explains. In the sim: the truth line "
        "of a run of the same reference and --seed, which grasps it alike",
    )
    p.add_argument(
        "--excitation",
        choices=EXCITATIONS,
        default=None,
        help="'static' (tilted poses at rest: mass and COM; the sequencer's default) or "
        "'motion' (a designed wrist motion: mass, COM and inertia)",
    )
    p.add_argument(
        "--motion-period",
        type=float,
        help="s; with --excitation motion: each motion's period (default: the sequencer's, "
        f"{SEQUENCER['motion_period'].default:g} s)",
    )
    p.add_argument(
        "--motion-cycles",
        type=int,
        help="with --excitation motion: how many periods the object's motion runs (and the "
        "empty hand's, at least; python -m com_core.planning.motion_accuracy says how many "
        "a target needs; default 1)",
    )
    p.add_argument(
        "--hand-motion-cycles",
        type=int,
        help="with --excitation motion: how many periods the empty hand's motion runs when "
        "it moves (its fit is kept and taken off each object's; default: the sequencer's, "
        f"{SEQUENCER['hand_motion_cycles'].default})",
    )
    p.add_argument(
        "--motion-acceleration",
        type=float,
        help="rad/s^2; with --excitation motion: the bound on each wrist joint's "
        "acceleration, within the arm's own limits (default: the sequencer's, "
        f"{SEQUENCER['motion_acceleration'].default:g}); with a shorter --motion-period, a "
        "faster motion",
    )
    p.add_argument(
        "--target-inertia",
        type=float,
        help="with --excitation motion: each principal moment's sigma, as a fraction of it, "
        "for a guessed box of --mass: the run takes the fastest motion that meets it",
    )
    p.add_argument(
        "--hold",
        action="store_true",
        help="end holding the object (the sequencer's release:=false) and show 1 s of the "
        "compensated wrench",
    )
    p.add_argument("--real-time-factor", type=float, default=5.0, help="0: as fast as possible")
    p.add_argument("--bag-dir", type=Path, default=Path("bags"))
    p.add_argument("--timeout", type=float, default=300.0, help="s for the whole exploration")
    return p


def interrupt(signum: int, _frame: object) -> None:
    """Raise KeyboardInterrupt, as Ctrl-C does, naming the signal ``signum``."""
    raise KeyboardInterrupt(signal.Signals(signum).name)


def interrupted_by(error: KeyboardInterrupt) -> signal.Signals:
    """The signal that raised ``error``: the one ``interrupt`` named, else SIGINT."""
    return signal.Signals.__members__.get(str(error.args[0]) if error.args else "", signal.SIGINT)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.reference_com is not None and not args.calibrate:
        parser.error("--reference-com is the reference weight's: give --calibrate too")
    try:
        import wrench_sim  # noqa: F401  # the simulator: an optional dependency (package.xml)
    except ModuleNotFoundError as error:
        if error.name != "wrench_sim":
            raise
        print(f"demo: {NO_SIMULATOR}", file=sys.stderr)
        return 2
    for sig in STOP_SIGNALS:
        signal.signal(sig, interrupt)
    try:
        robot = read_robot_config(args.robot)
    except RobotConfigError as error:
        print(f"demo: {error}", file=sys.stderr)
        return 2
    params_file = robot_config_path(args.robot)
    print(f"robot: {robot.robot} ({params_file}); sensor: {simulated_sensor(args)}", flush=True)
    keep_dds_local(own_domain=True)
    sim_params, estimator_params, sequencer_params = node_parameters(args)
    refused = flag_refusals(args, sim_params, estimator_params, sequencer_params)
    if refused:  # before any node starts
        print("\n".join(f"demo: {line}" for line in refused), file=sys.stderr)
        return 2
    logs = args.bag_dir / "logs"
    try:
        logs.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        print(f"demo: --bag-dir={str(args.bag_dir)!r} refused: {error}", file=sys.stderr)
        return 2
    started = time.monotonic()
    children: list[Child] = []
    # the simulator and the estimator stop once the demo and the sequencer are gone
    first, last = Lifeline(), Lifeline()
    try:
        for package, name, params, echo, lifeline in (
            ("wrench_sim", "sim_node", sim_params, False, first.popen_kwargs()),
            ("com_estimator", "estimator_node", estimator_params, False, first.popen_kwargs()),
            ("exploration_sequencer", "sequencer_node", sequencer_params, True,
             last.popen_kwargs(holding=first)),
        ):  # fmt: skip
            command = [str(executable(package, name)), *ros_args(params, params_file=params_file)]
            log = logs / f"{package}.log"
            children.append(start_child(package, command, log, echo, lifeline))
            print(f"started {package}/{name} (log: {children[-1].log})", flush=True)
        return run_exploration(args, started, children)
    except KeyboardInterrupt as error:  # the sequencer, stopped first, cancels the run cleanly
        sig = interrupted_by(error)
        print(f"\ndemo: {sig.name}: cancelling the run, then stopping the nodes", flush=True)
        return 128 + sig
    finally:
        for child in reversed(children):
            stop(child.process)
            if child.copier is not None:  # the rest of its output, up to its end
                child.copier.join(timeout=2.0)
        first.close()
        last.close()


def simulated_sensor(args: argparse.Namespace) -> str:
    """The simulated sensor's profile: ``--sensor-profile``, else the one the robot's file
    names (an arm with a sensor of its own, the UR5e's), else DEFAULT_PROFILE."""
    return args.sensor_profile or file_profile(robot_config_path(args.robot)) or DEFAULT_PROFILE


def simulated_sensor_id(sim_params: dict[str, object]) -> str:
    """The simulated sensor's ``sensor_id``: its profile, serial and each part the flags
    set (a cached tare or hand motion of another sensor, or of this one set otherwise,
    never serves it)."""
    parts = [f"{k}={sim_params[k]:g}" for k in ("sigma_f", "sigma_tau") if k in sim_params]
    serial = sim_params.get("sensor_serial", 0)
    return "-".join(["sim", str(sim_params["sensor_profile"]), str(serial), *parts])


def node_parameters(
    args: argparse.Namespace,
) -> tuple[dict[str, object], dict[str, object], dict[str, object]]:
    """The parameters the flags give the simulator, the estimator and the sequencer."""
    # the noise per sample when given: the sim's, and the sequencer's for its first plan
    noise = {
        k: v
        for k, v in (("sigma_f", args.sigma_f), ("sigma_tau", args.sigma_tau))
        if v is not None
    }
    sim_params = {
        "object": args.object,
        "object_mass": args.mass,
        "reference_weight": args.calibrate,
        "seed": args.seed,
        "grasp_mode": args.grasp_mode,
        "slip_sigma": args.slip_sigma,
        "sensor_profile": simulated_sensor(args),
        "sensor_serial": args.sensor_serial,
        "real_time_factor": args.real_time_factor,
    } | noise
    tare_cache = str((args.bag_dir / "tare_cache.json").resolve())  # shared by both nodes
    sensor_id = simulated_sensor_id(sim_params)
    estimator_params = {
        "use_sim_time": True,
        "method": args.method,
        "tare_cache": tare_cache,
        "sensor_id": sensor_id,
    } | ({"information": args.information} if args.information else {})
    profile = PROFILES.get(str(sim_params["sensor_profile"]))  # else refused by its name
    estimator_params |= profile.datasheet() if profile else {}  # as a user tells theirs
    if args.reference_com is not None:  # a reference on a fixture
        estimator_params |= {"reference_com": list(args.reference_com),
                             "reference_com_sigma": FIXTURE_COM_SIGMA}  # fmt: skip
    sequencer_params = {
        "use_sim_time": True,
        "tilt_axes": args.axes.split(","),
        "both_directions": not args.one_way,
        "mass_guess": args.mass,
        "raise_tilt": args.raise_tilt,
        "release": not args.hold,
        "bag_dir": str(args.bag_dir.resolve()),
        "tare_cache": tare_cache,
        "sensor_id": sensor_id,
    } | {k: v for k, v in noise.items() if v > 0}  # none: it plans for its own until a tare
    for key, value in (
        ("excitation", args.excitation),
        ("motion_period", args.motion_period),
        ("motion_cycles", args.motion_cycles),
        ("hand_motion_cycles", args.hand_motion_cycles),
        ("motion_acceleration", args.motion_acceleration),
        ("target_inertia", args.target_inertia),
        ("tilt", args.tilt),
        ("max_tilt", args.max_tilt),
        ("dwell", args.dwell),
        ("target_com_sigma", args.target_sigma),
    ):
        if value is not None:  # else the sequencer's own default
            sequencer_params[key] = value
    return sim_params, estimator_params, sequencer_params


FLAGS = {
    "object_mass": "--mass",
    "mass_guess": "--mass",
    "seed": "--seed",
    "slip_sigma": "--slip-sigma",
    "sensor_profile": "--sensor-profile",
    "sensor_serial": "--sensor-serial",
    "sigma_f": "--sigma-f",
    "sigma_tau": "--sigma-tau",
    "real_time_factor": "--real-time-factor",
    "tilt": "--tilt",
    "max_tilt": "--max-tilt",
    "dwell": "--dwell",
    "target_com_sigma": "--target-sigma",
    "excitation": "--excitation",
    "motion_period": "--motion-period",
    "motion_cycles": "--motion-cycles",
    "hand_motion_cycles": "--hand-motion-cycles",
    "motion_acceleration": "--motion-acceleration",
    "target_inertia": "--target-inertia",
    "tilt_axes": "--axes",
    "bag_dir": "--bag-dir",
    "reference_com": "--reference-com",
}
"""The demo's flag for each node parameter it sets from one (the others are its own)."""
TIMEOUT = Input("timeout", 300.0, "for the whole exploration", unit="s", low=0.0,
                high=86400.0, low_open=True)  # fmt: skip


def flag_refusals(
    args: argparse.Namespace,
    sim: dict[str, object],
    estimator: dict[str, object],
    sequencer: dict[str, object],
) -> list[str]:
    """Why the flags cannot run ([] when they can), each naming the flag: every value the
    nodes would take checked by its parameter's row (``com_core.inputs``), and the
    simulated sensor's parts together (``SensorProfile.problems``)."""
    from wrench_sim.parameters import check_parameter, sensor_profile

    out: dict[str, str] = {}  # by flag: the first refusal (--mass sets two parameters)
    for name, value in sim.items():
        out.setdefault(
            FLAGS.get(name, name), check_parameter(name, value, sim, FLAGS.get(name, ""))
        )
    for table, params in ((SETTINGS, estimator), (SEQUENCER, sequencer)):
        for name, value in params.items():
            if name in table and not out.get(flag := FLAGS.get(name, name)):
                out[flag] = table[name].problem(value, FLAGS.get(name, ""))
    try:
        if sim["sensor_profile"] in PROFILES:  # else refused by its name above
            sensor_profile(sim)
    except InputError as error:  # its parts named by the flags that set them
        text = str(error)
        for name in ("sigma_f", "sigma_tau"):
            text = text.replace(f"{name}=", f"{FLAGS[name]}=")
        out["sensor"] = text
    out["--timeout"] = TIMEOUT.problem(args.timeout, "--timeout")
    return [line for line in out.values() if line]


def start_child(
    package: str, command: list[str], log: Path, echo: bool, popen: dict[str, Any] | None = None
) -> Child:
    """``command`` as a process in a session of its own (Ctrl-C is the demo's: it stops
    the nodes in order), its stdout and stderr to ``log`` and, with ``echo``, to the
    terminal too (``echo_log``, in a thread); ``popen``: more ``subprocess.Popen``
    arguments (a lifeline's ``popen_kwargs``). The process writes its log itself: the log
    is whole even when the demo dies first."""
    with open(log, "w") as out:
        process = subprocess.Popen(
            command, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
            **(popen or {}),
        )  # fmt: skip
    if not echo:
        return Child(package, process, log)
    copier = threading.Thread(target=echo_log, args=(log, process), daemon=True)
    copier.start()
    return Child(package, process, log, copier)


def echo_log(log: Path, process: subprocess.Popen) -> None:
    """Each line ``process`` writes to ``log``, to the terminal as it comes (checked every
    ECHO_POLL s), up to its last once the process has ended. A terminal that is gone
    (closed: SIGHUP) ends the echo; the log goes on."""
    pending = ""
    with open(log, errors="replace") as source:
        while True:
            ended = process.poll() is not None
            pending += source.read()
            *lines, pending = pending.split("\n")
            if ended and pending:
                lines, pending = [*lines, pending], ""
            try:
                sys.stdout.writelines(line + "\n" for line in lines)
                sys.stdout.flush()
            except OSError:
                return
            if ended:
                return
            time.sleep(ECHO_POLL)


def exited(children: Sequence[Child]) -> list[Child]:
    """The children whose process has ended."""
    return [child for child in children if child.process.poll() is not None]


def listen(node, executor, children: Sequence[Child], timeout: float = 10.0) -> tuple[Any, list]:
    """A new best-effort subscription of ``node`` to the compensated stream, and the list
    its messages gather ((stamp ns, frame, wrench) each), spun until the first arrives
    (``timeout`` s at most): the list starts at the stream's present, never at what an
    older reader's queue kept of the past (a reader slower than the stream reads that
    first). Destroy it with ``node.destroy_subscription`` once read."""
    from geometry_msgs.msg import WrenchStamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    gathered: list = []
    subscription = node.create_subscription(
        WrenchStamped,
        COMPENSATED_TOPIC,
        lambda raw: gathered.append(decode_wrench(raw)),
        QoSProfile(depth=COMPENSATED_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT),
        raw=True,
    )
    end = time.monotonic() + timeout
    while not gathered and time.monotonic() < end and not exited(children):
        executor.spin_once(timeout_sec=0.05)
    return subscription, gathered


def collect(
    executor,
    compensated: list,
    seconds: float,
    timeout: float,
    samples: int = 0,
    children: Sequence[Child] = (),
) -> None:
    """Spin ``executor`` until the messages ``compensated`` gathers ((stamp ns, frame,
    wrench) each) span ``seconds`` of the sensor's time and number ``samples`` (a
    best-effort stream faster than this process reads loses some), ``timeout`` s of wall
    time at most, or one of ``children`` has ended."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and not exited(children):
        span = (compensated[-1][0] - compensated[0][0]) * 1e-9 if compensated else -1.0
        if len(compensated) >= samples and span >= seconds:
            return
        executor.spin_once(timeout_sec=0.05)


def wait_for(executor, future, children: Sequence[Child], timeout: float) -> list[Child]:
    """Spin ``executor`` until ``future`` is done, a child has ended (checked every POLL s)
    or ``timeout`` s passed: the children that ended (empty if none did)."""
    deadline = time.monotonic() + timeout
    while not (ended := exited(children)) and not future.done():
        left = deadline - time.monotonic()
        if left <= 0.0:
            break
        executor.spin_until_future_complete(future, timeout_sec=min(POLL, left))
    return ended


def cancel(executor, sent, children: Sequence[Child]) -> None:
    """Cancel the goal of ``sent`` (its ``send_goal_async`` future) once it is accepted, as
    Ctrl-C would, so that the sequencer ends its run before it is stopped: spins at most
    CANCEL_REQUEST_WAIT s in all, and no longer than the children still running do."""
    deadline = time.monotonic() + CANCEL_REQUEST_WAIT
    running = [child for child in children if child.process.poll() is None]
    if wait_for(executor, sent, running, CANCEL_REQUEST_WAIT) or not sent.done():
        return
    if sent.result().accepted:
        wait_for(executor, sent.result().cancel_goal_async(), running, deadline - time.monotonic())


def run_exploration(args: argparse.Namespace, started: float, children: Sequence[Child]) -> int:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import InertiaStamped
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from rclpy.signals import SignalHandlerOptions
    from std_msgs.msg import String

    from com_interfaces.action import Explore

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)  # Ctrl-C: cancel the goal
    node = rclpy.create_node("demo")
    latched = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    truths: list[InertiaStamped] = []
    estimates: list[InertiaStamped] = []
    statuses: list = []
    node.create_subscription(InertiaStamped, TRUTH_TOPIC, truths.append, latched)
    node.create_subscription(InertiaStamped, ESTIMATE_TOPIC, estimates.append, latched)
    node.create_subscription(
        DiagnosticArray,
        DIAGNOSTICS_TOPIC,
        lambda m: statuses.extend(
            (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, s)
            for s in m.status
            if s.name == DIAGNOSTIC_NAME
        ),
        10,
    )
    compensated: list = []
    urdf: list[str] = []
    if args.hold:
        node.create_subscription(String, ROBOT_DESCRIPTION_TOPIC, lambda m: urdf.append(m.data),
                                 latched)  # fmt: skip
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        client = ActionClient(node, Explore, EXPLORE_SERVICE)
        deadline = time.monotonic() + 60.0
        while not (ended := exited(children)) and not client.wait_for_server(POLL):
            if time.monotonic() > deadline:
                print("demo: the sequencer did not come up", file=sys.stderr)
                return 1
        if ended:
            summarise_ended(ended, started)
            return 1
        print(f"sending a goal to {EXPLORE_SERVICE}", flush=True)
        options = Explore.Goal(reference_mass=args.mass if args.calibrate else 0.0)
        sent = client.send_goal_async(options, feedback_callback=show_progress)
        if ended := wait_for(executor, sent, children, 30.0):
            summarise_ended(ended, started)
            cancel(executor, sent, children)
            return 1
        if not sent.done() or not sent.result().accepted:
            print("demo: the sequencer did not take the goal", file=sys.stderr)
            return 1
        goal = sent.result()
        future = goal.get_result_async()
        try:
            ended = wait_for(executor, future, children, args.timeout)
        except KeyboardInterrupt as error:
            sig = interrupted_by(error)
            goal.cancel_goal_async()
            print(f"\ndemo: {sig.name}: cancelling the run", flush=True)
            if ended := wait_for(executor, future, children, CANCEL_WAIT):
                print_ended(ended)
            elif future.done():
                print(f"explore: {future.result().result.message}", flush=True)
            return 128 + sig
        if ended:
            summarise_ended(ended, started)
            cancel(executor, sent, children)
            return 1
        if not future.done():
            print(f"demo: no answer within {args.timeout:g} s", file=sys.stderr)
            return 1
        end = time.monotonic() + 2.0  # the status, and the estimate if it is published
        while time.monotonic() < end and not (
            (statuses and "mass" in status_values(statuses) and estimates) or exited(children)
        ):  # a status heard during the run carries no answer: wait for the one after it
            executor.spin_once(timeout_sec=0.1)
        result = future.result().result
        if args.hold and result.status == "OK":
            subscription, compensated = listen(node, executor, children)
            collect(executor, compensated, 1.0, timeout=10.0, samples=1000, children=children)
            node.destroy_subscription(subscription)
        ended = exited(children)
        print_summary(result, estimates, truths, statuses, time.monotonic() - started)
        if compensated:
            w = np.array([wrench for _, _, wrench in compensated])
            mean, sd = w.mean(axis=0), w.std(axis=0) / np.sqrt(len(w))
            print(
                f"holding:  {COMPENSATED_TOPIC} over {len(w)} samples: f "
                f"({', '.join(f'{v:+.4f}' for v in mean[:3])}) +- "
                f"({', '.join(f'{v:.4f}' for v in sd[:3])}) N, tau "
                f"({', '.join(f'{v * 1e3:+.2f}' for v in mean[3:])}) +- "
                f"({', '.join(f'{v * 1e3:.2f}' for v in sd[3:])}) mN m (contact: none)"
            )
            values = status_values(statuses)
            if values.get("excitation") == MOTION and urdf and not exited(children):
                in_motion(node, executor, urdf[-1], args, values)
        if ended:
            print_ended(ended)
            return 1
        return 0 if result.status == "OK" else 1
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


def in_motion(node, executor, urdf: str, args, values: dict) -> None:
    """Move the wrist along a motion no fit used (a design of its own seed) while holding,
    and print the compensated wrench's rms over it against the sensor's noise: the
    samples stamped from the trajectory's start (sent once the stream is heard, as a
    trajectory controller starts it on arrival) to the motion's end."""
    from trajectory_msgs.msg import JointTrajectory

    from com_core.planning.excitation import design_excitation
    from com_core.robot.choreography import Choreography
    from com_core.sequencing.motion import excitation_path
    from exploration_sequencer.ros_arm import trajectory_message

    config = read_robot_config(args.robot)
    motion = Choreography.of(config, urdf)
    home = [motion.home_positions()[name] for name in motion.robot.joint_names]
    period = args.motion_period or SEQUENCER["motion_period"].default  # the run's
    excitation = design_excitation(motion.robot, home, config.arm_joints[-3:], period=period,
                                   iterations=20, seed=THIRD_MOTION_SEED)  # fmt: skip
    publisher = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
    subscription, compensated = listen(node, executor, ())
    publisher.publish(trajectory_message(excitation_path(excitation, config.arm_joints)))
    collect(executor, compensated, excitation.period, timeout=30.0)
    node.destroy_subscription(subscription)
    if not compensated:
        print(f"in motion: no {COMPENSATED_TOPIC} during the motion")
        return
    w = np.array([wrench for _, _, wrench in compensated])
    rms = np.sqrt(np.mean((w - w.mean(axis=0)) ** 2, axis=0))
    noise = np.array(vector_value(values, "noise_sigma") or [math.nan] * 6)
    print(
        f"in motion: {COMPENSATED_TOPIC} over {len(w)} samples of a {excitation.period:g} s "
        f"wrist motion no fit used: rms f ({', '.join(f'{v:.3f}' for v in rms[:3])}) N, tau "
        f"({', '.join(f'{v * 1e3:.2f}' for v in rms[3:])}) mN m (less its mean); "
        f"({', '.join(f'{v:.2f}' for v in rms / noise)}) x the sensor's noise"
    )


def show_progress(message) -> None:
    """One line per feedback that says something new: phase, percentage, time left and,
    once object windows closed, the live COM sigma."""
    f = message.feedback
    line = f"progress: {f.progress:4.0%} {f.phase}"
    if f.progress > 0:  # a plan to count from
        line += f", {f.time_remaining:.0f} s (sim) left"
    if all(math.isfinite(s) for s in f.sigma_com):
        line += f"; COM sigma so far ({', '.join(f'{s * 1e3:.2f}' for s in f.sigma_com)}) mm"
    if line != getattr(show_progress, "last", ""):
        show_progress.last = line
        print(line, flush=True)


def print_ended(ended: Sequence[Child]) -> None:
    """Per child that ended: its package, its exit code (negative: minus the signal that
    ended it, named), its last error line (``last_error_line`` of its log) and its log's path."""
    for child in ended:
        if child.copier is not None:  # its last lines, up to the end of its output
            child.copier.join(timeout=2.0)
        try:
            line = last_error_line(child.log.read_text(errors="replace")) or "(no output)"
        except OSError as error:
            line = f"(no log: {error})"
        code = child.process.returncode
        killed = f" ({signal.strsignal(-code)})" if code < 0 else ""
        print(f"exited:   {child.package}, exit code {code}{killed}: {line}")
        print(f"          log: {child.log}")


def print_inertia(values: dict[str, str], truth) -> None:
    """The inertia about the COM (kg cm^2, ft_sensor) estimated (or only fitted, not
    published) and held, element by element with the error over its sigma, and the
    principal moments."""
    from com_core.estimation.fits.motion import principal_moments

    elements, published = inertia_value(values)
    estimate = np.array(elements)
    cov = np.array(vector_value(values, "inertia_cov")).reshape(6, 6)
    held = np.array([getattr(truth, name) for name in INERTIA_ELEMENTS])
    z = (estimate - held) / np.sqrt(np.diag(cov))
    moments, sigma = principal_moments(inertia_matrix(estimate), cov)
    true_moments = np.linalg.eigvalsh(inertia_matrix(held))

    def cm2(v) -> str:
        return "(" + ", ".join(f"{1e4 * x:.2f}" for x in v) + ")"

    names = ", ".join(name.capitalize() for name in INERTIA_ELEMENTS)
    state = "" if published else " (not published: a moment within its sigma)"
    print(f"inertia:  {names} {cm2(estimate)} kg cm^2 about the COM{state}")
    print(f"          truth {cm2(held)}; error / sigma ({', '.join(f'{x:+.1f}' for x in z)})")
    print(f"          principal moments {cm2(moments)} +- {cm2(sigma)}, truth {cm2(true_moments)}")


def summarise_ended(ended: Sequence[Child], started: float) -> None:
    """The summary of a run cut short by children that ended: ``print_ended`` and the wall
    time since ``started``."""
    print("\n=== summary ===")
    print_ended(ended)
    print(f"time:     {time.monotonic() - started:.1f} s wall in all", flush=True)


def status_values(statuses: list) -> dict[str, str]:
    """The latest of ``statuses`` ((stamp ns, DiagnosticStatus)) as its values by key."""
    return {kv.key: kv.value for kv in statuses[-1][1].values} if statuses else {}


def print_summary(result, estimates, truths, statuses, wall: float) -> None:
    """The service's answer, the estimate (from the estimator's status, with whether it
    was published on ~/estimate), the ground truth held in the hand, the error."""
    print("\n=== summary ===")
    print(f"explore: {'success' if result.status == 'OK' else 'FAILED'}: {result.message}")
    stamp, values = (statuses[-1][0] if statuses else 0), status_values(statuses)
    if "mass" in values:
        com = [float(values[f"com_{a}"]) for a in "xyz"]
        sig = [float(values[f"sigma_com_{a}"]) * 1e3 for a in "xyz"]
        print(
            f"estimate: mass {float(values['mass']) * 1e3:.2f} +- "
            f"{float(values['sigma_mass']) * 1e3:.2f} g, COM "
            f"({', '.join(f'{c * 1e3:.2f}' for c in com)}) +- "
            f"({', '.join(f'{s:.2f}' for s in sig)}) mm in ft_sensor, information "
            f"{values.get('information', '?')}"
            + ("" if estimates else " (flagged: not published on ~/estimate)")
        )
        if alone := vector_value(values, "wrenches_sigma_com", 1e3):
            print(
                f"          the wrenches alone on the same windows: COM +- "
                f"({', '.join(f'{s:.2f}' for s in alone)}) mm"
            )
        if drift := vector_value(values, "bias_drift"):
            print(
                f"          sensor bias drift since the tare: "
                f"{math.hypot(*drift[:3]):.3f} N, {math.hypot(*drift[3:]) * 1e3:.2f} mN m"
            )
        for line in verification_lines(values):
            print(f"          {line}")
        if noise := noise_line(values):
            print(f"          {noise}")
        held = [t for t in truths if t.header.stamp.sec * 10**9 + t.header.stamp.nanosec <= stamp]
        if held:
            t = held[-1].inertia
            truth = [t.com.x, t.com.y, t.com.z]
            err = [(a - b) * 1e3 for a, b in zip(com, truth, strict=True)]
            print(
                f"truth:    mass {t.m * 1e3:.2f} g, COM "
                f"({', '.join(f'{c * 1e3:.2f}' for c in truth)}) mm"
            )
            print(
                f"error:    mass {(float(values['mass']) - t.m) / t.m:+.2%}, COM "
                f"({', '.join(f'{x:+.2f}' for x in err)}) mm, |e| = "
                f"{math.sqrt(sum(x * x for x in err)):.2f} mm"
            )
            if inertia_value(values)[0] is not None:
                print_inertia(values, t)
    print(f"time:     {wall:.1f} s wall in all")
    if " bag " in result.message:
        bag = Path(result.message.rsplit(" bag ", 1)[1].strip())
        print(f"bag:      {bag}")
        print(f"report:   {bag / 'report.png'}")
        if (bag / PAYLOAD_FILE).is_file():
            print(f"payload:  {bag / PAYLOAD_FILE} (and the control_toolbox and URDF files)")


if __name__ == "__main__":
    sys.exit(main())
