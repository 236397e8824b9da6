"""What the choreography costs between windows: each move from a window's end to the next
window's start, measured in a run's bag against its plan.

    source ./env.sh && python bench/choreography.py <bag> [<bag> ...] [--settle 0.3]

A move is sent when a static window ends (a trajectory controller starts a trajectory when
it arrives, so none is sent ahead while a window is open); the next window starts
``settle`` s after the joint states show the arm resting at its goal. Per bag, over the
moves of its passes (one trajectory between two windows): the planned time (the
trajectory's duration, as sent on /exploration_sequencer/arm_trajectory, plus ``settle``:
the reference, what a move sent ahead to start at the window's end would take) against the
measured time (the sim-time stamps of the window labels), their ratio, and the time each
move takes beyond its plan. A bag whose trajectories are on /arm_controller/joint_trajectory
instead (a run that sent its moves ahead) is read the same way.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rosbags.typesys import Stores, get_typestore

from com_core.bags.cdr import decode_header
from com_core.bags.reader import read_raw
from com_core.contract import (
    ARM_COMMAND_TOPIC,
    ARM_SENT_TOPIC,
    MOVING,
    POSE_TOPIC,
    STATIC_PREFIXES,
)

NS = 1_000_000_000


def moves(bag: Path, settle: float) -> list[tuple[str, float, float]]:
    """(the window moved to, planned s, measured s) of each window-to-window move."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    events: list[tuple[str, object]] = []  # in the bag's order: labels and trajectories
    topics = (POSE_TOPIC, ARM_SENT_TOPIC, ARM_COMMAND_TOPIC)
    for topic, msgtype, _, raw in read_raw(bag, topics):
        if topic == POSE_TOPIC:
            events.append(("label", decode_header(raw)))
        else:
            msg = typestore.deserialize_cdr(raw, msgtype)
            last = msg.points[-1].time_from_start
            events.append((topic, (last.sec * NS + last.nanosec) * 1e-9))
    sent_topic = ARM_SENT_TOPIC if any(kind == ARM_SENT_TOPIC for kind, _ in events) else (
        ARM_COMMAND_TOPIC)  # fmt: skip
    out = []
    window, end, durations = None, None, []  # the open window, its end, moves since it
    for kind, value in events:
        if kind == "label":
            stamp, label = value
            if label == MOVING and window is not None:
                end = stamp
            elif label.startswith(STATIC_PREFIXES):
                if window is not None and end is not None and len(durations) == 1:  # a pass
                    out.append((label, durations[0] + settle, (stamp - end) * 1e-9))
                window, end, durations = label, None, []
            else:  # a motion's span, the end of the run: no pass goes on through it
                window, end, durations = None, None, []
        elif kind == sent_topic and window is not None:  # sent in the window or after it
            durations.append(value)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bags", nargs="+", type=Path)
    parser.add_argument("--settle", type=float, default=0.3, help="s, the sequencer's settle")
    args = parser.parse_args()
    for bag in args.bags:
        rows = moves(bag, args.settle)
        if not rows:
            print(f"{bag}: no window-to-window move")
            continue
        planned = sum(p for _, p, _ in rows)
        measured = sum(m for _, _, m in rows)
        extra = [m - p for _, p, m in rows]
        print(
            f"{bag.name}: {len(rows)} moves between windows, planned {planned:.2f} s, measured "
            f"{measured:.2f} s (sim): ratio {measured / planned:.3f}; per move "
            f"{1e3 * sum(extra) / len(rows):.0f} ms beyond the plan (min {1e3 * min(extra):.0f}, "
            f"max {1e3 * max(extra):.0f})"
        )


if __name__ == "__main__":
    main()
