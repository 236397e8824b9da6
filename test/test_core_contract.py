"""com_core.contract: what the input status says, diagnostic levels both ways, and a type
for every topic of a run."""

from __future__ import annotations

from types import SimpleNamespace as Ns

import pytest

from com_core.contract import (
    DIAGNOSTIC_NAME,
    ERROR,
    INPUT_STATUS_NAME,
    OK,
    TOPIC_TYPES,
    WARN,
    heard_stamps,
    level_of,
    status_of,
)


def test_heard_stamps_reads_only_an_ok_input_status():
    def status(name=INPUT_STATUS_NAME, level=b"\x00", **values):
        kvs = [Ns(key=k, value=v) for k, v in values.items()]
        return Ns(name=name, level=level, values=kvs)

    assert heard_stamps(status(latest_stamp_ns="7", latest_label_ns="5")) == (7, 5)
    assert heard_stamps(status(latest_stamp_ns="7")) == (7, None)  # no label heard yet
    assert heard_stamps(status(level=b"\x01", latest_stamp_ns="7")) is None  # no wrenches
    assert heard_stamps(status(name=DIAGNOSTIC_NAME, latest_stamp_ns="7")) is None
    assert heard_stamps(status()) is None


def test_levels_and_statuses_map_both_ways():
    assert [status_of(level_of(s)) for s in (OK, WARN, ERROR)] == [OK, WARN, ERROR]
    # rclpy gives DiagnosticStatus.level as one byte; an int reads the same
    assert [status_of(bytes([level])) for level in (0, 1, 2, 3)] == [OK, WARN, ERROR, "STALE"]
    assert [status_of(level) for level in (0, 1, 2)] == [OK, WARN, ERROR]
    assert status_of(7) == ERROR  # an unknown level is not taken for OK
    with pytest.raises(KeyError):
        level_of("STALE")


def test_every_topic_is_absolute_and_has_a_ros2_message_type():
    for topic, msgtype in TOPIC_TYPES.items():
        assert topic.startswith("/") and not topic.endswith("/"), topic
        package, kind, name = msgtype.split("/")
        assert kind == "msg" and package.endswith("_msgs") and name[0].isupper(), msgtype


def test_no_python_file_outside_the_contract_spells_out_a_name_of_it():
    """Every topic and service name of the contract is used through its constant: no
    string literal in the packages, the bench or the tests equals one (names inside
    messages and docstrings are text, not endpoints)."""
    import io
    import tokenize
    from pathlib import Path

    import com_core.contract as contract

    names = {
        value
        for key, value in vars(contract).items()
        if key.endswith(("_TOPIC", "_SERVICE")) and isinstance(value, str)
    }
    root = Path(__file__).resolve().parents[1]
    files = [
        path
        for folder in (
            "src",
            "com_estimator",
            "exploration_sequencer",
            "wrench_sim",
            "bench",
            "test",
        )
        for path in (root / folder).rglob("*.py")
        if path.name != "contract.py"
    ]
    assert len(files) > 30
    found = []
    for path in files:
        tokens = tokenize.generate_tokens(io.StringIO(path.read_text()).readline)
        for token in tokens:
            if token.type == tokenize.STRING and token.string.strip("'\"") in names:
                found.append(f"{path.relative_to(root)}:{token.start[0]} {token.string}")
    assert not found, found
