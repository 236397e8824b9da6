"""The offline replay (com_estimator.replay) of bags as they reach a user: a copy cut
short, a run that died before ``done``, a recording without pose labels, a damaged chunk,
a directory of runs. All are made from the real run kept in bags/sample."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import WORKSPACE

from com_core.bags.cdr import decode_header
from com_core.bags.reader import read_metadata, read_raw
from com_core.bags.writer import CrashSafeBagWriter
from com_core.contract import (
    DIAGNOSTICS_TOPIC,
    JOINT_STATES_TOPIC,
    POSE_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    WRENCH_TOPIC,
)
from com_estimator import replay

SAMPLE = WORKSPACE / "bags" / "sample"
SAMPLE_WRENCHES = 23825
TARE_FILE = "tare.json"


def run_replay(capsys: pytest.CaptureFixture[str], bag: Path, *args: str) -> dict:
    """The replay's --json object for ``bag``."""
    replay.main([str(bag), "--json", *args])
    return json.loads(capsys.readouterr().out)


def copy_sample(tmp_path: Path, name: str) -> Path:
    """A copy of the sample bag (MCAP file, metadata.yaml, tare.json)."""
    bag = tmp_path / name
    shutil.copytree(SAMPLE, bag, ignore=shutil.ignore_patterns("*.png"))
    return bag


def rewrite(
    bag: Path, topics: tuple[str, ...], stop_log_ns: int | None = None
) -> CrashSafeBagWriter:
    """A bag of the sample's messages of ``topics`` logged before ``stop_log_ns``, with the
    sample's cached tare beside it; its writer is flushed and left open (what a recorder
    that died leaves: metadata.yaml says ``complete: false``)."""
    writer = CrashSafeBagWriter(bag)
    writer.open()
    for topic, msgtype, log_ns, raw in read_raw(SAMPLE, topics):
        if stop_log_ns is not None and log_ns >= stop_log_ns:
            break
        writer.write(topic, msgtype, log_ns, raw)
    writer.flush()
    shutil.copy(SAMPLE / TARE_FILE, bag / TARE_FILE)
    return writer


@pytest.fixture(scope="module")
def full() -> dict:
    """The sample's own replay."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        replay.main([str(SAMPLE), "--json"])
    result = json.loads(out.getvalue())
    assert result["status"] == "OK" and result["messages"] == SAMPLE_WRENCHES
    return result


# --- a copy cut short ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fraction", "read_at_least"),
    [(0.5, 0.45), (0.99, 0.98)],
)
def test_a_copy_cut_short_is_read_up_to_the_cut(tmp_path, capsys, full, fraction, read_at_least):
    """rosbags refuses a file without its Footer; the replay reads the MCAP records up to
    the cut (all but the chunk the cut falls in: 49.8 % of the wrenches at 50 % of the
    bytes, 99.2 % at 99 %) and says so."""
    bag = copy_sample(tmp_path, f"cut{int(fraction * 100)}")
    (mcap,) = bag.glob("*.mcap")
    os.truncate(mcap, int(mcap.stat().st_size * fraction))
    out = run_replay(capsys, bag)
    read = out["bag"]
    assert read["cut_short"] and "EndOfFile" in read["stopped"]
    assert "File end magic is invalid" in read["fallback"]
    assert read["listed"][WRENCH_TOPIC] == SAMPLE_WRENCHES  # from metadata.yaml
    share = read["read"][WRENCH_TOPIC] / SAMPLE_WRENCHES
    assert read_at_least < share < 1.0
    assert out["messages"] == read["read"][WRENCH_TOPIC]
    if fraction == 0.5:
        # the run stops after the fourth object window: no done label, WARN with both
        # reasons, and the estimate of the four poses it has
        assert read["read"][POSE_TOPIC] == 11
        assert out["status"] == "WARN"
        assert "the run has no done label: cut short after object/tilt_x-" in out["reason"]
        assert "the bag's MCAP file is cut short" in out["reason"]
        assert out["poses"] == ["home", "tilt_y+", "tilt_y-", "tilt_x-"]
        assert abs(out["mass"] - full["mass"]) < 4 * out["sigma_mass"]
    else:
        # every label and every sample up to done is before the cut (the end of the
        # recording is lost): the full estimate
        assert read["read"][POSE_TOPIC] == 19
        assert out["status"] == "OK"
        assert out["window_samples"] == full["window_samples"]
        assert (out["mass"], out["com"]) == (full["mass"], full["com"])
    replay.main([str(bag)])
    text = capsys.readouterr().out
    assert "bag: the bag's MCAP file is cut short" in text
    n = read["read"][WRENCH_TOPIC]
    assert f"{WRENCH_TOPIC}: {n} of {SAMPLE_WRENCHES} listed in metadata.yaml" in text
    assert ("every window of the run was read" in text) is (fraction == 0.99)


def test_topics_metadata_yaml_does_not_list_are_read_from_the_mcap_file(tmp_path, capsys, full):
    """rosbags drops the channels metadata.yaml does not list; the MCAP file has them."""
    bag = copy_sample(tmp_path, "unlisted")
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    head, _, tail = text.partition("  topics_with_message_count:\n")
    meta.write_text(head + "  topics_with_message_count: []\n" + tail[tail.index("  version:") :])
    assert read_metadata(bag)[:2] == ({}, True)  # still valid, with no topic list
    out = run_replay(capsys, bag)
    assert "metadata.yaml does not list" in out["bag"]["fallback"]
    assert not out["bag"]["cut_short"]
    assert out["messages"] == SAMPLE_WRENCHES
    assert (out["status"], out["mass"]) == ("OK", full["mass"])


# --- a run that died before done -------------------------------------------------------


def label_log_time(label: str, after: str | None = None) -> int:
    """Log time (ns) of the sample's label ``label`` (the first after label ``after``)."""
    seen = after is None
    for _, _, log_ns, raw in read_raw(SAMPLE, (POSE_TOPIC,)):
        name = decode_header(raw)[1]
        if seen and name == label:
            return log_ns
        seen = seen or name == after
    raise KeyError(label)


@pytest.mark.parametrize("closed", [False, True])
def test_a_run_without_done_is_warned_as_cut_short(tmp_path, capsys, full, closed):
    """The recording stops as object/tilt_x+ arrives: 4 object windows, no done. Its
    estimate is kept, but never as OK; an unclosed recording is named as such."""
    bag = tmp_path / "aborted"
    topics = (WRENCH_TOPIC, POSE_TOPIC, JOINT_STATES_TOPIC, ROBOT_DESCRIPTION_TOPIC)
    writer = rewrite(bag, topics, label_log_time("object/tilt_x+"))
    try:
        if closed:
            writer.close()
        assert read_metadata(bag)[1] is closed  # custom_data.complete
        out = run_replay(capsys, bag)
    finally:
        writer.close()
    assert out["status"] == "WARN"
    assert out["reason"].startswith("the run has no done label: cut short after object/tilt_x-")
    assert out["poses"] == ["home", "tilt_y+", "tilt_y-", "tilt_x-"]
    assert abs(out["mass"] - full["mass"]) < 4 * out["sigma_mass"]
    assert out["bag"]["complete"] is closed
    assert ("custom_data.complete: false" in out["reason"]) is not closed
    replay.main([str(bag)])
    assert "[WARN] ml (kinematics+mount): the run has no done label" in capsys.readouterr().out


# --- a recording without labels ----------------------------------------------------------


def test_an_unlabelled_recording_is_tared_by_load_level(tmp_path, capsys, full):
    """Only the wrenches of the sample up to the end of its object pass: its static
    windows are of the empty hand (9.82 N; the bias window at home) and of the loaded
    hand (10.80 N, the five poses; a 1 % calibration spreads one load's |f| over the
    orientations by ~1 %): the cached tare's level is the empty hand's. The object
    windows are tared with the cached tare's windows of the same gravity direction: the
    estimate is the labelled one's within 4 of its sigmas (they share the tare and most
    samples)."""
    bag = tmp_path / "unlabelled"
    rewrite(bag, (WRENCH_TOPIC,), label_log_time("moving", after="object/tilt_x+")).close()
    out = run_replay(capsys, bag, "--information", "wrenches")
    assert out["windows_from"].startswith(
        "no pose labels in the bag: 0 tare and 5 object windows by load level (9.82, 10.80 N)"
    )
    assert "5 of them with the cached tare" in out["windows_from"]
    assert out["status"] == "OK", out["reason"]
    assert out["poses"] == ["home", "tilt_y+", "tilt_y-", "tilt_x-", "tilt_x+"]
    assert abs(out["mass"] - full["mass"]) < 4 * full["sigma_mass"]
    com_error = np.abs(np.subtract(out["com"], full["com"]))
    assert np.all(com_error < 4 * np.array(full["sigma_com"]))

    # without the cached tare the lightest level stands for the empty hand: its window at
    # home tares the object's at home only; the other four are left out, not fitted
    # against a tare of another orientation, and one pose is no estimate
    (bag / TARE_FILE).unlink()
    out = run_replay(capsys, bag, "--information", "wrenches")
    assert "4 object windows left out: no tare window within 2 deg" in out["windows_from"]
    assert out["status"] == "ERROR"


# --- a damaged chunk; many runs at once --------------------------------------------------


def damage(bag: Path, at: float = 0.5, size: int = 4096) -> None:
    """Zero ``size`` bytes at fraction ``at`` of the bag's MCAP file (a bad sector)."""
    path = next(bag.glob("*.mcap"))
    with path.open("r+b") as stream:
        stream.seek(int(path.stat().st_size * at))
        stream.write(bytes(size))


def test_a_damaged_chunk_is_skipped_and_the_rest_read(tmp_path, capsys, full):
    bag = copy_sample(tmp_path, "damaged")
    damage(bag)
    result = run_replay(capsys, bag)
    reading = result["bag"]
    assert len(reading["damaged"]) == 1 and "CRCValidationError" in reading["damaged"][0]
    lost = SAMPLE_WRENCHES - result["messages"]
    assert 0 < lost < 0.05 * SAMPLE_WRENCHES  # one chunk of the 79: 0.1 s of the run
    assert result["status"] == "WARN" and "damaged chunk" in result["reason"], result["reason"]
    # the chunk fell in a move: the windows, and so the estimate, are the sample's
    assert result["window_samples"] == full["window_samples"]
    assert result["mass"] == pytest.approx(full["mass"], abs=1e-12)


def test_many_runs_are_replayed_each_and_tabulated(tmp_path, capsys, full):
    runs = tmp_path / "bags"
    runs.mkdir()
    copy_sample(runs, "a")
    damage(copy_sample(runs, "b"))
    cut = copy_sample(runs, "c")
    mcap = next(cut.glob("*.mcap"))
    os.truncate(mcap, mcap.stat().st_size // 2)
    (runs / "logs").mkdir()  # no bag: skipped in a directory of runs
    code = replay.main([str(runs), str(tmp_path / "missing"), "--csv", str(tmp_path / "r.csv")])
    out, err = capsys.readouterr()
    assert code == 2  # the worst: a path that is no bag
    assert "missing is not a rosbag2 directory" in err and "[4/4]" in err
    table = out[out.index("status") :].splitlines()
    assert [line.split()[0] for line in table[1:5]] == ["OK", "WARN", "WARN", "NO"]
    assert table[-1] == "1 OK, 2 WARN, 1 NO BAG of 4"
    rows = list(csv.DictReader((tmp_path / "r.csv").open()))
    assert [r["status"] for r in rows] == ["OK", "WARN", "WARN", "NO BAG"]
    assert float(rows[0]["mass"]) == full["mass"]

    assert replay.main([str(runs), "--json", "-j", "2"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["path"] for r in lines] == [str(runs / name) for name in "abc"]
    assert "damaged chunk" in lines[1]["reason"] and "cut short" in lines[2]["reason"]
    assert lines[0]["mass"] == full["mass"]  # the same numbers from another process


def test_every_option_has_its_help():
    with pytest.raises(SystemExit) as done, contextlib.redirect_stdout(io.StringIO()) as out:
        replay.main(["--help"])
    assert done.value.code == 0 and "--accuracy" in out.getvalue()


def test_a_defect_in_one_run_is_its_error_and_the_others_go_on(tmp_path, capsys, monkeypatch):
    """An exception that reaches a run's top level is a defect: said with its traceback
    as an internal error, that run's ERROR in the table, exit code 3; the other runs go
    on (here a missing path, refused as such)."""

    original = replay.replay

    def defect(bag, args):
        if bag == SAMPLE:
            raise ZeroDivisionError("a defect")
        return original(bag, args)

    monkeypatch.setattr(replay, "replay", defect)
    code = replay.main([str(SAMPLE), str(tmp_path / "missing"), "--csv", str(tmp_path / "r.csv")])
    out, err = capsys.readouterr()
    assert code == replay.INTERNAL_ERROR_CODE == 3
    assert f"{SAMPLE}: internal error\nTraceback" in err and "ZeroDivisionError" in err
    rows = list(csv.DictReader((tmp_path / "r.csv").open()))
    assert rows[0]["status"] == "ERROR" and rows[0]["reason"].startswith("internal error: ")
    assert rows[1]["status"] == "NO BAG" and out.splitlines()[-1] == "1 ERROR, 1 NO BAG of 2"


def test_a_bag_that_lacks_samples_the_node_used_is_warned_by_window(tmp_path, capsys, full):
    """The node's window counts come with the bag (its status on /diagnostics): a copy
    without 5 wrenches of the first object window replays WARN, naming that window."""
    labels = [decode_header(raw) for *_, raw in read_raw(SAMPLE, [POSE_TOPIC])]
    start, window = next((s, lbl) for s, lbl in labels if lbl.startswith("object/"))
    bag = tmp_path / "lacking"
    topics = (WRENCH_TOPIC, POSE_TOPIC, JOINT_STATES_TOPIC, ROBOT_DESCRIPTION_TOPIC,
              DIAGNOSTICS_TOPIC)  # fmt: skip
    dropped = 0
    with CrashSafeBagWriter(bag) as writer:
        for topic, msgtype, log_ns, raw in read_raw(SAMPLE, topics):
            if topic == WRENCH_TOPIC and dropped < 5 and decode_header(raw)[0] >= start:
                dropped += 1
                continue
            writer.write(topic, msgtype, log_ns, raw)
    shutil.copy(SAMPLE / TARE_FILE, bag / TARE_FILE)
    out = run_replay(capsys, bag)
    used = full["window_samples"][window]
    assert out["status"] == "WARN"
    assert (
        f"the bag holds {used - 5} of the {used} samples the estimator used in {window}"
        in (out["reason"])
    )


# --- a recording this project did not make -----------------------------------------------


def test_a_csv_log_of_orientations_and_wrenches_is_replayed(tmp_path, capsys):
    """``replay LOG.csv``: the recording's fit, printed as JSON with the self-check; a log
    without orientations is refused with exit code 2, by name."""
    from test_core_recording import LOAD, recorded, write_csv

    rec, _ = recorded(9)
    log = tmp_path / "log.csv"
    write_csv(log, rec, quaternions=True)
    out = run_replay(capsys, log)
    assert out["status"] == "OK", out["reason"]
    assert out["windows_from"] == "recording" and out["whole_load"]
    assert abs(out["mass"] - LOAD.mass) < 3 * out["sigma_mass"]
    assert len(out["check_sigmas"]) == 6
    bad = tmp_path / "bad.csv"
    bad.write_text("time,fx,fy,fz,tx,ty,tz\n0,1,2,3,4,5,6\n")
    assert replay.main([str(bad)]) == 2
    assert "qx, qy, qz, qw" in capsys.readouterr().err


@pytest.mark.slow
def test_an_unlabelled_bag_of_another_recorder_gives_the_load_and_the_bias(tmp_path, capsys):
    """A bag rosbags wrote (250 Hz wrenches, 100 Hz joint states, the URDF on
    /robot_description; no labels, no robot configuration) of the Panda holding a 0.4 kg
    box and wandering slowly with rests, through the realistic sensor with a 7 N bias:
    OK, the whole load and the bias within 3 sigma of the truth."""
    from dataclasses import replace as replaced

    from com_core.sensing.sensor_profiles import PROFILES
    from wrench_sim.config import SimConfig
    from wrench_sim.physics import ArmWorld
    from wrench_sim.sensor import profile_sensor
    from wrench_sim.studies import grasp, record_wandering, write_recording_bag

    world = ArmWorld(SimConfig(object_mass=0.4, seed=11))
    try:
        sensor = profile_sensor(PROFILES["realistic"], seed=11, serial=11)
        bias = np.array([4.0, -5.0, 3.0, 0.2, -0.1, 0.15])
        sensor.model = replaced(sensor.model, bias=bias)
        grasp(world)
        start = world.time
        recorded = record_wandering(world, sensor, np.random.default_rng(11), duration=25.0)
        middle = (start + world.time) / 2  # the fit's bias is at the middle: the drift then
        assert sensor.drift is not None
        bias = bias + sensor.drift.at(world.time) * middle / world.time
        mh, ch = world.hand_ground_truth()
        mo, co = world.object_ground_truth()
        bag = tmp_path / "wandering"
        robot = world.config.robot
        write_recording_bag(str(bag), recorded, robot.arm_joints, world.urdf_text)
    finally:
        world.close()
    out = run_replay(capsys, bag, "--sensor-frame", robot.sensor_frame)
    assert out["status"] == "OK", out["reason"]
    mass, com = mh + mo, (mh * ch + mo * co) / (mh + mo)
    assert abs(out["mass"] - mass) < 3 * out["sigma_mass"]
    assert np.all(np.abs(np.subtract(out["com"], com)) < 3 * np.array(out["sigma_com"]))
    assert np.all(np.abs(np.subtract(out["bias"], bias)) < 3 * np.array(out["bias_sigma"]))
    assert out["rests"] >= 2 and out["left_out"] == 0
    # the core's reader of a bag gives the replay's recording: the same fit, to the bit
    from com_core.estimation.recordings import fit_recording, recording_from_bag
    from com_core.estimation.runs.settings import exploration_from

    settings = {"sensor_frame": robot.sensor_frame}
    again = fit_recording(
        recording_from_bag(bag, settings), calibration=exploration_from(settings).calibration
    )
    assert again.estimate is not None and again.estimate.mass == out["mass"]


def test_a_tare_recording_gives_the_object_alone_through_the_replay(tmp_path, capsys):
    """``--tare-recording`` (a log of the empty tool): the object alone, said so."""
    from test_core_recording import LOAD, sensor, write_csv

    from com_core.paper.synthetic import Load, wandering_recording

    rng = np.random.default_rng(13)
    tool = Load(0.15, (0.0, 0.005, 0.03))
    both = tool.mass + LOAD.mass
    com = (tool.mass * np.array(tool.com) + LOAD.mass * np.array(LOAD.com)) / both
    empty = wandering_recording(sensor(), tool, rng, duration=30.0)
    write_csv(tmp_path / "empty.csv", empty, True)
    held = wandering_recording(sensor(), Load(both, tuple(com)), rng, duration=30.0)
    write_csv(tmp_path / "held.csv", held, True)
    out = run_replay(
        capsys, tmp_path / "held.csv", "--tare-recording", str(tmp_path / "empty.csv")
    )
    assert out["status"] == "OK", out["reason"]
    assert not out["whole_load"]
    assert abs(out["mass"] - LOAD.mass) < 3 * out["sigma_mass"]
    with pytest.raises(SystemExit) as refused:  # refused by name before any run
        replay.main([str(tmp_path / "held.csv"), "--tare-recording", "nowhere.csv"])
    assert refused.value.code == 2
    assert "--tare-recording" in capsys.readouterr().err


def test_a_log_of_a_sensor_with_hysteresis_is_read_through_its_gain(capsys, tmp_path):
    """A log of wrenches and orientations (``LOG.npz``, no ROS) read by a sensor whose
    hysteresis reads every change of load with the gain 1 - d: told the band
    (``--hysteresis``), the replay takes the gain off its readings as it does a bag's, and
    the mass of a noiseless log is exact; untold, it reads light, by between the force
    axes' d."""
    from test_core_recording import LOAD, recorded

    from com_core.sensing.hysteresis import Hysteresis

    band, full_scale = (3.75, 3.75, 2.0, 0.04, 0.04, 0.04), (150.0, 4.0)
    gain = Hysteresis(band, (full_scale[0],) * 3 + (full_scale[1],) * 3).gain()
    rec, _ = recorded(5, noise=False)
    log = tmp_path / "log.npz"
    np.savez(log, time=rec.times, wrench=rec.wrenches * gain, rotation=rec.rotations)
    scale = ["--full-scale", *map(str, full_scale), "--accuracy", "0"]
    told = run_replay(capsys, log, *scale, "--hysteresis", *map(str, band))
    untold = run_replay(capsys, log, *scale)
    assert told["status"] == "OK", told["reason"]
    assert told["mass"] == pytest.approx(LOAD.mass, rel=1e-6)
    light = 1 - untold["mass"] / LOAD.mass  # ~3.2 %: the tilts load fx and fy too
    assert 1 - gain[2] < light < 1 - gain[0], (light, 1 - gain)
