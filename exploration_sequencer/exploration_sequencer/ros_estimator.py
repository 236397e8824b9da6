"""The estimator's port (``com_core.sequencing.ports.EstimatorPort``) over ROS: its
settings read, a run's options set on it and restored after, a reset, the payload files
saved (its services; each call is retried three times and fails as a RunError that names
the service), and what it has heard and answered (its diagnostics, which the I/O node
hears)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.callback_groups import CallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from std_srvs.srv import Trigger

from com_core.contract import (
    ESTIMATOR_PARAMETERS_SERVICE,
    ESTIMATOR_RESET_SERVICE,
    ESTIMATOR_SAVE_PAYLOAD_SERVICE,
    ESTIMATOR_SET_PARAMETERS_SERVICE,
    status_of,
)
from com_core.sequencing.errors import RunError, TimeoutRunError
from com_core.sequencing.ports import EstimatorAnswer
from exploration_sequencer.io_node import IoNode

CALL_TRIES, CALL_TIMEOUT = 3, 3.0  # s (wall) each: a request sent before the service matched


class EstimatorLink:
    """The estimator's services for ``node`` (in ``group``), waited for on ``io``, and its
    diagnostics as ``io`` hears them; ``service_timeout()`` is how long (s, wall) a
    service may take to appear."""

    def __init__(
        self,
        node: Node,
        io: IoNode,
        group: CallbackGroup,
        service_timeout: Callable[[], float],
    ) -> None:
        self._log, self._io, self._timeout = node.get_logger(), io, service_timeout
        self._reset = node.create_client(Trigger, ESTIMATOR_RESET_SERVICE, callback_group=group)
        self._get = node.create_client(
            GetParameters, ESTIMATOR_PARAMETERS_SERVICE, callback_group=group
        )
        self._set = node.create_client(
            SetParameters, ESTIMATOR_SET_PARAMETERS_SERVICE, callback_group=group
        )
        self._save = node.create_client(
            Trigger, ESTIMATOR_SAVE_PAYLOAD_SERVICE, callback_group=group
        )
        self._restore: dict[str, object] = {}  # the parameters a run changed, as they were

    def _call(self, client, request, what: str):
        """The answer of a service; RunError if it is not there within
        ``service_timeout()`` s, or does not answer CALL_TRIES tries of CALL_TIMEOUT s."""
        if not client.wait_for_service(timeout_sec=self._timeout()):
            raise RunError(f"{client.srv_name} is not available ({what})")
        for attempt in range(1, CALL_TRIES + 1):
            future = client.call_async(request)
            try:
                self._io.wait(future.done, what, wall_timeout=CALL_TIMEOUT)
                break
            except TimeoutRunError:
                client.remove_pending_request(future)
                if attempt == CALL_TRIES:
                    raise
                self._log.warning(f"{client.srv_name} did not answer; asking again")
        return future.result()

    def settings(self, names: Sequence[str]) -> dict[str, Any]:
        """The estimator's parameters ``names`` by name, as Python values."""
        answer = self._call(self._get, GetParameters.Request(names=list(names)),
                            "reading the estimator's settings")  # fmt: skip
        return {n: parameter_value_to_python(v) for n, v in zip(names, answer.values,
                                                                strict=True)}  # fmt: skip

    def set(self, name: str, value: object) -> None:
        """Set the estimator's parameter ``name`` for this run (``restore`` puts it back);
        RunError when the estimator refuses it."""
        answer = self._call(self._get, GetParameters.Request(names=[name]), f"reading {name}")
        previous = Parameter.from_parameter_msg(ParameterMsg(name=name, value=answer.values[0]))
        self._restore.setdefault(name, previous.value)
        request = SetParameters.Request(
            parameters=[Parameter(name, value=value).to_parameter_msg()]
        )
        answer = self._call(self._set, request, f"setting the estimator's {name}")
        if not answer.results[0].successful:
            raise RunError(f"the estimator refused {name}={value!r}: {answer.results[0].reason}")

    def restore(self) -> None:
        """The estimator's parameters as they were before the run's options (a failure is
        logged)."""
        for name, value in self._restore.items():
            request = SetParameters.Request(
                parameters=[Parameter(name, value=value).to_parameter_msg()]
            )
            try:
                self._call(self._set, request, f"restoring {name}")
            except RunError as exc:
                self._log.error(f"the estimator's {name} not restored: {exc}")
        self._restore.clear()

    def reset(self) -> None:
        """A new exploration on the estimator (its ~/reset)."""
        self._call(self._reset, Trigger.Request(), "resetting the estimator")

    def save_payload(self, bag: Path) -> None:
        """The estimator's payload files beside the bag (its ~/save_payload, to the bag's
        directory); a failure is logged, the run goes on."""
        directory = Parameter("payload_save_dir", Parameter.Type.STRING, str(bag))
        request = SetParameters.Request(parameters=[directory.to_parameter_msg()])
        try:
            self._call(self._set, request, "setting payload_save_dir")
            answer = self._call(self._save, Trigger.Request(), "saving the payload")
        except RunError as exc:
            self._log.error(f"payload files not written: {exc}")
            return
        if answer.success:
            self._log.info(f"payload files: {answer.message}")
        else:
            self._log.error(f"payload files not written: {answer.message}")

    def heard(self) -> tuple[int, int]:
        return self._io.estimator_latest, self._io.estimator_label

    def clear_answers(self) -> None:
        self._io.diagnostics.clear()

    def answer(self, done_ns: int) -> EstimatorAnswer | None:
        status = next((s for stamp, s in self._io.diagnostics if stamp == done_ns), None)
        if status is None:
            return None
        values = {kv.key: kv.value for kv in status.values}
        return EstimatorAnswer(status_of(status.level), status.message, values,
                               status.hardware_id)  # fmt: skip
