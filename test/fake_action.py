"""An action client's futures and client without ROS: what the sequencer's action ports
(``exploration_sequencer.action_goal``) wait on, set by hand."""

from __future__ import annotations

from collections.abc import Callable


class Future:
    """Done once ``set``; its callbacks run then (or at once when added after)."""

    def __init__(self, value: object = None, done: bool = False) -> None:
        self.value, self._done = value, done
        self._callbacks: list[Callable[[Future], None]] = []

    def done(self) -> bool:
        return self._done

    def result(self) -> object:
        return self.value

    def set(self, value: object) -> None:
        self.value, self._done = value, True
        for callback in self._callbacks:
            callback(self)

    def add_done_callback(self, callback: Callable[[Future], None]) -> None:
        self._callbacks.append(callback)
        if self._done:
            callback(self)


class Client:
    """A server that is ready and answers every goal with ``answer``."""

    def __init__(self, answer: Future) -> None:
        self.answer = answer

    def server_is_ready(self) -> bool:
        return True

    def send_goal_async(self, goal: object) -> Future:
        return self.answer
