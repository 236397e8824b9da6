"""Shared, launch-free fixtures: a private ROS domain, node processes, an rclpy context.

- ``ros_domain_id()`` claims a ROS_DOMAIN_ID in 1..100 that no other test session on this
  machine holds (an exclusive lock file per id, starting from a pid-derived offset).
- ``ros_env``: the environment for child processes: os.environ plus
  ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and the test's own ROS_DOMAIN_ID.
- ``start_node(script, package, params=None, args=None, name=None)`` starts
  <prefix>/lib/<package>/<script> as a process (as ``ros2 run`` would), logging
  to a file under tmp_path (parameters as ``com_core.runtime.processes.ros_args`` writes them);
  every node is stopped at teardown (``com_core.runtime.processes.stop``: SIGINT, then SIGTERM,
  then SIGKILL), and its log tail is printed when the test failed; a node still running at
  teardown must end on SIGINT with exit code 0, and no node may log a traceback or an
  internal error however it ended, or the test errors.
- ``rclpy_context``: an rclpy Context on the same domain, shut down at teardown;
  ``wait_for_messages`` and ``spin_until`` wait on it with a timeout.
- ``replay_json(bag)``: the installed replay's --json answer; ``write_stream_bag(path,
  stream)``: a run bag of a synthetic exploration stream (no ROS).
- ``shared_value(tmp_path_factory, key, compute)``: ``compute()``'s value, computed once
  per test session by whichever pytest-xdist worker asks first (a module's tests may run
  on several), pickled for the others.
- OPENBLAS_NUM_THREADS is 1 unless set (see below).
- FASTRTPS_DEFAULT_PROFILES_FILE is ``fastdds_quick_discovery.xml`` unless set: more initial
  discovery announcements, so a test's client finds nodes that start beside it at once
  (with Fast DDS's defaults, one time in three it took 2-3 s more).
"""

from __future__ import annotations

import os
from pathlib import Path

# One BLAS thread unless told otherwise, read once as numpy loads (here, through com_core),
# and inherited by the processes the tests start: the fits' least squares are small, and a
# second thread waiting for a core that another process keeps busy makes each of them 100
# times slower.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault(
    "FASTRTPS_DEFAULT_PROFILES_FILE", str(Path(__file__).with_name("fastdds_quick_discovery.xml"))
)

import fcntl
import itertools
import json
import pickle
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import pytest

from com_core.contract import INTERNAL_ERROR
from com_core.robot.config import read_robot_config, urdf_file
from com_core.runtime.processes import STOP_SEQUENCE, executable, ros_args, stop
from com_core.runtime.rosenv import keep_dds_local

# Nothing in the test process may talk DDS beyond this machine.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
keep_dds_local()

WORKSPACE = Path(__file__).resolve().parents[1]
PANDA = read_robot_config("panda")
"""The Panda's robot configuration: every node's default arm."""
PANDA_JOINTS = (*PANDA.arm_joints, *PANDA.gripper_joints)
"""The names of the Panda's /joint_states: arm, then gripper."""


def choreography(robot: str) -> Any:
    """The choreography (``com_core.robot``) of a shipped robot configuration on the
    URDF of its ``urdf`` file (gripper joints movable, as a real arm's)."""
    from com_core.robot.choreography import Choreography

    config = read_robot_config(robot)
    return Choreography.of(config, urdf_file(config).read_text())


_LOCK_DIR = Path(tempfile.gettempdir()) / "ros_domain_id_locks"
_held_locks: dict[int, Any] = {}
_counter = itertools.count()
_LOG_TAIL_LINES = 40


T = TypeVar("T")


def shared_value(
    tmp_path_factory: pytest.TempPathFactory, key: str, compute: Callable[[], T]
) -> T:
    """``compute()``'s value (picklable), computed once per test session: under
    pytest-xdist the first worker to ask computes it, holding a lock file in the
    session's shared temporary directory, and pickles it there; the others wait for the
    lock and read it. Without xdist, ``compute()``."""
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        return compute()
    root = tmp_path_factory.getbasetemp().parent / "shared_values"
    root.mkdir(exist_ok=True)
    path = root / f"{key}.pickle"
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if path.exists():
            return pickle.loads(path.read_bytes())
        value = compute()
        partial = path.with_suffix(".partial")
        partial.write_bytes(pickle.dumps(value))
        partial.replace(path)
        return value


def ros_domain_id() -> int:
    """Claim a ROS_DOMAIN_ID in 1..100 unused by any other test session on this machine.

    Tries ids from an offset derived from the pid and a per-session counter, taking an
    exclusive non-blocking lock on a file per id; the lock is held until
    ``release_domain_id`` (or the end of the process).
    """
    _LOCK_DIR.mkdir(exist_ok=True)
    start = os.getpid() * 7 + next(_counter)
    for k in range(100):
        domain = (start + k) % 100 + 1
        if domain in _held_locks:
            continue
        handle = open(_LOCK_DIR / f"{domain}.lock", "w")  # noqa: SIM115 - held while in use
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _held_locks[domain] = handle
        return domain
    raise RuntimeError("all ROS domain ids 1..100 are in use by other test sessions")


def release_domain_id(domain: int) -> None:
    """Release a domain id claimed by ``ros_domain_id``."""
    handle = _held_locks.pop(domain, None)
    if handle is not None:
        handle.close()


@pytest.hookimpl(tryfirst=True, hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo) -> Iterator[None]:
    """Remember each phase's report on the item, so fixtures know whether the test failed."""
    outcome = yield
    report = outcome.get_result()
    setattr(item, f"rep_{report.when}", report)


@pytest.fixture
def ros_env() -> Iterator[dict[str, str]]:
    """Environment for child processes: localhost-only discovery and this test's domain."""
    domain = ros_domain_id()
    env = dict(os.environ)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(domain)
    env["PYTHONUNBUFFERED"] = "1"
    env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"
    yield env
    release_domain_id(domain)


UNCLEAN_EXIT = ("Traceback", "never retrieved", "terminate called")
"""Text a node's output must not hold after SIGINT: a shutdown that is not clean."""


def unclean_exit(process: subprocess.Popen, sig: signal.Signals | None, log: str) -> str:
    """Why a node stopped by ``stop`` did not shut down cleanly ('' if it did): the first
    signal of STOP_SEQUENCE (SIGINT) must end it, with exit code 0 and none of UNCLEAN_EXIT
    in its output."""
    if sig is None:
        return ""
    if sig != STOP_SEQUENCE[0][0] or process.returncode != 0:
        return f"needed {sig.name}, exit code {process.returncode}"
    return ", ".join(f"{text!r} in its output" for text in UNCLEAN_EXIT if text in log)


DEFECTS = (INTERNAL_ERROR, "Traceback")
"""Text no node's output may hold, however it ended: a defect, never a user's input."""


def defect_logged(log: str) -> str:
    """What of DEFECTS a node's output holds ('' if none)."""
    return ", ".join(f"{text!r} in its output" for text in DEFECTS if text in log)


def log_tail(path: Path, lines: int = _LOG_TAIL_LINES) -> str:
    """The last ``lines`` lines of a log file."""
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError as error:
        return f"(no log: {error})"


@pytest.fixture
def start_node(
    ros_env: dict[str, str], tmp_path: Path, request: pytest.FixtureRequest
) -> Iterator[Callable[..., subprocess.Popen]]:
    """Callable that starts a node's console script as a process; all are stopped at teardown.

    ``start_node(script, package, params=None, args=None, name=None)``: the script is found
    as ``ros2 run`` finds it (``com_core.runtime.processes.executable``); ``params`` become
    ``-p name:=value`` (pass ``{"use_sim_time": True}`` to ask for sim time), ``args`` are
    extra command-line arguments placed before ``--ros-args``, ``name`` remaps the node name.
    The process's ``log_path`` attribute is its stdout+stderr log.
    """
    started: list[tuple[subprocess.Popen, Path]] = []

    def start(
        script: str,
        package: str,
        params: dict[str, Any] | None = None,
        args: list[str] | None = None,
        name: str | None = None,
    ) -> subprocess.Popen:
        remaps = {"__node": name} if name else None
        command = [
            str(executable(package, script)),
            *(args or []),
            *ros_args(params or {}, remaps),
        ]
        log_path = tmp_path / f"{name or script}-{len(started)}.log"
        with open(log_path, "w") as log:
            process = subprocess.Popen(
                command, env=ros_env, stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path
            )
        process.log_path = log_path  # type: ignore[attr-defined]
        started.append((process, log_path))
        return process

    yield start
    stopped_by = [stop(process) for process, _ in reversed(started)][::-1]
    failed = any(
        getattr(getattr(request.node, f"rep_{when}", None), "failed", False)
        for when in ("setup", "call")
    )
    unclean = [
        f"{log_path.name}: {why}"
        for (process, log_path), sig in zip(started, stopped_by, strict=True)
        if (why := unclean_exit(process, sig, log_path.read_text(errors="replace")))
        or (why := defect_logged(log_path.read_text(errors="replace")))
    ]
    if failed or unclean:
        for process, log_path in started:
            print(f"\n----- {log_path.name} (exit code {process.returncode}), last lines -----")
            print(log_tail(log_path))
    if unclean and not failed:
        pytest.fail(
            "nodes did not shut down cleanly on SIGINT, or logged a defect: " + "; ".join(unclean)
        )


@pytest.fixture
def rclpy_context(ros_env: dict[str, str]) -> Iterator[Any]:
    """An rclpy Context initialised on the test's ROS_DOMAIN_ID; shut down at teardown."""
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_env["ROS_DOMAIN_ID"]))
    yield context
    rclpy.try_shutdown(context=context)


def spin_until(node: Any, predicate: Callable[[], bool], timeout: float) -> bool:
    """Spin ``node`` until ``predicate()`` is true or ``timeout`` s (wall) passed."""
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    deadline = time.monotonic() + timeout
    try:
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.05)
        return True
    finally:
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0.0)


def wait_for_messages(
    node: Any, msg_type: Any, topic: str, count: int = 1, timeout: float = 10.0, qos: Any = 10
) -> list[Any]:
    """Subscribe to ``topic`` and return the first ``count`` messages (fewer on timeout)."""
    received: list[Any] = []
    subscription = node.create_subscription(msg_type, topic, received.append, qos)
    try:
        spin_until(node, lambda: len(received) >= count, timeout)
    finally:
        node.destroy_subscription(subscription)
    return received[:count]


def replay_json(bag: Path, env: dict[str, str] | None = None, *options: str) -> dict[str, Any]:
    """What the installed ``replay`` prints for ``bag`` with ``--json`` (the offline
    estimate: mass, com, sigmas, status, ...)."""
    out = subprocess.run(
        [str(executable("com_estimator", "replay")), str(bag), "--json", *options],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    return json.loads(out)


def write_stream_bag(path: Path, stream: Any, labels: bool = True, **writer: Any) -> None:
    """A run bag of a synthetic ``stream`` (``com_core.paper.synthetic.exploration_stream``): its
    wrenches, and its pose labels unless ``labels`` is False, in stamp order; ``writer``
    passes on to CrashSafeBagWriter (chunk_size, ...)."""
    from com_core.bags.cdr import encode_header, encode_wrench_stamped
    from com_core.bags.writer import CrashSafeBagWriter
    from com_core.contract import POSE_TOPIC, TOPIC_TYPES, WRENCH_TOPIC

    messages = [
        (int(s), WRENCH_TOPIC, encode_wrench_stamped(int(s), "ft_sensor", w))
        for s, w in zip(stream.stamps, stream.wrenches, strict=True)
    ]
    if labels:
        messages += [(s, POSE_TOPIC, encode_header(s, lbl)) for s, lbl in stream.labels]
    with CrashSafeBagWriter(path, **writer) as bag:
        for stamp, topic, raw in sorted(messages, key=lambda m: m[0]):
            bag.write(topic, TOPIC_TYPES[topic], stamp, raw)


def made_up_calibration(sensor: str, share: float = 0.1) -> Any:
    """A calibration of ``sensor`` as one in place would give: an estimate drawn from the
    stated prior, ``share`` of the prior's variance left."""
    from dataclasses import replace

    import numpy as np

    from com_core.estimation.fits.in_place import InPlaceCalibration
    from com_core.estimation.fits.known_gravity import Reference
    from com_core.estimation.runs.sensor_calibration import SensorCalibration
    from com_core.sensing.calibration import Calibration

    stated = Calibration(0.01, 290.0, 10.0)
    estimate = np.random.default_rng(7).normal(0.0, stated.sigma, (6, 6))
    left = share * stated.error_cov
    result = InPlaceCalibration(replace(stated, estimate=estimate, residual_cov=left),
                                Reference(1.0, 1e-4), 40.0, 42, ("home", "tilt_x+"))  # fmt: skip
    return SensorCalibration(sensor, 1.8e9, result)
