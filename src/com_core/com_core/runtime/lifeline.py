"""A lifeline from a process to the nodes it starts: a node whose starter ended stops.

The starter (the demo) opens a pipe and holds its write end; each node it starts inherits
the read end, named in its environment by ``LIFELINE_ENV``. Nothing is ever written. When
the starter ends, however it ends (SIGKILL too), the kernel closes its write end; once no
process holds one, the node's read returns end of file, and the node stops as Ctrl-C
stops it (``stop_with_parent``: SIGINT to its main thread). A node started by hand has no
``LIFELINE_ENV`` and runs as before.

Nodes that must stop in order (the sequencer before the simulator, so that a cancelled
run still puts the object back with the simulator running) are chained: a node started
``holding`` another lifeline keeps that lifeline's write end open until it ends itself,
and the nodes on that lifeline stop only once both the starter and the holder are gone.

A pipe rather than ``prctl(PR_SET_PDEATHSIG)``: the death signal follows the thread that
started the child, not its process, and is set in a ``preexec_fn``, which is unsafe in a
process that runs threads; and rather than polling ``os.getppid()``: the end of file comes
at once, and nothing wakes up while the starter lives.
"""

from __future__ import annotations

import os
import signal
import stat
import threading
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["LIFELINE_ENV", "Lifeline", "stop_with_parent"]

LIFELINE_ENV = "COM_LIFELINE_FD"
"""The environment variable that names, in a node, the read end of its starter's lifeline."""


class Lifeline:
    """A pipe whose write end this process holds and whose read end the nodes it starts
    with ``popen_kwargs`` watch; ``close`` (or the end of this process) cuts it."""

    def __init__(self) -> None:
        self.read_fd, self.write_fd = os.pipe()  # neither is inherited unless passed

    def popen_kwargs(
        self, env: Mapping[str, str] | None = None, holding: Lifeline | None = None
    ) -> dict[str, Any]:
        """``subprocess.Popen`` keyword arguments for a node that watches this lifeline:
        ``env`` (default: this process's environment) with ``LIFELINE_ENV`` naming the read
        end, and ``pass_fds`` with that read end and, with ``holding``, the write end of
        that other lifeline, which the node then holds open until it ends."""
        fds = (self.read_fd,) if holding is None else (self.read_fd, holding.write_fd)
        return {
            "env": {**(os.environ if env is None else env), LIFELINE_ENV: str(self.read_fd)},
            "pass_fds": fds,
        }

    def close(self) -> None:
        """Close both ends (once): the nodes that watch it stop once no holder is left."""
        for fd in (self.read_fd, self.write_fd):
            if fd >= 0:
                os.close(fd)
        self.read_fd = self.write_fd = -1


def stop_with_parent(
    say: Callable[[str], None] | None = None, sig: signal.Signals = signal.SIGINT
) -> threading.Thread | None:
    """Watch the lifeline ``LIFELINE_ENV`` names, if any: a daemon thread that waits for its
    end of file (the process that started this one ended, and every holder), then passes
    ``say`` a line that says so and sends ``sig`` to the main thread, so the node stops as
    on Ctrl-C. Returns the thread; None (nothing watched) when the environment names no
    pipe, as for a node started by hand. The variable is removed from the environment, so
    that processes this one starts do not take the lifeline for theirs."""
    text = os.environ.pop(LIFELINE_ENV, None)
    try:
        fd = int(text) if text is not None else -1
        if fd < 0 or not stat.S_ISFIFO(os.fstat(fd).st_mode):
            return None
    except (ValueError, OSError):
        return None
    os.set_inheritable(fd, False)
    parent = os.getppid()
    main = threading.main_thread().ident

    def watch() -> None:
        try:
            while os.read(fd, 1):  # nothing is written: only the end of file returns
                pass
        except OSError:  # the descriptor is no longer the pipe: nothing to watch
            return
        if say is not None:
            say(f"the process that started this one (pid {parent}) ended: stopping")
        signal.pthread_kill(main, sig)

    thread = threading.Thread(target=watch, name="lifeline", daemon=True)
    thread.start()
    return thread
