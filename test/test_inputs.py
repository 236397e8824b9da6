"""com_core.inputs: every input's check, and the tables of the sequencer's parameters and
the estimator's settings built from it (no ROS)."""

from __future__ import annotations

import math

import pytest

from com_core.estimation.runs.settings import SETTINGS
from com_core.inputs import Input, problems, refusal, table_of
from exploration_sequencer.parameters import PARAMETERS as SEQUENCER

TILT = Input("tilt", 0.5, "wrist tilt", unit="rad", low=0.0, high=math.pi / 2, low_open=True,
             high_open=True, fix="a tilt the wrist makes")  # fmt: skip
GUESS = Input("com_guess", [0.0], "a guess", kind="floats", unit="m", low=-1.0, high=1.0,
              lengths=(3,), keep=([0.0],))  # fmt: skip


@pytest.mark.parametrize(
    ("value", "why"),
    [
        (3.0, "must be in (0, pi/2) rad"),
        (0.0, "must be in (0, pi/2) rad"),
        (math.pi / 2, "must be in (0, pi/2) rad"),
        (math.nan, "must be a finite number (0, pi/2) rad"),
        (-math.inf, "must be a finite number (0, pi/2) rad"),
        ("0.5", "must be a number"),
        (True, "must be a number"),
        ([0.5], "must be a number"),
    ],
)
def test_a_number_out_of_its_range_is_refused_by_name_value_range_and_fix(value, why):
    assert TILT.problem(value) == f"tilt={value!r} refused: {why}; a tilt the wrist makes"


@pytest.mark.parametrize("value", [0.5, 1, 1e-9, math.pi / 2 - 1e-9])
def test_a_number_in_its_range_is_taken(value):
    assert TILT.problem(value) == ""


@pytest.mark.parametrize(
    ("value", "why"),
    [
        ([0.01, 0.0], "must be 3 values, each [-1, 1] m; or [0.0]; got 2 values"),
        ([], "must be 3 values, each [-1, 1] m; or [0.0]; got 0 values"),
        ([0.0, 0.0, 2.0], "must be in [-1, 1] m (each of the list)"),
        ([0.0, math.nan, 0.0], "must be a finite number [-1, 1] m (each of the list)"),
        ("abc", "must be a list (3 values, each [-1, 1] m; or [0.0])"),
        (0.1, "must be a list (3 values, each [-1, 1] m; or [0.0])"),
    ],
)
def test_a_list_is_checked_for_length_and_each_value(value, why):
    assert GUESS.problem(value) == f"com_guess={value!r} refused: {why}"


def test_a_value_that_means_not_set_here_is_taken_as_it_is():
    assert GUESS.problem([0.0]) == GUESS.problem((0.0,)) == ""
    assert GUESS.problem([0.01, 0.0, 0.05]) == ""
    profile = Input("sigma_f", math.nan, "noise", low=0.0, keep=(math.nan,))
    assert profile.problem(math.nan) == "" and "refused" in profile.problem(-1.0)


def test_texts_and_flags():
    method = Input("method", "ml", "the estimator", kind="str", choices=("ml", "two_pose"))
    assert method.problem("two_pose") == ""
    assert method.problem("ls") == "method='ls' refused: must be one of ['ml', 'two_pose']"
    assert method.problem(1.0) == "method=1.0 refused: must be a text"
    flag = Input("release", True, "put back", kind="bool")
    assert flag.problem(False) == "" and "true or false" in flag.problem(1)
    assert flag.allowed() == "true | false"


def test_what_a_table_says_each_input_takes():
    assert TILT.allowed() == "(0, pi/2) rad"
    assert GUESS.allowed() == "3 values, each [-1, 1] m; or [0.0]"
    assert SEQUENCER["tilt_axes"].allowed() == "1 or 2 values, each y | x"
    assert SEQUENCER["sim_timeout"].allowed() == "[0.5, 600] s"
    assert SETTINGS["alpha"].allowed() == "(0, 0.5)"


def test_problems_names_each_refused_value_and_each_unknown_name():
    refused = problems(SEQUENCER, {"tilt": 3.0, "dwell": 1.0, "tilts": 0.5})
    assert refused[0].startswith("tilt=3.0 refused: must be in [0.01, pi/2) rad")
    assert refused[1].startswith("'tilts' is no input here (known: ")
    assert len(refused) == 2


def test_refusal_and_table_of():
    assert refusal("x", 1, "too big", "use 0") == "x=1 refused: too big; use 0"
    with pytest.raises(ValueError, match="twice"):
        table_of([TILT, TILT])
    with pytest.raises(ValueError, match="kind"):
        Input("x", 0, "", kind="number")


@pytest.mark.parametrize("table", [SEQUENCER, SETTINGS], ids=["sequencer", "estimator"])
def test_every_default_is_accepted_by_its_own_row(table):
    for name, row in table.items():
        assert row.problem(row.default) == "", name


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("tilt_axes", ["x", "x"]),
        ("tilt_axes", ["x", "z"]),
        ("tilt_axes", []),
        ("dwell", 0.0),
        ("dwell", 1e9),
        ("grasp_check_dwell", -0.1),
        ("min_load", -1e-3),
        ("correlation_time", -0.001),
        ("max_object_time", -1.0),
        ("sim_timeout", math.nan),
        ("bag_dir", " "),
    ],
)
def test_the_sequencers_parameters_refuse_what_has_no_meaning(name, value):
    assert SEQUENCER[name].problem(value).startswith(f"{name}={value!r} refused: ")


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("method", "least_squares"),
        ("alpha", 0.5),
        ("alpha", 0.0),
        ("sigma_f", -0.1),
        ("max_label_gap", math.inf),
        ("gravity", [0.0, 0.0, 0.0]),
        ("gravity", [0.0, 0.0, -9.8, 0.0]),
        ("full_scale", [0.0, 10.0]),
        ("robot_description", "/no/such/file.urdf"),
        ("sensor_frame", ""),
    ],
)
def test_the_estimators_settings_refuse_what_has_no_meaning(name, value):
    assert SETTINGS[name].problem(value).startswith(f"{name}={value!r} refused: ")


def test_a_path_is_writable_or_refused_by_name_and_left_as_it_was(tmp_path):
    from com_core.inputs import unwritable

    assert unwritable("bag_dir", tmp_path / "a" / "b", directory=True) == ""
    assert (tmp_path / "a" / "b").is_dir() and not any((tmp_path / "a" / "b").iterdir())
    assert unwritable("tare_cache", tmp_path / "c" / "cache.json") == ""
    assert not (tmp_path / "c" / "cache.json").exists()  # no empty file left behind
    blocker = tmp_path / "file"
    blocker.write_text("x")
    why = unwritable("bag_dir", blocker / "bags", directory=True)
    assert why.startswith(f"bag_dir='{blocker / 'bags'}' refused: cannot be written"), why
    assert unwritable("tare_cache", blocker / "cache.json").startswith("tare_cache=")
