"""Every input, tried with its boundary cases and with drawn values (``fuzz_inputs``): each
value is either taken and runs, or refused with a line that names the input, its value
and what it takes; never an internal error or a traceback.

Here without node processes: the rows' checks; a run's plan for every sequencer
parameter and goal option it takes (planned or refused with the planner's advice); the
simulated sensor's parts through its readings; the demo's flags and the replay's options
(the estimator's settings) through their command lines: a refused value ends with exit
code 2 and its name before anything runs, a value taken replays the sample run. The node
processes, at start and at every set, are ``test_fuzz_nodes.py``.
"""

from __future__ import annotations

import contextlib
import io
import math
from dataclasses import fields, replace
from typing import Any

import numpy as np
import pytest
from conftest import PANDA as PANDA_CONFIG
from conftest import WORKSPACE, choreography
from fuzz_inputs import boundary_values, values_of

from com_core.estimation.runs.settings import SETTINGS
from com_core.inputs import Input
from com_core.planning.decisions import (
    PlanInfeasible,
    RunSettings,
    plan_within_reach,
    planning_noise,
    predicted_run,
)
from com_core.planning.run_time import static_run_phases, time_left
from com_core.sensing.sensor_profiles import PROFILES

rclpy = pytest.importorskip("rclpy")  # the nodes' tables import their messages

from com_estimator import replay  # noqa: E402
from com_estimator.estimator_node import PARAMETERS as ESTIMATOR  # noqa: E402
from com_interfaces.action import Explore  # noqa: E402
from exploration_sequencer import demo  # noqa: E402
from exploration_sequencer.explore_action import goal_options  # noqa: E402
from exploration_sequencer.parameters import PARAMETERS as SEQUENCER  # noqa: E402
from wrench_sim.parameters import PARAMETERS as SIM  # noqa: E402
from wrench_sim.parameters import PROFILE_PARAMETERS, check_parameter, sensor_profile  # noqa: E402

TABLES = {"sim_node": SIM, "estimator_node": ESTIMATOR, "sequencer_node": SEQUENCER}
RUN_FIELDS = [f.name for f in fields(RunSettings)]
DEFAULT_RUN = RunSettings.from_parameters(lambda name: SEQUENCER[name].default)
PANDA = choreography("panda")
SAMPLE = WORKSPACE / "bags" / "sample"


def refused_by_name(line: str, name: str, value: Any) -> bool:
    return line.startswith(f"{name}={value!r} refused: ")


@pytest.mark.parametrize("node", TABLES)
def test_every_value_of_every_parameter_is_taken_or_refused_by_name(node):
    for name, row in TABLES[node].items():
        for value in values_of(row):
            line = row.problem(value)
            assert line == "" or refused_by_name(line, name, value), (node, name, value, line)


def test_the_boundary_cases_of_a_range_are_refused():
    """The generator reaches past every bound: a row with a range refuses something."""
    for table in TABLES.values():
        for name, row in table.items():
            if row.kind in ("float", "int", "floats"):
                assert any(row.problem(v) for v in boundary_values(row)), name


def plan_or_refusal(settings: RunSettings) -> str:
    """The run's plan for ``settings`` as the sequencer makes it (for the estimator's
    defaults), its time checked; '' when planned, else the planner's refusal."""
    noise, _ = planning_noise(None, settings)
    try:
        planned = plan_within_reach(settings, PANDA, noise)
        planned, prediction = predicted_run(planned, settings, PANDA, "ml", "kinematics+mount")
    except PlanInfeasible as refusal:
        return str(refusal)
    assert np.all(np.isfinite(prediction.sigma_com)) and prediction.sigma_mass > 0
    plan, config = planned.plan, PANDA_CONFIG
    phases = static_run_phases(
        plan, PANDA.pose_joints(plan.tare_plan()), planned.poses, motion=PANDA,
        speed=settings.speed, home=config.home_joints, pick=config.pick_joints,
        verify=PANDA.verify_joints()[0], tare_check=False, bias_dwell=settings.bias_dwell,
        grasp_check_dwell=0.2, verify_dwell=2.0, bracket=True, release=True,
    )  # fmt: skip
    total = time_left(phases, -1, 0.0, 1.0)
    assert math.isfinite(total) and total > 0
    return ""


@pytest.mark.parametrize("name", RUN_FIELDS)
def test_every_run_setting_it_takes_is_planned_or_refused_with_advice(name):
    row = SEQUENCER[name]
    for value in values_of(row, seed=1):
        if row.problem(value):
            continue
        value = tuple(value) if isinstance(value, list) else value
        settings = replace(DEFAULT_RUN, **{name: value})
        if name == "target_com_sigma":  # the planner's searches, within its limits
            settings = replace(settings, max_object_time=5.0)
        refusal = plan_or_refusal(settings)
        assert refusal == "" or "cannot be met" in refusal or "refused" in refusal, refusal


GOAL_VALUES = {
    "target_com_sigma": [math.nan, -1e-3, math.inf, 1e9, 5e-3],
    "tilt": [math.nan, -0.5, 3.0, math.inf, 1e-9, 0.3],
    "max_tilt": [math.nan, -0.5, 3.0, 1.2],
    "dwell": [math.nan, -1.0, 1e9, math.inf, 0.5],
    "raise_tilt": [-128, -2, 2, 127, 0, 1],
    "fewer_poses": [-128, -2, 2, 127, 0, 1],
    "information": ["", " ", "guess", "x" * 300, "wrenches", "kinematics"],
    "excitation": ["", " ", "dynamic", "x" * 300, "static", "motion"],
    "reference_mass": [math.nan, -1.0, math.inf, 1e9, 1.0],
    "motion_period": [math.nan, -1.0, math.inf, 0.5, 2.0],
    "motion_cycles": [-(2**31), -1, 21, 2**31 - 1, 3],
    "motion_acceleration": [math.nan, -8.0, math.inf, 1e9, 0.5, 20.0],
    "target_inertia": [math.nan, -0.1, math.inf, 1e9, 0.2],
}


def test_the_fuzz_covers_every_goal_field():
    assert set(GOAL_VALUES) == set(Explore.Goal.get_fields_and_field_types())


@pytest.mark.parametrize(("field", "values"), GOAL_VALUES.items())
def test_every_goal_field_is_taken_or_refused_by_name(field, values):
    for value in values:
        options, refusals = goal_options(Explore.Goal(**{field: value}))
        assert all(line.startswith(f"{field}={value!r} refused: ") for line in refusals), refusals
        if refusals or field in ("information", "excitation", "reference_mass"):
            continue
        changes = {k: v for k, v in options.items() if k in RUN_FIELDS}
        if changes.get("target_com_sigma"):
            changes["max_object_time"] = 5.0
        refusal = plan_or_refusal(replace(DEFAULT_RUN, **changes))
        assert refusal == "" or "cannot be met" in refusal or "refused" in refusal, refusal


@pytest.mark.parametrize("name", PROFILE_PARAMETERS)
def test_every_sensor_part_it_takes_gives_readings_or_is_refused_by_name(name):
    """Each part the sim takes, over each profile: the profile's parts together are a
    sensor (or refused naming a part and the fix), and that sensor reads finite wrenches."""
    from com_core.inputs import InputError
    from com_core.sensing.wrench_model import SensorModel
    from wrench_sim.sensor import BiasDrift, WrenchSensor

    row = SIM[name]
    for value in values_of(row, seed=3):
        if check_parameter(name, value):
            continue
        for profile in PROFILES:
            try:
                p = sensor_profile({"sensor_profile": profile, name: value})
            except InputError as refusal:
                assert " refused: " in str(refusal)
                continue
            rng = np.random.default_rng(0)
            model = SensorModel.from_scalars(
                p.sigma_f, p.sigma_tau, resolution_f=p.resolution_f,
                resolution_tau=p.resolution_tau, limit_f=p.limit_f, limit_tau=p.limit_tau,
                rate_hz=1000.0, correlation_time=p.correlation_time,
            )  # fmt: skip
            drift = BiasDrift([p.warmup_f] * 3 + [p.warmup_tau] * 3, p.warmup_time,
                              [p.random_walk_f] * 3 + [p.random_walk_tau] * 3, rng)  # fmt: skip
            sensor = WrenchSensor(model, rng, drift)
            readings = [sensor.read([0.0, 0.0, -9.8, 0.01, 0.0, 0.0], 1e-3 * k) for k in range(5)]
            assert np.all(np.isfinite(readings)) and len(p.modes) == len(p.vibration_hz)


DEMO_FLAGS = {
    "--mass": SIM["object_mass"],
    "--seed": SIM["seed"],
    "--sensor-serial": SIM["sensor_serial"],
    "--slip-sigma": SIM["slip_sigma"],
    "--sigma-f": SIM["sigma_f"],
    "--sigma-tau": SIM["sigma_tau"],
    "--real-time-factor": SIM["real_time_factor"],
    "--tilt": SEQUENCER["tilt"],
    "--max-tilt": SEQUENCER["max_tilt"],
    "--dwell": SEQUENCER["dwell"],
    "--target-sigma": SEQUENCER["target_com_sigma"],
    "--motion-period": SEQUENCER["motion_period"],
    "--motion-cycles": SEQUENCER["motion_cycles"],
    "--hand-motion-cycles": SEQUENCER["hand_motion_cycles"],
    "--motion-acceleration": SEQUENCER["motion_acceleration"],
    "--target-inertia": SEQUENCER["target_inertia"],
    "--timeout": demo.TIMEOUT,
}
TEXT_FLAGS = {
    "--axes": ["", ",", "z", "x,x", "y,x,y", "x"],
    "--object": ["", "sphere", "mug"],
    "--grasp-mode": ["", "glue", "friction"],
    "--sensor-profile": ["", "noisy", "white"],
    "--method": ["", "ls", "two_pose"],
    "--information": ["", "all", "wrenches"],
    "--robot": ["", "ur5", "/no/such/robot.yaml", "xarm6"],
    "--bag-dir": ["/proc/no/such/dir"],
}


def demo_answer(argv: list[str]) -> tuple[int | None, str]:
    """(exit code, or None when the flags are taken; what it said) of the demo's checks
    of ``argv``: argparse's and ``flag_refusals``; nothing starts."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            args = demo.build_parser().parse_args(argv)
        except SystemExit as stop:
            return int(stop.code or 0), err.getvalue()
    try:
        demo.read_robot_config(args.robot)
    except demo.RobotConfigError as error:
        return 2, str(error)
    sim, estimator, sequencer = demo.node_parameters(args)
    refused = demo.flag_refusals(args, sim, estimator, sequencer)
    if not refused and args.bag_dir.is_absolute() and not args.bag_dir.parent.exists():
        refused = [f"--bag-dir={str(args.bag_dir)!r} refused"]
    return (2 if refused else None), "\n".join(refused)


def flag_texts(row: Input) -> list[str]:
    """A number flag's values as a user types them."""
    texts = ["", "x", "nan", "inf", "-inf", "1e999", "0", "-1", "1e9", "0x10"]
    return texts + [repr(v) for v in values_of(row, seed=4) if isinstance(v, (int, float))]


@pytest.mark.parametrize("flag", [*DEMO_FLAGS, *TEXT_FLAGS])
def test_every_demo_flag_is_taken_or_refused_by_name_before_anything_starts(flag, tmp_path):
    texts = TEXT_FLAGS.get(flag) or flag_texts(DEMO_FLAGS[flag])
    for text in texts:
        code, said = demo_answer([f"{flag}={text}", "--bag-dir", str(tmp_path / "bags")])
        if flag == "--bag-dir":
            code, said = demo_answer([f"{flag}={text}"])
        assert code in (None, 2), (flag, text, said)
        if code == 2:
            assert flag in said or "robot" in said, (flag, text, said)


def replay_answer(argv: list[str]) -> tuple[int, str]:
    """(exit code, stderr) of the replay's command line ``argv``."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = replay.main(argv)
        except SystemExit as stop:
            code = int(stop.code or 0)
    return code, err.getvalue()


def replay_values(row: Input) -> list[list[str]]:
    """A replay option's values as a command line gives them (a list option: n values)."""
    n = len(row.default) if isinstance(row.default, list) else 1
    texts = ["", "x", "nan", "inf", "-1", "0", "1e9"]
    if row.kind in ("float", "floats"):
        drawn = [v for v in values_of(row, seed=5) if isinstance(v, (int, float, list))]
        texts += [repr(v[0] if isinstance(v, list) else v) for v in drawn if v]
    elif row.choices:
        texts += list(row.choices)
    return [[t] * n for t in dict.fromkeys(texts)] + ([["1"] * (n + 1)] if n > 1 else [])


REPLAY_OPTIONS = [name for name in SETTINGS if name != "tare_cache"]


@pytest.mark.parametrize("name", REPLAY_OPTIONS)
def test_every_replay_option_refused_is_named_before_any_run_is_read(name, tmp_path):
    """A refused value: exit code 2 naming the option, before any bag is read (the bag
    here does not exist, so a value taken answers 2 for the bag instead)."""
    option = "--" + name.replace("_", "-")
    missing = str(tmp_path / "no-bag")
    for values in replay_values(SETTINGS[name]):
        code, said = replay_answer([missing, option, *values])
        assert code == 2, (option, values, said)
        assert option in said or name in said or "is not a rosbag2 directory" in said, said


def test_the_replays_files_are_refused_by_name_before_any_run_is_read(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for argv, named in (
        (["--csv", str(blocker / "r.csv")], "--csv="),
        (["--tare", str(tmp_path / "none.json")], "--tare="),
        (["--robot-description", str(tmp_path / "none.urdf")], "--robot-description="),
    ):
        code, said = replay_answer([str(SAMPLE), *argv])
        assert code == 2 and named in said and " refused: " in said, said


@pytest.mark.slow
@pytest.mark.parametrize("name", REPLAY_OPTIONS)
def test_every_replay_option_it_takes_replays_the_sample_run(name):
    """A value taken reads the sample run to a solution: exit code 0 or 1, never 3."""
    option = "--" + name.replace("_", "-")
    for values in replay_values(SETTINGS[name]):
        code, said = replay_answer([str(SAMPLE), option, *values, "--json"])
        assert code in (0, 1, 2), (option, values, said)
        assert "internal error" not in said and "Traceback" not in said, said


def test_the_demo_names_the_simulated_sensor_by_its_profile_serial_and_set_parts(tmp_path):
    """Both nodes that cache take the sim sensor's ``sensor_id``; another profile, or the
    same one with other noise, is another sensor (a cached tare never crosses)."""

    def sensor_ids(*flags: str) -> set[str]:
        args = demo.build_parser().parse_args([*flags, "--bag-dir", str(tmp_path)])
        _, estimator, sequencer = demo.node_parameters(args)
        return {estimator["sensor_id"], sequencer["sensor_id"]}

    assert sensor_ids() == {"sim-realistic-0"}  # the robot file's
    ideal = sensor_ids("--sensor-profile", "ideal", "--sigma-f", "1e-6", "--sigma-tau", "1e-7")
    assert ideal == {"sim-ideal-0-sigma_f=1e-06-sigma_tau=1e-07"}
    assert sensor_ids("--sigma-f", "0.2") == {"sim-realistic-0-sigma_f=0.2"}
    assert sensor_ids("--sensor-serial", "7") == {"sim-realistic-7"}


def test_the_demos_reference_com_is_the_estimators_on_a_fixture_and_checked_as_it(tmp_path):
    flags = ["--calibrate", "--mass", "1.0", "--bag-dir", str(tmp_path)]
    args = demo.build_parser().parse_args([*flags, "--reference-com", "0.011", "-0.0045", "0.106"])
    sim, estimator, sequencer = demo.node_parameters(args)
    np.testing.assert_allclose(estimator["reference_com"], [0.011, -0.0045, 0.106])
    assert estimator["reference_com_sigma"] == 5e-5
    assert demo.flag_refusals(args, sim, estimator, sequencer) == []
    assert "reference_com" not in demo.node_parameters(demo.build_parser().parse_args(flags))[1]
    for bad in (["0", "0", "nan"], ["0", "20", "0.1"]):
        args = demo.build_parser().parse_args([*flags, "--reference-com", *bad])
        refused = demo.flag_refusals(args, *demo.node_parameters(args))
        assert len(refused) == 1 and refused[0].startswith("--reference-com="), refused
    with pytest.raises(SystemExit):  # three numbers
        demo.build_parser().parse_args([*flags, "--reference-com", "0.01", "0.02"])
    with pytest.raises(SystemExit):  # a reference's, not an object's
        demo.main(["--reference-com", "0", "0", "0.1", "--bag-dir", str(tmp_path)])
