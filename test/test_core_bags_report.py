"""com_core.report.figure (and bags.run, which it reads a run with): a PNG per bag, also for
failed runs and bags missing topics."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from com_core.bags.cdr import encode_header, encode_wrench_stamped
from com_core.bags.reader import RECORDER_LOST_KEY
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import (
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    ERROR,
    ESTIMATE_TOPIC,
    HAND_TRUTH_TOPIC,
    MOVING,
    OBJECT_TOPIC,
    OK,
    POSE_TOPIC,
    TARE_PREFIX,
    TRUTH_TOPIC,
    WARN,
    WRENCH_TOPIC,
)
from com_core.estimation.runs.cutting import window_sample_counts
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.solution import Solution, missing_samples
from com_core.paper.synthetic import Load, exploration_stream
from com_core.planning.planner import Plan
from com_core.report.commands import SentTrajectory, trajectory_problems
from com_core.report.figure import write_report
from com_core.report.run import read_run

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))
TS = get_typestore(Stores.ROS2_JAZZY)
T = TS.types
LEVELS = {"OK": 0, "WARN": 1, "ERROR": 2}
FAR = (0.3, 0.4, -0.5)
SLIP = (0.0, 0.0, -0.002)  # m  # the object on the table, before the grasp and after the release


def _header(stamp_ns: int, frame_id: str = "ft_sensor"):
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )


def _inertia(stamp_ns: int, mass: float, com) -> bytes:
    msg = T["geometry_msgs/msg/InertiaStamped"](
        header=_header(stamp_ns),
        inertia=T["geometry_msgs/msg/Inertia"](
            m=float(mass),
            com=T["geometry_msgs/msg/Vector3"](x=com[0], y=com[1], z=com[2]),
            ixx=0.0, ixy=0.0, ixz=0.0, iyy=0.0, iyz=0.0, izz=0.0,
        ),
    )  # fmt: skip
    return bytes(TS.serialize_cdr(msg, "geometry_msgs/msg/InertiaStamped"))


def _string(text: str) -> bytes:
    return bytes(TS.serialize_cdr(T["std_msgs/msg/String"](data=text), "std_msgs/msg/String"))


def _diagnostics(stamp_ns: int, solution: Solution, samples: int) -> list[bytes]:
    """Two DiagnosticArrays at ``stamp_ns``: the estimator's status, then another node's."""
    kv = T["diagnostic_msgs/msg/KeyValue"]
    values = [kv(key=k, value=v) for k, v in solution.diagnostic_values()]
    values.append(kv(key="samples", value=str(samples)))
    ours = T["diagnostic_msgs/msg/DiagnosticStatus"](
        level=LEVELS[solution.status],
        name=DIAGNOSTIC_NAME,
        message=solution.reason,
        hardware_id="ft_sensor",
        values=values,
    )
    other = T["diagnostic_msgs/msg/DiagnosticStatus"](
        level=2, name="some_driver: temperature", message="too hot", hardware_id="", values=[]
    )
    array = T["diagnostic_msgs/msg/DiagnosticArray"]
    return [
        bytes(TS.serialize_cdr(array(header=_header(stamp_ns), status=[s]), array.__msgtype__))
        for s in (ours, other)
    ]


def write_run(
    path: Path,
    dwell: float = 0.5,
    seed: int = 1,
    drop_tare: bool = False,
    skip: tuple[str, ...] = (),
    shift_sigma: float = 0.0,
    lose: int = 0,
) -> tuple[Solution, float]:
    """A run bag as the sequencer records it; returns the estimator's solution and done (s).

    The truth is published not held at the start (object on the table), held at the grasp
    (the first object window), and not held again after ``done`` (the release).
    ``drop_tare`` relabels the tare windows ``moving`` (an ERROR run: no tare);
    ``shift_sigma`` (m) moves the object in the grasp at each tilt, and the truth is then
    republished (held) at the last object window with the COM moved by 2 mm. ``lose``
    wrenches of the first object window the estimator used are not in the bag, and its
    metadata.yaml says the recorder lost them.
    """
    stream = exploration_stream(
        Plan(dwell=dwell, gravity_home=(0, 0, -1)),
        LOAD,
        HAND,
        np.random.default_rng(seed),
        shift_sigma=shift_sigma,
    )
    labels = [
        (s, MOVING if drop_tare and lbl.startswith(TARE_PREFIX) else lbl)
        for s, lbl in stream.labels
    ]
    exploration = Exploration()
    exploration.add_samples(stream.stamps, stream.wrenches, "ft_sensor")
    for stamp, label in labels:
        exploration.add_label(stamp, label)
    solution = exploration.solve()
    done = exploration.done_stamp()
    grasp = next(s for s, lbl in labels if lbl.startswith("object/"))
    start, end = int(stream.stamps[0]), int(stream.stamps[-1])

    messages = [
        (int(s), WRENCH_TOPIC, "geometry_msgs/msg/WrenchStamped",
         encode_wrench_stamped(int(s), "ft_sensor", w))
        for s, w in zip(stream.stamps, stream.wrenches, strict=True)
    ]  # fmt: skip
    messages += [
        (s, POSE_TOPIC, "std_msgs/msg/Header", encode_header(s, lbl)) for s, lbl in labels
    ]
    inertia, string = "geometry_msgs/msg/InertiaStamped", "std_msgs/msg/String"
    described = "shape=box mass=0.1000 grasp_mode=rigid state="
    messages += [
        (start, TRUTH_TOPIC, inertia, _inertia(start, LOAD.mass, FAR)),
        (start + 1, OBJECT_TOPIC, string, _string(described + "not_held")),
        (grasp - 5, TRUTH_TOPIC, inertia, _inertia(grasp - 5, LOAD.mass, LOAD.com)),
        (grasp - 4, OBJECT_TOPIC, string, _string(described + "held")),
        (end, TRUTH_TOPIC, inertia, _inertia(end, LOAD.mass, FAR)),
        (end + 1, OBJECT_TOPIC, string, _string(described + "not_held")),
        (start, HAND_TRUTH_TOPIC, inertia, _inertia(start, HAND.mass, HAND.com)),
    ]
    if shift_sigma:
        last = [s for s, lbl in labels if lbl.startswith("object/")][-1]
        slipped = np.add(LOAD.com, SLIP)
        messages.append((last, TRUTH_TOPIC, inertia, _inertia(last, LOAD.mass, slipped)))
    if solution.estimate is not None:
        e = solution.estimate
        messages.append((done + 1, ESTIMATE_TOPIC, inertia, _inertia(done, e.mass, e.com)))
    diag = _diagnostics(done, solution, exploration.sample_count)
    messages += [(done + 2 + k, DIAGNOSTICS_TOPIC, "diagnostic_msgs/msg/DiagnosticArray", raw)
                 for k, raw in enumerate(diag)]  # fmt: skip
    lost = set(range(grasp + 10**8, grasp + 10**8 + lose * 10**6))  # 1 kHz stamps
    with CrashSafeBagWriter(path) as bag:
        for stamp, topic, msgtype, raw in sorted(messages, key=lambda m: m[0]):
            if topic not in skip and not (topic == WRENCH_TOPIC and stamp in lost):
                bag.write(topic, msgtype, stamp, raw)
        if lose:
            bag.custom_data[RECORDER_LOST_KEY] = json.dumps({WRENCH_TOPIC: lose})
    return solution, done * 1e-9


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) px of a PNG; asserts the signature and the IHDR chunk."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def test_report_of_a_good_run(tmp_path):
    bag = tmp_path / "run_ok"
    solution, _ = write_run(bag, dwell=2.0)  # ~23k wrench messages, as a real run
    assert solution.status == OK
    started = time.process_time()  # CPU time: what another busy process leaves alone
    png = write_report(bag)
    elapsed = time.process_time() - started
    assert png == bag / "report.png" and png.exists()
    assert png_size(png) == (1600, 1100)
    assert png.stat().st_size > 50_000  # a drawn figure, not an empty canvas
    assert elapsed < 10.0, f"report took {elapsed:.2f} s of CPU"  # ~1.5 s here

    run = read_run(bag)
    assert run.status == OK and run.missing == []
    assert len(run.stamps) == run.counts[WRENCH_TOPIC] > 20_000
    assert run.diagnostic["values"]["method"] == "ml"  # the estimator's, not the other node's
    assert run.estimate.mass == solution.estimate.mass
    # the truth held in the hand before done, not the object on the table
    np.testing.assert_allclose(run.truth.com, LOAD.com)
    assert "held" in run.truth_note


def test_report_of_an_error_run_shows_the_reason(tmp_path):
    bag = tmp_path / "run_error"
    solution, _ = write_run(bag, drop_tare=True)
    assert solution.status == ERROR and solution.estimate is None
    png = write_report(bag, tmp_path / "out" / "error.png")
    assert png == tmp_path / "out" / "error.png"
    assert png_size(png) == (1600, 1100)
    run = read_run(bag)
    assert run.status == ERROR and run.estimate is None
    assert run.missing == [ESTIMATE_TOPIC]
    assert run.diagnostic["message"] == solution.reason


@pytest.mark.parametrize(
    "skip",
    [
        (TRUTH_TOPIC, HAND_TRUTH_TOPIC, OBJECT_TOPIC),
        (DIAGNOSTICS_TOPIC,),
        (WRENCH_TOPIC, POSE_TOPIC),
        (WRENCH_TOPIC, POSE_TOPIC, ESTIMATE_TOPIC, DIAGNOSTICS_TOPIC, TRUTH_TOPIC),
    ],
    ids=["no-truth", "no-diagnostics", "no-wrench-no-labels", "almost-empty"],
)
def test_report_of_a_bag_missing_topics_says_what_is_missing(tmp_path, skip):
    bag = tmp_path / "run"
    write_run(bag, skip=skip)
    png = write_report(bag)
    assert png_size(png) == (1600, 1100)
    run = read_run(bag)
    assert set(skip) <= set(run.missing)
    if TRUTH_TOPIC in skip:
        assert run.truth is None and run.truth_note == "no ground truth"


def test_report_of_a_run_where_the_object_moved_in_the_grasp(tmp_path):
    bag = tmp_path / "run_warn"
    solution, _ = write_run(bag, dwell=1.0, seed=4, shift_sigma=0.003)
    assert solution.status == WARN and solution.consistency.suspect_pose
    png = write_report(bag)
    assert png_size(png) == (1600, 1100)
    run = read_run(bag)
    assert run.status == WARN
    assert run.diagnostic["values"]["suspect_pose"] == solution.consistency.suspect_pose
    # the last truth while held before done: the slipped one, and the note says so
    np.testing.assert_allclose(run.truth.com, np.add(LOAD.com, SLIP))
    assert "moved 2.00 mm" in run.truth_note


def test_report_of_a_path_that_is_not_a_bag(tmp_path):
    with pytest.raises(FileNotFoundError):
        write_report(tmp_path / "nothing")


def test_report_module_leaves_pyplot_alone():
    """It draws on its own Figure: importing it neither loads pyplot (nor rclpy, which
    test_ros_free checks for every core module)."""
    code = "import sys, com_core.report.figure; assert 'matplotlib.pyplot' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_report_of_a_kinematic_run_shows_its_own_numbers():
    """The sample run (information kinematics+mount): the banner names the model and the
    numbers show what the wrenches alone give on its windows, the bias drift, the hand
    fitted (the sim's 1.010 kg, to the realistic sensor's 1 % calibration), the mounting,
    the base tilt and the sensor's noise learnt; lines fit the column."""
    from conftest import WORKSPACE

    from com_core.report.figure import _summary_lines

    run = read_run(WORKSPACE / "bags" / "sample")
    assert run.diagnostic["values"]["information"] == "kinematics+mount"
    lines = _summary_lines(run, [])
    text = "\n".join(lines)
    for start in ("wrenches   alone: COM", "bias drift", "hand fit   1.0", "mounting   rpy"):
        assert start in text, text
    assert "sensor noise 0.1" in text and "correlation time" in text, text
    assert "base tilt " in text and all(len(line) <= 64 for line in lines), text


def test_the_numbers_show_the_verification_wrapped_to_the_table():
    from com_core.report.figure import _kinematic_lines

    values = {
        "verify_wrench diagonal": "0.003,0.001,-0.007,3e-05,-0.00016,0.00015",
        "verify_sigma diagonal": "0.003,0.003,0.003,0.00014,0.00015,0.00014",
        "verify_distance diagonal": "2.68,1.53,4.03",
    }
    lines = _kinematic_lines(values)
    assert lines[0].startswith("verification 'diagonal': f (0.003, 0.001, -0.007)")
    assert "2.68 and 1.53 sigma (4.03 allowed)" in " ".join(lines)
    assert all(len(line) <= 64 for line in lines)


def test_a_run_in_motion_shows_its_inertia_against_the_truth_held():
    """The inertia's six elements of the estimator's status (kg m^2, shown in kg cm^2),
    each against the truth's element of the same name, with its sigma; none for a run
    without them (static)."""
    from com_core.report.figure import _inertia_rows
    from com_core.report.run import Inertia, RunData

    values = {
        "inertia": "2e-4,1e-6,-2e-6,3e-4,4e-6,3.5e-4",
        "sigma_inertia": "1e-5,2e-5,3e-5,4e-5,5e-5,6e-5",
    }
    held = np.array([2.1e-4, 0.0, 0.0, 3.1e-4, 0.0, 3.4e-4])
    truth = Inertia(0, 0, 0.5, np.zeros(3), held)
    run = RunData("motion", diagnostic={"level": 0, "message": "", "values": values}, truth=truth)
    rows = _inertia_rows(run)
    assert [row.name for row in rows] == ["Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]
    np.testing.assert_allclose([r.error for r in rows], [-0.1, 0.01, -0.02, -0.1, 0.04, 0.1])
    np.testing.assert_allclose([r.sigma for r in rows], [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    static = RunData("static", diagnostic={"level": 0, "message": "", "values": {"mass": "0.5"}})
    assert _inertia_rows(static) == []


def test_the_fits_quality_is_its_p_value_at_rest_and_its_chi2_per_dof_in_motion():
    from com_core.report.figure import _fit_quality

    at_rest = {"chi2": "32.81", "dof": "41", "p_value": "0.815"}
    assert _fit_quality(at_rest) == "32.81 / 41,  p = 0.815"
    in_motion = {"chi2": "21577.18", "dof": "19774", "p_value": "nan", "excitation": "motion",
                 "chi2_expected_per_dof": "1.2", "chi2_allowed_per_dof": "2.041"}  # fmt: skip
    assert _fit_quality(in_motion) == "1.091 (one rigid load up to 2.041)"
    del in_motion["chi2_allowed_per_dof"]  # recorded before the run's allowance was kept
    assert _fit_quality(in_motion) == "1.091 (one rigid load up to 1.800)"
    assert _fit_quality({"mass": "0.5"}) is None


def test_a_bag_that_lacks_samples_the_estimator_used_says_which_window(tmp_path):
    """The bag's samples per window against the estimator's counts in its status: whole,
    nothing; 7 wrenches lost in the first object window, that window with both counts and
    the recorder's own count, in the report's problems too."""
    whole, lacking = tmp_path / "whole", tmp_path / "lacking"
    solution, _ = write_run(whole)
    run = read_run(whole)
    held = window_sample_counts(run.stamps, run.labels, run.done_ns)
    assert held == solution.window_samples  # the estimator's own cut, sample for sample
    assert run.incomplete == []
    write_run(lacking, lose=7)
    first = next(label for label in solution.window_samples if label.startswith("object/"))
    used = solution.window_samples[first]
    assert read_run(lacking).incomplete == [
        f"the recorder lost 7 of {WRENCH_TOPIC} before they reached it (metadata.yaml)",
        f"the bag holds {used - 7} of the {used} samples the estimator used in {first}",
    ]
    assert missing_samples({first: used}, {first: used + 1}) == []  # more is not less


def test_trajectories_that_would_move_the_arm_in_a_window_or_jolt_it_are_named():
    """A trajectory controller starts a trajectory on arrival: one recorded while a static
    window is open moves the arm through it, unless its first point holds the arm at rest
    until the window's end; a point without velocities is interpolated linearly."""
    s = 1_000_000_000
    labels = [(1 * s, "tare/home"), (6 * s, MOVING), (8 * s, "motion/tare"), (11 * s, MOVING)]

    def sent(labels_before, stamp=0, first=0, at_rest=True, positions_only=False):
        return SentTrajectory(labels_before, stamp, first, at_rest, positions_only)

    fine = [
        sent(0),  # before any window
        sent(2),  # after the window closed
        sent(1, stamp=5 * s, first=s, at_rest=True),  # holds still until the window's end
        sent(2, stamp=8 * s),  # an excitation sent ahead of its span
    ]
    assert trajectory_problems(fine, labels) == []
    bad = [
        sent(1),  # runs on arrival: to its first point inside the window
        sent(1, stamp=4 * s, first=s),  # its first point due before the window's end
        sent(1, stamp=5 * s, first=s, at_rest=False),
        sent(2, positions_only=True),
    ]
    problems = trajectory_problems(bad, labels)
    assert problems[:3] == [
        f"arm trajectory {k}: arrived while the window tare/home (from t = 1.000 s) was open; "
        "a trajectory controller moves the arm on arrival"
        for k in (1, 2, 3)
    ]
    assert problems[3:] == [
        "arm trajectory 4: a point with positions only (the controller interpolates it "
        "linearly: a velocity step)"
    ]
