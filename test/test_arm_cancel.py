"""The arm's action port without ROS (``exploration_sequencer.ros_arm.ActionArm``): a goal
whose answer a run's cancel stopped waiting for is cancelled once the controller accepts
it, and its end awaited, before the way back is planned from where the arm is."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from fake_action import Client, Future

from com_core.sequencing.errors import CancelledRunError, TimeoutRunError
from exploration_sequencer.ros_arm import ActionArm


class Handle:
    """An accepted goal: its end comes when it is cancelled."""

    accepted = True

    def __init__(self) -> None:
        self.ended, self.cancelled = Future(), False

    def get_result_async(self) -> Future:
        return self.ended

    def cancel_goal_async(self) -> Future:
        self.cancelled = True
        self.ended.set("canceled")
        return Future(done=True)


class Clock:
    """Cancels the run's first wait for an answer; a later wait sees the controller
    answer (``on_wait``) and times out if what it waits for never comes."""

    def __init__(self, on_wait: Callable[[], None]) -> None:
        self.cancelled, self.on_wait, self.waits = False, on_wait, []

    def wait(self, done: Callable[[], object], what: str, wall_timeout: float | None) -> None:
        self.waits.append(what)
        if "waiting for the answer" in what and not self.cancelled:
            self.cancelled = True
            raise CancelledRunError(f"cancelled while {what}")
        self.on_wait()
        if not done():
            raise TimeoutRunError(f"no {what}")


def arm(answer: Future, clock: Clock) -> ActionArm:
    port = ActionArm.__new__(ActionArm)  # no node: its client and publisher are fakes
    port._clock, port._client, port._running, port._unanswered = clock, Client(answer), None, None
    port._config = type("Config", (), {"arm_action": "/arm_controller/follow_joint_trajectory",
                                       "goal_tolerance": 0.01,
                                       "stopped_velocity_tolerance": 0.01})()  # fmt: skip
    port._sent = type("Publisher", (), {"publish": lambda self, msg: None})()
    return port


def path():
    from com_core.sequencing.ports import JointPath

    return JointPath(("j1",), ((0.0, [0.0], [0.0], [0.0]), (1.0, [0.1], [0.0], [0.0])))


@pytest.mark.parametrize("accepted", [True, False])
def test_a_goal_sent_as_the_run_was_cancelled_is_cancelled_once_accepted(accepted):
    handle, answer = Handle(), Future()
    handle.accepted = accepted
    clock = Clock(on_wait=lambda: answer.set(handle))  # the answer comes after the cancel
    port = arm(answer, clock)
    with pytest.raises(CancelledRunError):
        port.send(path(), "moving to tilt_x-")
    assert not handle.cancelled  # not yet answered
    port.forget()
    assert handle.cancelled is accepted  # held where it is, its end awaited
    assert any("ending a cancelled goal" in w for w in clock.waits) is accepted
    port.forget()  # once only
    assert port._unanswered is None


def test_no_answer_to_the_cancelled_goal_leaves_the_way_back_to_go_on():
    clock = Clock(on_wait=lambda: None)  # the controller never answers
    port = arm(Future(), clock)
    with pytest.raises(CancelledRunError):
        port.send(path(), "moving to tilt_x-")
    port.forget()  # no error: the way back starts from where the arm is
    assert port._unanswered is None
