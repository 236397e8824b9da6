"""Feed a recorded run (rosbag2 directory) to an ``Exploration``, as the node is fed
over DDS: the replay's input path (``com_estimator.replay``, ``bench/``)."""

from __future__ import annotations

from pathlib import Path

from com_core.bags.cdr import decode_header, decode_wrenches
from com_core.bags.reader import BagReading, read_raw
from com_core.contract import (
    DIAGNOSTIC_NAME,
    DIAGNOSTICS_TOPIC,
    JOINT_STATES_TOPIC,
    POSE_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    WRENCH_TOPIC,
)
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.fit_setup import WRENCHES

__all__ = ["feed_bag"]

_BATCH = 4096  # wrench messages decoded at once


def feed_bag(
    bag: Path | str,
    exploration: Exploration,
    wrench_topic: str = WRENCH_TOPIC,
    pose_topic: str = POSE_TOPIC,
    reading: BagReading | None = None,
) -> tuple[int, int]:
    """Feed a bag's wrenches and pose labels to ``exploration`` in recorded order, and
    for ``information`` 'kinematics' its joint states (every publisher's, each message
    with the joints it names, as the node keeps them), with the last robot description
    in ``reading.robot_description`` and the estimator's last exploration status's values
    in ``reading.estimator_values``.

    Returns (wrench messages, label messages) read; ``reading`` as in ``read_raw``.
    Wrenches are decoded in batches, as the node does; the result does not depend on the
    batching.
    """
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    pending: list[bytes] = []
    n_wrench = n_label = 0

    def flush() -> None:
        if pending:
            stamps, wrenches, frames, bad = decode_wrenches(pending)
            exploration.count_dropped("undecodable (malformed CDR)", bad)
            exploration.add_samples(stamps, wrenches, frames)
            pending.clear()

    topics = [wrench_topic, pose_topic, DIAGNOSTICS_TOPIC]
    if exploration.information != WRENCHES:
        topics += [JOINT_STATES_TOPIC, ROBOT_DESCRIPTION_TOPIC]
    for topic, msgtype, _, raw in read_raw(bag, topics, reading):
        if topic == wrench_topic:
            pending.append(raw)
            n_wrench += 1
            if len(pending) >= _BATCH:
                flush()
        elif msgtype == "std_msgs/msg/Header":
            try:
                exploration.add_label(*decode_header(raw))
            except ValueError:
                exploration.count_dropped("undecodable (malformed CDR)", 1, labels=True)
                continue
            n_label += 1
        elif topic == JOINT_STATES_TOPIC:
            msg = typestore.deserialize_cdr(raw, msgtype)
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            exploration.add_joint_state(stamp, msg.name, msg.position.tolist())
        elif topic == ROBOT_DESCRIPTION_TOPIC and reading is not None:
            reading.robot_description = typestore.deserialize_cdr(raw, msgtype).data
        elif topic == DIAGNOSTICS_TOPIC and reading is not None:
            for status in typestore.deserialize_cdr(raw, msgtype).status:
                if status.name == DIAGNOSTIC_NAME:
                    reading.estimator_values = {kv.key: kv.value for kv in status.values}
    flush()
    return n_wrench, n_label
