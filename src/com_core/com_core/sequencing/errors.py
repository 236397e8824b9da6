"""What ends a run: each a message that says why."""

from __future__ import annotations

__all__ = ["CancelledRunError", "RecordingError", "RunError", "TimeoutRunError"]


class RunError(RuntimeError):
    """An exploration cannot go on; the message says why."""


class TimeoutRunError(RunError):
    """Something the arm answers did not happen in time (e.g. the arm was blocked)."""


class RecordingError(RunError):
    """The run's recording stopped (a full or failing disk): the run goes back and ends."""


class CancelledRunError(RunError):
    """The run was cancelled (a goal's cancel, or the node stopping)."""
