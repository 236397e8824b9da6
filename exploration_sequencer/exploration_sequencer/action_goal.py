"""One goal to a driver's action, as the sequencer's adapters send them: the server awaited,
the goal sent, its acceptance and its result, each within a timeout, every failure a
RunError that names the action."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient
from rclpy.task import Future

from com_core.sequencing.errors import CancelledRunError, RunError, TimeoutRunError
from com_core.sequencing.ports import RunClock


def accepted_goal(
    clock: RunClock,
    client: ActionClient,
    name: str,
    goal: Any,
    what: str,
    timeout: float,
    instead: str,
    interrupted: Callable[[Future], None] | None = None,
) -> Any:
    """Send ``goal`` to ``client``'s action ``name`` and return its handle once accepted;
    RunError naming the action when no server answers within ``timeout`` s (wall;
    ``instead`` says what to do then) or the goal is rejected. A wait for the answer cut
    short by the run's cancel hands its future (the goal on its way, perhaps accepted
    later) to ``interrupted`` before the error goes on."""

    def waited(done, doing: str) -> None:
        try:
            clock.wait(done, f"{doing} of the action {name}", timeout)
        except TimeoutRunError as exc:
            raise RunError(
                f"no {doing.split()[-1]} from the action {name} within {timeout:g} s while "
                f"{what} (is the driver running? {instead})"
            ) from exc

    waited(client.server_is_ready, "waiting for the server")
    sent = client.send_goal_async(goal)
    try:
        waited(sent.done, "waiting for the answer")
    except CancelledRunError:
        if interrupted is not None:
            interrupted(sent)
        raise
    handle = sent.result()
    if handle is None or not handle.accepted:
        raise RunError(f"the action {name} rejected the goal of {what} (its log says why)")
    return handle


def succeeded_result(clock: RunClock, future: Any, name: str, what: str, timeout: float) -> Any:
    """The result of a goal's result ``future`` once done within ``timeout`` s (wall);
    RunError unless its status is SUCCEEDED."""
    try:
        clock.wait(future.done, f"{what}: waiting for the result of {name}", timeout)
    except TimeoutRunError as exc:
        raise RunError(f"no result from the action {name} within {timeout:g} s while {what}") \
            from exc  # fmt: skip
    response = future.result()
    if response is None or response.status != GoalStatus.STATUS_SUCCEEDED:
        status = "no status" if response is None else f"status {response.status}"
        text = getattr(getattr(response, "result", None), "error_string", "")
        raise RunError(f"the action {name} did not succeed {what} ({status}"
                       f"{', ' + text if text else ''})")  # fmt: skip
    return response.result
