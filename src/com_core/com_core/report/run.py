"""One exploration run read back from its bag: wrenches, labels, estimate, ground truth.

Ground truth: ``/wrench_sim/ground_truth`` is republished whenever the object is grasped,
released, or moves in the grasp (slip). The report compares with the last one published
while the object was held, at or before the ``done`` label (the state the estimate
describes). "Held" comes from ``/wrench_sim/object`` (``state=held``/``state=not_held``),
published together with the truth message it pairs with (nearest by log time); a truth
message without a description is a republish while held. Without descriptions every
truth message counts as held. If none qualifies, the last truth message is used and the
report says so. If the truth moved while held before ``done`` (a slip), the report
gives by how much.

Messages are decoded from their CDR bytes with ``com_core.bags.cdr`` (wrenches, labels) and
the rosbags type store (the rest); nothing here imports rclpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.bags.cdr import decode_header, decode_wrench_batch
from com_core.bags.reader import read_raw, recorder_lost, recorder_lost_text
from com_core.contract import (
    ARM_SENT_TOPIC,
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    ESTIMATE_TOPIC,
    HAND_TRUTH_TOPIC,
    OBJECT_TOPIC,
    POSE_TOPIC,
    TRUTH_MOVE_M,
    TRUTH_TOPIC,
    WRENCH_TOPIC,
    done_stamp,
    status_of,
)
from com_core.estimation.runs.cutting import window_sample_counts
from com_core.estimation.runs.solution import missing_samples, window_counts
from com_core.report.commands import SentTrajectory, trajectory_problems
from com_core.robot.dynamics import INERTIA_ELEMENTS

__all__ = ["RUN_BAG_TOPICS", "Inertia", "RunData", "motion_fitted", "read_run"]

RUN_BAG_TOPICS = (
    WRENCH_TOPIC,
    POSE_TOPIC,
    ESTIMATE_TOPIC,
    DIAGNOSTICS_TOPIC,
    TRUTH_TOPIC,
    HAND_TRUTH_TOPIC,
    OBJECT_TOPIC,
)
"""The topics a run's summary reads."""
_BATCH = 16384


@dataclass(frozen=True)
class Inertia:
    """One geometry_msgs/InertiaStamped: mass (kg), COM (shape (3,), m, ``ft_sensor``) and
    the inertia about the COM (shape (6,), kg m^2, its ``robot.dynamics.INERTIA_ELEMENTS``).

    ``stamp_ns`` is the header stamp (sim time), ``log_ns`` the bag's log time.
    """

    stamp_ns: int
    log_ns: int
    mass: float
    com: NDArray[np.float64]
    inertia: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))


@dataclass
class RunData:
    """What the report shows of one run bag.

    Attributes
    ----------
    name : run id (the bag directory's name).
    stamps : shape (n,); ns, sim time (header stamps), sorted.
    wrenches : shape (n, 6); N and N m; ``ft_sensor``.
    labels : (stamp ns, label) sorted by stamp.
    done_ns : stamp of the ``done`` that ends the run (``com_core.contract.done_stamp``).
    estimate : the ``/com_estimator/estimate`` of this run (stamped with its ``done``), or None.
    diagnostic : level (int), message (str) and values (dict of str) of the last
        ``com_estimator: exploration`` status on ``/diagnostics``, or None.
    truth : the object's ground truth chosen as the module says, or None.
    truth_note : how ``truth`` was chosen (one line).
    hand : the last ``/wrench_sim/hand_ground_truth``, or None.
    object_text : the last ``/wrench_sim/object`` description with ``state=held`` (else
        the last one), or None.
    counts : messages read per topic.
    notes : problems met while reading (unreadable bag, undecodable messages).
    incomplete : what the bag lacks of the run: messages the recorder was told it lost,
        and each window of which it holds fewer samples than the estimator used.
    commands : what in the arm's trajectories as sent (ARM_SENT_TOPIC) a trajectory
        controller would run through a static window or as a velocity step
        (``report.commands``).
    """

    name: str
    stamps: NDArray[np.int64] = field(default_factory=lambda: np.empty(0, np.int64))
    wrenches: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 6)))
    labels: list[tuple[int, str]] = field(default_factory=list)
    done_ns: int | None = None
    estimate: Inertia | None = None
    diagnostic: dict | None = None
    truth: Inertia | None = None
    truth_note: str = ""
    hand: Inertia | None = None
    object_text: str | None = None
    counts: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    incomplete: list[str] = field(default_factory=list)
    commands: list[str] = field(default_factory=list)

    @property
    def missing(self) -> list[str]:
        """Topics of a run bag with no message in this one."""
        return [t for t in RUN_BAG_TOPICS if not self.counts.get(t)]

    @property
    def status(self) -> str:
        """OK, WARN, ERROR (from the diagnostics), or UNKNOWN without them."""
        if self.diagnostic is None:
            return "UNKNOWN"
        return status_of(self.diagnostic["level"])


def read_run(bag: Path | str) -> RunData:
    """Read everything the report shows from a run bag (rosbag2 directory, MCAP).

    A bag that cannot be read to its end gives what was read before the failure and a
    note saying why.
    """
    from rosbags.typesys import Stores, get_typestore

    bag = Path(bag)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    run = RunData(name=bag.resolve().name)
    raws: list[bytes] = []
    stamp_parts: list[NDArray[np.int64]] = []
    wrench_parts: list[NDArray[np.float64]] = []
    other_frames: dict[str, int] = {}
    truths: list[Inertia] = []
    states: list[tuple[int, bool]] = []  # (log ns, held) from /wrench_sim/object
    trajectories: list[SentTrajectory] = []

    def flush() -> None:
        if not raws:
            return
        try:
            stamps, wrenches, frames = decode_wrench_batch(raws)
        except (ValueError, IndexError) as exc:
            run.notes.append(f"{len(raws)} undecodable wrench messages dropped ({exc})")
        else:
            stamp_parts.append(stamps)
            wrench_parts.append(wrenches)
            for name in set(frames.tolist()) - {"ft_sensor"}:
                other_frames[name] = other_frames.get(name, 0) + int((frames == name).sum())
        raws.clear()

    def inertia(raw: bytes, log_ns: int) -> Inertia:
        msg = typestore.deserialize_cdr(raw, "geometry_msgs/msg/InertiaStamped")
        c = msg.inertia.com
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        elements = np.array([getattr(msg.inertia, name) for name in INERTIA_ELEMENTS])
        return Inertia(stamp, log_ns, float(msg.inertia.m), np.array([c.x, c.y, c.z]), elements)

    try:
        for topic, msgtype, log_ns, raw in read_raw(bag, (*RUN_BAG_TOPICS, ARM_SENT_TOPIC)):
            run.counts[topic] = run.counts.get(topic, 0) + 1
            try:
                if topic == WRENCH_TOPIC:
                    raws.append(raw)
                    if len(raws) >= _BATCH:
                        flush()
                elif topic == POSE_TOPIC:
                    if msgtype != "std_msgs/msg/Header":
                        run.notes.append(f"labels of type {msgtype} ignored")
                        continue
                    run.labels.append(decode_header(raw))
                elif topic == ARM_SENT_TOPIC:
                    trajectories.append(_sent(typestore.deserialize_cdr(raw, msgtype),
                                              len(run.labels)))  # fmt: skip
                elif topic == ESTIMATE_TOPIC:
                    run.estimate = inertia(raw, log_ns)
                elif topic == TRUTH_TOPIC:
                    truths.append(inertia(raw, log_ns))
                elif topic == HAND_TRUTH_TOPIC:
                    run.hand = inertia(raw, log_ns)
                elif topic == OBJECT_TOPIC:
                    text = typestore.deserialize_cdr(raw, msgtype).data
                    held = "state=held" in text.split()
                    if held or not any(h for _, h in states):
                        run.object_text = text  # the last one while held, if ever held
                    if "state=" in text:
                        states.append((log_ns, held))
                elif topic == DIAGNOSTICS_TOPIC:
                    msg = typestore.deserialize_cdr(raw, msgtype)
                    for status in msg.status:
                        if status.name == DIAGNOSTIC_NAME:
                            run.diagnostic = {
                                "level": int(status.level),
                                "message": status.message,
                                "values": {kv.key: kv.value for kv in status.values},
                            }
            except Exception as exc:  # one bad message must not cost the report
                run.notes.append(f"undecodable message on {topic}: {exc}")
    except Exception as exc:  # a truncated bag (crashed recorder): report what was read
        run.notes.append(f"bag not read to the end: {exc}")
    flush()
    if stamp_parts:
        stamps, wrenches = np.concatenate(stamp_parts), np.concatenate(wrench_parts)
        order = np.argsort(stamps, kind="stable")
        run.stamps, run.wrenches = stamps[order], wrenches[order]
    for name, n in other_frames.items():
        run.notes.append(f"{n} wrench samples in frame {name!r}, not 'ft_sensor'")
    run.done_ns = done_stamp(run.labels)  # in recorded order, before sorting by stamp
    run.commands = trajectory_problems(trajectories, run.labels)
    if lost := recorder_lost_text(recorder_lost(bag)):
        run.incomplete.append(lost)
    if run.diagnostic is not None:  # the windows the bag holds fewer samples of than used
        used = window_counts(run.diagnostic["values"])
        held = window_sample_counts(run.stamps, run.labels, run.done_ns)
        run.incomplete += missing_samples(used, held)
    run.labels.sort(key=lambda sl: sl[0])
    latched_earlier = run.estimate is not None and run.estimate.stamp_ns != run.done_ns
    if run.done_ns is not None and latched_earlier:  # the latched estimate of an earlier run
        run.estimate = None
    until = run.done_ns
    if until is None and run.estimate is not None:
        until = run.estimate.stamp_ns
    run.truth, run.truth_note = _choose_truth(truths, states, until)
    return run


def _sent(msg, labels_before: int) -> SentTrajectory:
    """A trajectory_msgs/JointTrajectory as ``report.commands`` reads it."""
    first = msg.points[0] if len(msg.points) else None
    tfs = first.time_from_start if first is not None else None
    return SentTrajectory(
        labels_before=labels_before,
        stamp_ns=msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
        first_ns=0 if tfs is None else tfs.sec * 1_000_000_000 + tfs.nanosec,
        first_at_rest=first is not None
        and len(first.velocities) > 0
        and not any(first.velocities),
        positions_only=any(len(p.velocities) == 0 for p in msg.points),
    )


def _choose_truth(
    truths: list[Inertia], states: list[tuple[int, bool]], until_ns: int | None
) -> tuple[Inertia | None, str]:
    """The last truth published while held at or before ``until_ns`` (see module)."""
    if not truths:
        return None, "no ground truth"
    held = [True] * len(truths)
    log_times = np.array([t.log_ns for t in truths])
    for log_ns, is_held in states:  # each description pairs with its truth message
        held[int(np.argmin(np.abs(log_times - log_ns)))] = is_held
    candidates = [
        t
        for t, h in zip(truths, held, strict=True)
        if h and (until_ns is None or t.stamp_ns <= until_ns)
    ]
    n = len(truths)
    if not candidates:
        return truths[-1], f"the last of {n} published (none while held before done)"
    chosen = candidates[-1]
    note = f"t = {chosen.stamp_ns * 1e-9:.3f} s, the last of {n} published while held"
    note += " before done" if until_ns is not None else ""
    moved = max(float(np.linalg.norm(t.com - chosen.com)) for t in candidates)
    if moved > TRUTH_MOVE_M:
        note += f"; moved {moved * 1e3:.2f} mm in the grasp"
    return chosen, note


def motion_fitted(
    bag: Path | str, values: dict[str, str]
) -> list[tuple[str, NDArray[np.float64], NDArray[np.float64]]]:
    """The wrench the motion fit of a run's status ``values`` (its parameters, bias and
    delay) gives along the object's motions of ``bag`` (``motion_solution.fitted_wrenches``
    with the bag's joint states and robot description, the frames of its robot
    configuration); [] when the run was not in motion or the bag lacks them."""
    from com_core.bags.reader import BagReading
    from com_core.estimation.runs.feed import feed_bag
    from com_core.estimation.runs.motion_solution import MOTION, fitted_wrenches
    from com_core.estimation.runs.settings import exploration_from, robot_from
    from com_core.estimation.runs.solution import vector_value
    from com_core.robot.config import BAG_ROBOT_FILE, RobotConfigError, read_robot_config

    keys = ("parameters", "hand_parameters", "bias", "delay")
    if values.get("excitation") != MOTION or not all(k in values for k in keys):
        return []
    settings: dict[str, object] = {"information": "kinematics"}
    try:
        config = read_robot_config(str(Path(bag) / BAG_ROBOT_FILE))
        settings |= {"sensor_frame": config.sensor_frame, "base_frame": config.base_frame}
    except RobotConfigError:
        pass
    exploration = exploration_from(settings)
    reading = BagReading()
    feed_bag(bag, exploration, reading=reading)
    robot, _ = robot_from(settings, reading.robot_description)
    if robot is None:
        return []
    load = np.add(vector_value(values, "parameters"), vector_value(values, "hand_parameters"))
    bias = np.array(vector_value(values, "bias"))
    return fitted_wrenches(exploration, robot, load, bias, float(values["delay"]))
