"""Offline replay: the estimate of recorded explorations, as the node computed it.

    replay BAG [BAG ...] [--method ml|two_pose] [--json] [...]

Each BAG is a rosbag2 directory, or a directory of them (every run under ``bags/``):
each run is replayed on its own, one failing run never stops the others, and more than
one ends with a table of them (``--csv FILE``: also as CSV; ``-j N``: N runs at once).
``--json`` prints one JSON object per run (JSON Lines).
The exit code is the worst run's: 0 every estimate OK or WARN, 1 a run with status
ERROR, 2 a path that is no bag or an option out of its range, 3 an internal error (a bug,
with its traceback).

Reads /ft_sensor/wrench and /exploration_sequencer/pose from a rosbag2 directory
(MCAP) and feeds them to the same ``com_core.estimation.runs.exploration.Exploration``
the node uses, with the node's settings of that run (BAG/estimator.yaml; an option
overrides one), so the same messages give the same numbers to the last bit.

A recording without pose labels (a bag this project did not make, a lab's old recording)
with joint states and a robot description (the bag's /robot_description, or
``--robot-description``; ``--sensor-frame``, ``--base-frame``) is fitted as any
recording is (``com_core.estimation.recordings.recording_fit``): the rests and the slow
motion between them, whatever the bias, with the noise learnt from the recording, what
it could not tell named, and a self-check (each half predicting the other). So is a log
of wrenches and the sensor's orientations that never was ROS: ``replay LOG.csv`` or
``LOG.npz`` (columns: ``recording.CSV_COLUMNS``). ``--tare-recording`` (a bag or a log
of the empty tool) gives the object alone; without it, the whole load beyond the sensor.
A stated ``--hysteresis`` takes its gain off a log's readings as off a bag's.

A bag without pose labels nor kinematics is cut into static windows by
``com_core.estimation.recordings.static_windows.find_static_windows`` (blocks of 50 ms
whose spread is at the noise level, joined while their means agree within 6 standard
errors, kept when longer than 0.3 s) and sorted by ``split_load_levels`` into the empty
hand's and the loaded hand's by the magnitude of their mean force (the gravity load, N,
whatever the orientation): each object window is tared with the tare window (of the bag
or of the cached tare) whose force points the same way within 2 deg. With one load level
the estimate is of the whole load beyond the sensor (hand + object), untared. The output
says which it did. Tare windows of poses the bag has no fresh tare for come from the
run's cached tare, BAG/tare.json (``--tare``).

The robot model of a kinematic fit is the bag's /robot_description with the sensor and
base frames of the run's robot configuration, BAG/robot.yaml (``--robot``), unless
``--sensor-frame`` or ``--base-frame`` set them. A run in motion that reused the empty
hand's motion fit of an earlier run has it in BAG/hand_motion.json, and a run of a sensor
calibrated in place its calibration in BAG/sensor_calibration.json.

A bag whose MCAP file was cut short (no Footer) is read up to the cut, and one with a
damaged chunk (a bad sector, a copy gone wrong) is read around it
(``com_core.bags.reader``); a labelled run without its ``done`` label, cut before the end
of its last window, or with a damaged chunk is reported WARN with the reason (its
estimate is kept); ``--json`` gives what was read under ``bag``.
"""

from __future__ import annotations

import argparse
import builtins
import csv
import dataclasses
import functools
import io
import json
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext, redirect_stderr, redirect_stdout
from pathlib import Path

from com_core.bags.reader import INCOMPLETE_TEXT, BagReading
from com_core.contract import (
    ERROR,
    INTERNAL_ERROR,
    OK,
    POSE_TOPIC,
    WARN,
    WINDOW_PREFIXES,
    WRENCH_TOPIC,
)
from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.recordings import (
    Recording,
    RecordingFit,
    fit_recording,
    read_recording_file,
    recording_from_bag,
    recording_from_inbox,
)
from com_core.estimation.recordings.static_windows import find_static_windows, split_load_levels
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.feed import feed_bag
from com_core.estimation.runs.fit_setup import WRENCHES
from com_core.estimation.runs.hand_motion import HAND_MOTION_FILE, load_hand_motion
from com_core.estimation.runs.sensor_calibration import (
    CALIBRATION_FILE,
    SensorCalibration,
    calibration_path,
    load_calibration,
    save_calibration,
)
from com_core.estimation.runs.settings import (
    BAG_SETTINGS_FILE,
    SETTINGS,
    defaults,
    exploration_from,
    read_bag_settings,
    robot_from,
    use_cached_tares,
    use_sensor_calibration,
)
from com_core.estimation.runs.solution import (
    Solution,
    format_solution,
    missing_samples,
    window_counts,
)
from com_core.estimation.runs.tare_cache import BAG_TARE_FILE
from com_core.inputs import refusal, unwritable
from com_core.planning.decisions import tare_cache_path
from com_core.report.recording import write_recording_report
from com_core.robot.config import BAG_ROBOT_FILE, RobotConfigError, read_robot_config
from com_core.sensing.calibration import Calibration, reading_correction

ROBOT_FRAMES = ("sensor_frame", "base_frame")
"""The settings a run's robot configuration gives the replay."""


INTERNAL_ERROR_CODE = 3


def build_parser() -> argparse.ArgumentParser:
    """The bag, the estimator's settings as options (``--sigma-f`` for ``sigma_f``, with
    the node's defaults) but ``tare_cache`` (``--tare``), the topics, ``--json``."""
    parser = argparse.ArgumentParser(prog="replay", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "bags",
        type=Path,
        nargs="+",
        metavar="BAG",
        help="rosbag2 directory (MCAP storage), or a directory of them",
    )
    for name, row in SETTINGS.items():
        if name != "tare_cache":
            option = "--" + name.replace("_", "-")
            text = f"{row.description}; {row.allowed()}".replace("%", "%%")  # argparse's %
            # unset: the run's (its estimator.yaml, robot.yaml), else the default
            text += f" (default: the run's; without it {row.default!r})"
            if isinstance(row.default, list):
                parser.add_argument(option, type=float, nargs=len(row.default), help=text)
            else:
                parser.add_argument(option, type=type(row.default), help=text)
    parser.add_argument("--wrench-topic", default=WRENCH_TOPIC)
    parser.add_argument("--pose-topic", default=POSE_TOPIC)
    parser.add_argument(
        "--tare",
        type=Path,
        default=None,
        help=f"cached tare windows (default: BAG/{BAG_TARE_FILE} if present)",
    )
    parser.add_argument(
        "--tare-recording",
        type=Path,
        default=None,
        help="a recording of the empty tool (a bag, or a CSV or .npz log) for a recording "
        "without pose labels: the object alone comes out",
    )
    parser.add_argument(
        "--report",
        type=Path,
        default=None,
        help="for a recording without pose labels: write its PNG report to this file",
    )
    parser.add_argument(
        "--robot",
        type=Path,
        default=None,
        help=f"robot configuration whose frames the fit takes (default: BAG/{BAG_ROBOT_FILE} "
        "if present)",
    )
    parser.add_argument(
        "--calibration", type=Path, metavar="FILE",
        help="with --reference-mass (a run of a reference weight): keep the sensor's "
        f"calibration in place in FILE (default: {CALIBRATION_FILE} beside the bag's "
        "directory, where the nodes' default tare cache is)",
    )  # fmt: skip
    parser.add_argument(
        "--json", action="store_true", help="print one JSON object per run (JSON Lines)"
    )
    parser.add_argument("--csv", type=Path, help="also write one row per run to this file")
    parser.add_argument(
        "-j", "--jobs", type=int, default=1, help="runs replayed at once (processes)"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"-j {args.jobs}: must be 1 or more")
    refused = [  # each named by its option
        why
        for name, value in option_settings(args).items()
        if (why := SETTINGS[name].problem(value, "--" + name.replace("_", "-")))
    ]
    if args.csv is not None and (why := unwritable("--csv", args.csv)):
        refused.append(why)
    if args.report is not None and (why := unwritable("--report", args.report)):
        refused.append(why)
    if args.tare is not None and not args.tare.is_file():
        refused.append(refusal("--tare", str(args.tare), "is no file"))
    if args.tare_recording is not None and not args.tare_recording.exists():
        refused.append(refusal("--tare-recording", str(args.tare_recording), "does not exist"))
    if refused:
        parser.error("; ".join(refused))  # before any run is read: exit code 2
    runs = [run for path in args.bags for run in bag_directories(path)]
    if args.calibration is not None and len(runs) != 1:
        parser.error(f"--calibration keeps the calibration of one run, not {len(runs)}")
    codes, rows = [], []
    with ProcessPoolExecutor(args.jobs) if args.jobs > 1 else nullcontext() as pool:
        mapped = (pool or builtins).map(replay_captured, runs, [args] * len(runs))
        for k, (bag, (code, solution, out, err)) in enumerate(zip(runs, mapped, strict=True)):
            sys.stdout.write(out)
            sys.stderr.write(err)
            if len(runs) > 1:  # progress, apart from the output
                status = solution.status if solution else "NO BAG"
                print(f"replay: [{k + 1}/{len(runs)}] {status} {bag}", file=sys.stderr)
            codes.append(code)
            rows.append((bag, solution))
    if len(runs) > 1 and not args.json:
        print(summary_table(rows))
    if args.csv is not None:
        write_csv(args.csv, rows)
    return max(codes)


def option_settings(args: argparse.Namespace) -> dict[str, object]:
    """The estimator settings the options give (those given only)."""
    names = [name for name in SETTINGS if name != "tare_cache"]
    return {name: getattr(args, name) for name in names if getattr(args, name) is not None}


def replay_captured(bag: Path, args: argparse.Namespace) -> tuple[int, Solution | None, str, str]:
    """``replay`` of one run with what it prints kept: (exit code, solution, stdout,
    stderr); a defect of this program is said with its traceback and is that run's ERROR
    (``INTERNAL_ERROR`` in its reason, exit code 3), and the other runs go on."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code, solution = replay(bag, args)
        except Exception as exc:
            print(f"replay: {bag}: {INTERNAL_ERROR}\n{traceback.format_exc()}", file=sys.stderr)
            code = INTERNAL_ERROR_CODE
            solution = Solution(ERROR, f"{INTERNAL_ERROR}: {exc!r}", args.method or "ml")
    return code, solution, out.getvalue(), err.getvalue()


def write_csv(path: Path, rows: list[tuple[Path, Solution | None]]) -> None:
    """One row per run: the bag, status, mass and COM with their sigmas (kg, m), reason."""
    columns = ["bag", "status", "mass", "sigma_mass"]
    columns += [f"{k}_{a}" for k in ("com", "sigma_com") for a in "xyz"] + ["reason"]
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        for bag, solution in rows:
            e = solution.estimate if solution else None
            numbers = [e.mass, e.sigma_mass, *e.com, *e.sigma_com] if e is not None else [""] * 8
            status = solution.status if solution else "NO BAG"
            writer.writerow([str(bag), status, *numbers, solution.reason if solution else ""])


def bag_directories(path: Path) -> list[Path]:
    """``path`` if it is a rosbag2 directory, else the rosbag2 directories in it (sorted;
    one level down), else ``[path]`` (which replay then refuses by name)."""
    if is_bag(path) or not path.is_dir():
        return [path]
    found = sorted(p for p in path.iterdir() if p.is_dir() and is_bag(p))
    return found or [path]


def is_bag(path: Path) -> bool:
    """A rosbag2 directory: metadata.yaml or an MCAP file in it."""
    return (path / "metadata.yaml").is_file() or any(path.glob("*.mcap"))


LOG_SUFFIXES = (".csv", ".npz")
"""A log of wrenches and orientations that never was ROS (``recording.read_recording_file``)."""


def summary_table(rows: list[tuple[Path, Solution | None]]) -> str:
    """One line per run: status, mass and COM with their sigmas, the bag; then counts."""
    lines = ["", f"{'status':7} {'mass g, COM mm (sensor frame)':>61}  bag"]
    counts: dict[str, int] = {}
    for bag, solution in rows:
        status = solution.status if solution else "NO BAG"
        counts[status] = counts.get(status, 0) + 1
        e = solution.estimate if solution else None
        if e is None:
            numbers = f"{'-':>16} {'-':>44}"
        else:
            com = ", ".join(f"{c * 1e3:.2f}" for c in e.com)
            sigma = ", ".join(f"{c * 1e3:.2f}" for c in e.sigma_com)
            numbers = f"{e.mass * 1e3:8.2f} +- {e.sigma_mass * 1e3:4.2f} ({com}) +- ({sigma})"
        lines.append(f"{status:7} {numbers:>61}  {bag}")
    lines.append(", ".join(f"{n} {status}" for status, n in counts.items()) + f" of {len(rows)}")
    return "\n".join(lines)


def replay(bag: Path, args: argparse.Namespace) -> tuple[int, Solution | None]:
    """One run replayed and printed; (exit code, its solution or None when refused)."""
    args = argparse.Namespace(**vars(args), bag=bag)
    if args.bag.is_file() and args.bag.suffix in LOG_SUFFIXES:
        read = functools.partial(read_recording_file, args.bag)
        return replay_recording(args, read, option_settings(args), {})
    if not is_bag(args.bag):
        print(f"replay: {args.bag} is not a rosbag2 directory", file=sys.stderr)
        return 2, None
    settings = read_bag_settings(args.bag / BAG_SETTINGS_FILE) | option_settings(args)
    robot_file = args.robot or args.bag / BAG_ROBOT_FILE
    robot = None
    if args.robot is not None or robot_file.is_file():
        try:
            robot = read_robot_config(str(robot_file))
        except RobotConfigError as error:
            print(f"replay: {error}", file=sys.stderr)
            return 2, None
    for name in ROBOT_FRAMES:  # an option, else the run's configuration, else the default
        if name not in settings:
            settings[name] = getattr(robot, name) if robot else SETTINGS[name].default
    exploration = exploration_from(settings)
    sensor_id = robot.sensor_id if robot else ""  # the run's calibration, as the node took it
    if exploration.reference is None:  # a calibration reads the sensor as it reads
        calibration = load_calibration(args.bag / CALIBRATION_FILE, sensor_id)
        use_sensor_calibration(exploration, calibration)
    use_cached_tares(exploration, args.tare or args.bag / BAG_TARE_FILE)
    reading = BagReading()
    n_wrench, n_label = feed_bag(
        args.bag, exploration, args.wrench_topic, args.pose_topic, reading=reading
    )
    if exploration.information != WRENCHES and exploration.robot is None:
        exploration.robot, exploration.robot_problem = robot_from(
            settings, reading.robot_description
        )
    if (cached := load_hand_motion(args.bag / HAND_MOTION_FILE)) is not None:
        exploration.hand_motion = cached.fit  # the node's, from its cache
    if not n_label and exploration.robot is not None and exploration.joint_states:
        robot = exploration.robot
        return replay_recording(
            args,
            lambda: recording_from_inbox(exploration, robot, str(args.bag)),
            settings,
            {"messages": n_wrench, "bag": reading.as_dict()},
            exploration.calibration,
            corrected=True,  # exploration.samples(): through the calibration and the gain
        )
    if n_label:
        source = f"pose labels from the bag ({n_label})"
    else:
        if exploration.robot_problem:
            print(f"replay: no kinematics: {exploration.robot_problem}", file=sys.stderr)
        stamps, wrenches = exploration.samples()
        levels = split_load_levels(find_static_windows(stamps, wrenches), exploration.tares)
        for stamp, label in levels.labels:
            exploration.add_label(stamp, label)
        exploration.untared = levels.untared
        source = f"no pose labels in the bag: {levels.describe()}"
    reasons = cut_short_reasons(exploration, n_label, reading)
    solution = exploration.solve()
    used = window_counts(reading.estimator_values)  # the node's, from its status in the bag
    solution = with_warnings(solution, reasons + missing_samples(used, solution.window_samples))
    kept = keep_calibration(args, solution, sensor_id) if solution.calibrated else ""
    if args.json:
        extra = {
            "path": str(args.bag),
            "windows_from": source,
            "messages": n_wrench,
            "bag": reading.as_dict(),
        } | ({"calibration_kept": kept} if kept else {})
        print(json.dumps(solution.as_dict() | extra))
    else:
        print(f"{args.bag}: {n_wrench} wrenches; windows from {source}")
        for note in reading.notes():
            print(f"bag: {note}")
        if reading.cut_short and n_label and not reasons:
            print("bag: the cut lies after done: every window of the run was read")
        print(format_solution(solution))
        if kept:
            print(kept)
    return (1 if solution.status == ERROR else 0), solution


def keep_calibration(args: argparse.Namespace, solution: Solution, sensor_id: str) -> str:
    """Keep the calibration in place ``solution`` identified (a run of a reference weight)
    for ``sensor_id`` when the command line asked for it (``--reference-mass`` or
    ``--calibration``), in ``--calibration`` or beside the bag's directory; what was done
    (after what it is, when its status does not say)."""
    assert solution.calibrated is not None
    summary = "" if solution.status == OK else solution.calibrated.summary() + "\n"
    if not sensor_id:
        why = f"the run's {BAG_ROBOT_FILE} names no sensor_id (give one with --robot)"
        return f"{summary}calibration not kept: it is kept per sensor, and {why}"
    if solution.calibration is None:
        return f"{summary}calibration not kept: {solution.reason}"
    if args.reference_mass is None and args.calibration is None:
        return "calibration not kept here (the node kept it; --calibration FILE keeps it)"
    path = args.calibration or calibration_path(tare_cache_path("", str(args.bag.parent)))
    save_calibration(path, SensorCalibration(sensor_id, time.time(), solution.calibration))
    return (f"calibration of {sensor_id!r} kept in {path}: the estimator applies it to that "
            "sensor's runs (with the tare cache beside it)")  # fmt: skip


def replay_recording(
    args: argparse.Namespace,
    read,
    settings: dict,
    extra: dict,
    calibration: Calibration | None = None,
    corrected: bool = False,
) -> tuple[int, RecordingFit | None]:
    """A recording without labels fitted (``recording.fit_recording``) and printed, with
    ``--tare-recording``; ``read()`` gives the ``Recording``, ``settings`` the estimator's
    (the run's and the options'; the calibration, gravity, hysteresis and drift prior the
    fit takes). ``calibration``: the sensor's calibration in place, in place of the
    settings' stated accuracy. Its readings and the tare recording's are read through it
    and the gain of the settings' hysteresis (``sensing.calibration.reading_correction``),
    the recording's own unless ``corrected`` (a bag's samples, read so already).
    (exit code, the fit or None when the recording or its tare cannot be read)."""
    settings = defaults() | settings
    exploration = exploration_from(settings)
    calibration = calibration or exploration.calibration
    try:
        recording = read()
        tare = None if args.tare_recording is None else tare_recording(args)
    except (EstimationError, ValueError, OSError) as error:
        print(f"replay: {args.bag}: {error}", file=sys.stderr)
        return 2, None
    correction = reading_correction(calibration, exploration.hysteresis)
    if correction is not None:  # the same sensor's readings
        if not corrected:
            recording = dataclasses.replace(recording, wrenches=recording.wrenches @ correction.T)
        if tare is not None:
            tare = dataclasses.replace(tare, wrenches=tare.wrenches @ correction.T)
    fit = fit_recording(
        recording,
        tare,
        calibration,
        settings["gravity"],
        exploration.bias_drift_rate,
    )
    if args.report is not None:
        write_recording_report(recording, fit, args.report)
    if args.json:
        print(
            json.dumps(
                fit.as_dict() | {"path": str(args.bag), "windows_from": "recording"} | extra
            )
        )
    else:
        print(
            f"{args.bag}: {len(recording.times)} wrenches; a recording without pose labels "
            f"({'joint states' if recording.dynamic else 'orientations'})"
        )
        print(fit.summary())
    return (1 if fit.status == ERROR else 0), fit


def tare_recording(args: argparse.Namespace) -> Recording:
    """The ``--tare-recording``: a log, or a bag with joint states and the robot model of
    the options (or of the bag's /robot_description)."""
    path = args.tare_recording
    if path.is_file():
        return read_recording_file(path)
    try:
        return recording_from_bag(path, option_settings(args), args.wrench_topic)
    except EstimationError as error:
        raise EstimationError(f"--tare-recording {error}") from error


def cut_short_reasons(exploration: Exploration, n_label: int, reading: BagReading) -> list[str]:
    """Why the bag may hold only part of the exploration ([] when it holds all of it).

    A labelled run is whole when it has its ``done`` label and, if its MCAP file was cut,
    samples up to the ``done`` stamp (ns, sensor time); a cancelled run says so. An
    unlabelled bag cannot tell, so a cut file or a recording never closed is reason
    enough.
    """
    reasons = []
    if exploration.cancelled:
        when = ", ".join(f"{t * 1e-9:.3f} s" for t in exploration.cancelled)
        reasons.append(f"the run was cancelled (at {when}): its windows were dropped")
    if n_label:
        done = exploration.done_stamp()
        latest = exploration.latest_stamp
        if done is None and not exploration.cancelled:
            reasons.append(
                f"the run has no done label: cut short after {last_window(exploration)}"
            )
        elif done is not None and reading.cut_short and (latest is None or latest < done):
            end = "no samples" if latest is None else f"samples end at {latest * 1e-9:.3f} s"
            reasons.append(f"{end}, before done at {done * 1e-9:.3f} s: the last window is cut")
    reasons += [reading.damaged_text()] if reading.damaged else []
    if reasons or not n_label:
        reasons += [reading.cut_text()] if reading.cut_short else []
        reasons += [INCOMPLETE_TEXT] if reading.complete is False else []
    return reasons


def last_window(exploration: Exploration) -> str:
    """The last window label that arrived, or what was there instead."""
    windows = [label for _, label in exploration.labels if label.startswith(WINDOW_PREFIXES)]
    return windows[-1] if windows else "no window label (before the first window)"


def with_warnings(solution: Solution, reasons: list[str]) -> Solution:
    """``solution`` with ``reasons`` first in its reason and notes; OK becomes WARN."""
    if not reasons:
        return solution
    text = "; ".join(reasons)
    status = WARN if solution.status == OK else solution.status
    reason = text if solution.status == OK else f"{text}; {solution.reason}"
    notes = (*reasons, *solution.notes)
    return dataclasses.replace(solution, status=status, reason=reason, notes=notes)


if __name__ == "__main__":
    sys.exit(main())
