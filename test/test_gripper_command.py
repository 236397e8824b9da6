"""The gripper's command without ROS: the sim's judgement of a GripperCommand goal (reached,
stalled), the sequencer's check of a closing on the object, the configuration's
``gripper_action`` and the bag's schema of the commands as sent."""

from __future__ import annotations

from pathlib import Path

import pytest

from com_core.bags.reader import read_raw
from com_core.bags.writer import MESSAGE_DEFINITIONS, CrashSafeBagWriter
from com_core.contract import GRIPPER_SENT_TOPIC, TOPIC_TYPES
from com_core.planning.decisions import closing_problem
from com_core.robot.config import (
    DEFAULT_GRIPPER_ACTION,
    ROBOTS,
    RobotConfig,
    read_robot_config,
)
from wrench_sim.gripper import GOAL_TOLERANCE, STALL_TIME, GripperGoal

STROKE = 0.04  # m: the Panda's fingers, open to closed


def test_a_goal_within_its_tolerance_is_reached():
    goal = GripperGoal(0.0, -STROKE, start=1.0)
    assert not goal.update(1.01, 0.02, -0.1, 0.0)  # moving
    assert goal.update(1.2, 0.5 * GOAL_TOLERANCE * STROKE, 0.0, 0.0)
    assert goal.outcome.reached_goal and not goal.outcome.stalled


def test_fingers_still_short_of_the_goal_stall_after_the_stall_time():
    goal = GripperGoal(0.0, -STROKE, start=1.0)
    assert not goal.update(1.2, 0.025, -0.1, 0.0)  # the last move
    assert not goal.update(1.2 + 0.5 * STALL_TIME, 0.025, 0.0, 5.0)  # still, not long
    assert goal.update(1.2 + STALL_TIME, 0.025, 0.0, 5.0)
    outcome = goal.outcome
    assert outcome.stalled and not outcome.reached_goal
    assert (outcome.position, outcome.effort) == (0.025, 5.0)


def test_a_closing_grasps_only_when_the_fingers_stopped_on_something():
    action = "the gripper action /g"
    assert closing_problem(True, False, 0.4, action) == ""
    assert "closed on nothing" in closing_problem(False, True, 1.0, action)
    assert "neither stalled" in closing_problem(False, False, 0.4, action)
    assert "finger joint states" in closing_problem(None, None, 0.99, "the gripper")
    assert closing_problem(None, None, 0.4, "the gripper") == ""  # a topic: no result
    assert "finger joint states" in closing_problem(True, False, 1.0, action)


@pytest.mark.parametrize("robot", ROBOTS)
def test_each_shipped_robot_names_its_gripper_action(robot: str):
    assert read_robot_config(robot).gripper_action.startswith("/")


def test_a_configuration_without_gripper_action_takes_the_default():
    values = read_robot_config("panda").parameters()
    del values["gripper_action"]
    assert RobotConfig.from_parameters(values).gripper_action == DEFAULT_GRIPPER_ACTION


def test_the_bag_keeps_gripper_commands_as_sent(tmp_path: Path):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    msgtype = TOPIC_TYPES[GRIPPER_SENT_TOPIC]
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(MESSAGE_DEFINITIONS[msgtype], msgtype))
    command = store.types[msgtype](position=0.04, max_effort=20.0)
    raw = bytes(store.serialize_cdr(command, msgtype))
    with CrashSafeBagWriter(tmp_path / "run") as bag:
        bag.write(GRIPPER_SENT_TOPIC, msgtype, 1_000, raw)
    [(topic, read_type, stamp, data)] = list(read_raw(tmp_path / "run", [GRIPPER_SENT_TOPIC]))
    assert (topic, read_type, stamp) == (GRIPPER_SENT_TOPIC, msgtype, 1_000)
    back = store.deserialize_cdr(data, msgtype)
    assert (back.position, back.max_effort) == (0.04, 20.0)
