"""The gripper's action port without ROS (``exploration_sequencer.ros_gripper.ActionGripper``):
a goal the run stops waiting for, its result late or the run cancelled, is cancelled (once
the driver accepts it, if it had not yet); a goal that ended, well or not, is left as it
ended."""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace

import pytest
from action_msgs.msg import GoalStatus
from fake_action import Client, Future

from com_core.sequencing.errors import CancelledRunError, RunError, TimeoutRunError
from exploration_sequencer.ros_gripper import ActionGripper

NAME = "/gripper_controller/gripper_cmd"


class Handle:
    def __init__(self, accepted: bool = True) -> None:
        self.accepted, self.ended, self.cancels = accepted, Future(), 0

    def get_result_async(self) -> Future:
        return self.ended

    def cancel_goal_async(self) -> Future:
        self.cancels += 1
        return Future()


class Clock:
    """Raises ``stop`` at the first wait whose text holds ``at``; any other wait for what
    has not come times out."""

    def __init__(self, at: str = "", stop: type[RunError] = CancelledRunError) -> None:
        self.at, self.stop = at, stop

    def wait(self, done: Callable[[], object], what: str, wall_timeout: float | None) -> None:
        if self.at and self.at in what:
            self.at = ""
            raise self.stop(f"stopped while {what}")
        if not done():
            raise TimeoutRunError(f"no {what}")


def gripper(answer: Future, clock: Clock) -> ActionGripper:
    port = ActionGripper.__new__(ActionGripper)  # no node: its client and publisher are fakes
    port._log = SimpleNamespace(info=lambda text: None)
    port._clock, port._client, port._name, port.timeout = clock, Client(answer), NAME, 10.0
    port._sent = SimpleNamespace(publish=lambda msg: None)
    return port


def answered(handle: Handle) -> Future:
    answer = Future()
    answer.set(handle)
    return answer


@pytest.mark.parametrize("stop", [TimeoutRunError, CancelledRunError])
def test_a_goal_whose_result_the_run_stops_waiting_for_is_cancelled(stop):
    handle = Handle()
    port = gripper(answered(handle), Clock("waiting for the result", stop))
    with pytest.raises(RunError) as raised:
        port.command(0.0, 20.0, "closing")
    assert handle.cancels == 1
    assert isinstance(raised.value, CancelledRunError) is (stop is CancelledRunError)
    if stop is TimeoutRunError:
        assert f"no result from the action {NAME}" in str(raised.value)


@pytest.mark.parametrize("accepted", [True, False])
def test_a_goal_sent_as_the_run_was_cancelled_is_cancelled_once_accepted(accepted):
    answer, handle = Future(), Handle(accepted)
    port = gripper(answer, Clock("waiting for the answer"))
    with pytest.raises(CancelledRunError):
        port.command(0.04, 20.0, "opening")
    assert handle.cancels == 0  # not answered yet
    answer.set(handle)
    assert handle.cancels == int(accepted)


@pytest.mark.parametrize("status", [GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED])
def test_a_goal_that_ended_is_left_as_it_ended(status):
    handle = Handle()
    result = SimpleNamespace(position=0.03, effort=20.0, stalled=True, reached_goal=False)
    handle.ended.set(SimpleNamespace(status=status, result=result))
    port = gripper(answered(handle), Clock())
    if status == GoalStatus.STATUS_SUCCEEDED:
        outcome = port.command(0.0, 20.0, "closing")
        assert (outcome.position, outcome.stalled) == (0.03, True)
    else:
        with pytest.raises(RunError, match="did not succeed closing"):
            port.command(0.0, 20.0, "closing")
    assert handle.cancels == 0
