"""exploration_sequencer.recorder_process without its child: the calls over the pipe."""

from __future__ import annotations

import multiprocessing
import threading
import time

import pytest

from com_core.sequencing.errors import RunError
from exploration_sequencer.recorder_process import RecorderError, RecorderProcess


def test_a_late_answer_to_a_call_that_timed_out_is_dropped_and_ends_the_run_by_name():
    """A recorder starved past a call's timeout answers it later: the next call gets its
    own answer, not that one; the timeout is a RunError (the run ends by name, no
    defect)."""
    parent, child = multiprocessing.Pipe()
    recorder = object.__new__(RecorderProcess)  # the pipe alone, no child process
    recorder._conn, recorder._lock, recorder._calls = parent, threading.Lock(), 0

    def serve() -> None:
        number, _, _ = child.recv()
        time.sleep(0.3)
        child.send((number, True, ["late"]))
        number, what, _ = child.recv()
        child.send((number, True, what))

    server = threading.Thread(target=serve)
    server.start()
    with pytest.raises(RecorderError, match=r"did not answer 'release' in 0\.1 s") as error:
        recorder._call("release", timeout=0.1)
    assert isinstance(error.value, RunError)
    assert recorder._call("failure", timeout=2.0) == "failure"
    server.join()
