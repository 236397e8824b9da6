"""A robot behind every port of ``com_core.sequencing`` (no ROS, no physics): what the run
tests drive in milliseconds.

One world: the run's clock (1 ms steps, jumping ahead while nothing moves), the Panda's
joint states, a trajectory controller that moves the joints linearly to a path's last
point, a gripper whose fingers stall on an object at the pick pose, a wrist sensor that
reads the gravity wrench of the hand and what it holds (from the URDF's kinematics, with
white noise) at 250 Hz, the pose labels, a recorder and an estimator that answers each
``done``. ``events`` says what the run sent, and when (sim ns).
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
from conftest import PANDA, choreography

from com_core.bags.cdr import WrenchStampedEncoder
from com_core.contract import DIAGNOSTICS_TOPIC, DONE, OK, WRENCH_TOPIC
from com_core.estimation.runs.settings import SETTINGS
from com_core.sensing.wrench_model import gravity_wrench
from com_core.sequencing.errors import CancelledRunError, RunError, TimeoutRunError
from com_core.sequencing.ports import EstimatorAnswer, GripperOutcome, JointPath

MS = 1_000_000
SAMPLE = 4 * MS  # the sensor's period: 250 Hz, enough samples per window, fewer to make
HOME, PICK = list(PANDA.home_joints), list(PANDA.pick_joints)
HAND = (0.7, np.array([0.0, 0.0, 0.06]))  # kg, m in the sensor frame
OBJECT = (0.4, np.array([0.01, -0.02, 0.11]))
NOISE = (0.02, 0.001)  # N, N m per sample
SENSOR = WrenchStampedEncoder("ft_sensor")


class FakeWorld:
    """See module. ``result_error``: the arm's controller does not succeed, with that
    reason; ``object_mass``: the object's (None: nothing stands at the pick pose);
    ``on_label(label, world)``: called as each label goes out (a test's cancel, say)."""

    def __init__(self, result_error: str = "", object_mass: float | None = OBJECT[0],
                 seed: int = 0) -> None:  # fmt: skip
        self.t = 10_000 * MS
        self.motion = choreography("panda")
        self.joints = {name: (q, 0.0) for name, q in zip(PANDA.arm_joints, HOME, strict=True)}
        self.joints |= {name: (PANDA.gripper_open, 0.0) for name in PANDA.gripper_joints}
        self.arm_joints: frozenset[str] = frozenset()
        self.events: list[tuple[int, str, object]] = []
        self.result_error = result_error
        self.object_mass = object_mass
        self.held = False
        self.cancel = threading.Event()
        self.sim_timeout = 5.0
        self.warnings: list[str] = []
        self.on_label = lambda label, world: None
        self._path: tuple[int, np.ndarray, np.ndarray, int] | None = None  # start, from, to, end
        self._rested = self.t
        self._rng = np.random.default_rng(seed)
        self._captured: list[bytes] | None = None
        self.latest_ns = 0
        self.recording, self.bag_written = False, 0
        self.disk_full_after: int | None = None  # labels, then the recorder's writer stops
        self.labels: list[tuple[int, str]] = []
        self.estimator_calls: list[tuple[str, object]] = []
        self.settings_values = {name: row.default for name, row in SETTINGS.items()}
        self.answer_status = OK

    # --- the world --------------------------------------------------------------------------

    def _advance(self, to_ns: int) -> None:
        """Time runs to ``to_ns``: the arm along its path, the sensor's samples."""
        while self.t < to_ns:
            step = MS if self._path is not None else to_ns - self.t
            self._sample(self.t, self.t + step)
            self.t += step
            self._move()

    def _move(self) -> None:
        if self._path is None:
            return
        start, q0, q1, end = self._path
        share = min(max((self.t - start) / (end - start), 0.0), 1.0)
        speed = 0.0 if share >= 1.0 else 1e9 / (end - start)
        q = q0 + share * (q1 - q0)
        self.joints |= {n: (float(v), float(speed * (b - a))) for n, v, a, b in
                        zip(PANDA.arm_joints, q, q0, q1, strict=True)}  # fmt: skip
        if share >= 1.0:
            self._path, self._rested = None, self.t

    def _sample(self, after_ns: int, to_ns: int) -> None:
        """The sensor's samples stamped every SAMPLE ns in (after_ns, to_ns], while
        captured."""
        stamps = range((after_ns // SAMPLE + 1) * SAMPLE, to_ns + 1, SAMPLE)
        if self._captured is None or not stamps:
            return
        gravity = self.motion.robot.gravity_in_sensor({n: q for n, (q, _) in self.joints.items()})
        wrench = gravity_wrench(HAND[0], HAND[1], gravity)
        if self.held and self.object_mass is not None:
            wrench = wrench + gravity_wrench(self.object_mass, OBJECT[1], gravity)
        noise = self._rng.normal(size=(len(stamps), 6)) * np.repeat(NOISE, 3)
        encode = SENSOR.encode
        self._captured += [
            encode(s, (wrench + n).tolist()) for s, n in zip(stamps, noise, strict=True)
        ]
        self.latest_ns = stamps[-1]

    # --- RunClock -------------------------------------------------------------------------

    def now_ns(self) -> int:
        return self.t

    def wait(self, done, what: str, wall_timeout: float | None) -> None:
        limit = self.t + round((wall_timeout or 60.0) * 1e9)
        while not done():
            if self.cancel.is_set():
                raise CancelledRunError(f"cancelled while {what}")
            if self.t > limit:
                raise TimeoutRunError(f"timed out while {what}")
            self._advance(self.t + MS)

    def sleep_until(self, stamp_ns: int, what: str) -> None:
        if self.cancel.is_set():
            raise CancelledRunError(f"cancelled while {what}")
        self._advance(stamp_ns)

    # --- JointFeed ------------------------------------------------------------------------

    def rested_since(self, names, resting) -> int | None:
        return self._rested if all(resting(n, *self.joints[n]) for n in names) else None

    def joints_over(self, start_ns: int, end_ns: int) -> dict[str, float]:
        return {name: q for name, (q, _) in self.joints.items()}

    # --- ArmPort --------------------------------------------------------------------------

    def send(self, path: JointPath, what: str) -> None:
        self.events.append((self.t, "send", path))
        q0 = np.array([self.joints[n][0] for n in path.names])
        start = max(self.t, path.stamp_ns)
        self._path = (start, q0, np.array(path.points[-1][1]), start + path.duration_ns)

    def finished(self, wall_timeout: float) -> None:
        self.events.append((self.t, "finished", None))
        if self.result_error:
            raise RunError(self.result_error)

    def forget(self) -> None:
        self.events.append((self.t, "forget", None))

    # --- GripperPort ----------------------------------------------------------------------

    def command(self, position: float, max_effort: float, what: str) -> GripperOutcome:
        self.events.append((self.t, "gripper", (position, max_effort, what)))
        at_pick = all(abs(self.joints[n][0] - q) < 1e-3
                      for n, q in zip(PANDA.arm_joints, PICK, strict=True))  # fmt: skip
        closing = position == PANDA.gripper_closed
        if closing and at_pick and self.object_mass is not None:
            position = PANDA.gripper_open + 0.5 * (PANDA.gripper_closed - PANDA.gripper_open)
            self.held = True
        elif not closing:
            self.held = False
        self.joints |= {name: (position, 0.0) for name in PANDA.gripper_joints}
        stalled = position != PANDA.gripper_closed and closing
        return GripperOutcome(position, max_effort, stalled, not stalled)

    # --- LabelSink ------------------------------------------------------------------------

    def publish(self, stamp_ns: int, label: str) -> None:
        self.events.append((self.t, "label", (stamp_ns, label)))
        self.labels.append((stamp_ns, label))
        self.on_label(label, self)

    # --- RunRecorder ----------------------------------------------------------------------

    def start(self, bag_dir: Path) -> None:
        Path(bag_dir).mkdir(parents=True)
        self.recording, self.bag_written = True, 0
        self.events.append((self.t, "recording", bag_dir))

    def stop(self) -> dict[str, int]:
        self.recording = False
        self.events.append((self.t, "stopped", None))
        return {WRENCH_TOPIC: self.bag_written}

    def failure(self) -> str:
        full = self.disk_full_after is not None and len(self.labels) > self.disk_full_after
        return "the bag's writer stopped: [Errno 28] No space left on device" if full else ""

    def capture(self, topic: str) -> None:
        if topic == DIAGNOSTICS_TOPIC:  # the estimator's statuses: one heard at once
            self.latest_ns = self.t
            return
        self._captured, self.latest_ns = [], 0

    def release(self, topic: str) -> list[bytes]:
        if topic == DIAGNOSTICS_TOPIC:
            self.events.append((self.t, "diagnostics heard", None))
            return []
        raws, self._captured = self._captured or [], None
        self.bag_written += len(raws)
        return raws

    # --- EstimatorPort --------------------------------------------------------------------

    def settings(self, names) -> dict:
        return {name: self.settings_values[name] for name in names}

    def set(self, name: str, value: object) -> None:
        self.estimator_calls.append(("set", (name, value)))

    def restore(self) -> None:
        self.estimator_calls.append(("restore", None))

    def reset(self) -> None:
        self.estimator_calls.append(("reset", None))

    def save_payload(self, bag: Path) -> None:
        self.estimator_calls.append(("save_payload", bag))

    def heard(self) -> tuple[int, int]:
        return self.t, self.labels[-1][0] if self.labels else -(2**62)

    def clear_answers(self) -> None:
        self.estimator_calls.append(("clear_answers", None))

    def answer(self, done_ns: int) -> EstimatorAnswer | None:
        if (done_ns, DONE) not in self.labels:
            return None
        return EstimatorAnswer(self.answer_status, "mass 0.400 kg", {"payload": "False"},
                               "ft_sensor")  # fmt: skip

    # --- RunLog ---------------------------------------------------------------------------

    def info(self, message: str) -> None:
        self.events.append((self.t, "info", message))

    def warning(self, message: str) -> None:
        self.warnings.append(message)
        self.events.append((self.t, "warning", message))

    def error(self, message: str) -> None:
        self.events.append((self.t, "error", message))

    # --- what a test reads ----------------------------------------------------------------

    def sent(self, kind: str) -> list[tuple[int, object]]:
        """(sim ns, value) of every event of ``kind``."""
        return [(t, value) for t, k, value in self.events if k == kind]
