"""Joint-space targets and motion times of an exploration (no ROS).

The wrist's last two joints do the tilting (Franka Panda, hand pointing down at home):
joint 6 tilts the hand about the sensor's y axis, and with joint 7 turned by +pi/2
(a turn about the sensor's z axis, along gravity at home, so the load's wrench does not
change) the same joint-6 tilt is about the sensor's x axis. The plan's poses map to
joints as:

    home      q_home
    tilt_y+-  q_home, joint 6 +- tilt
    tilt_x+-  q_home, joint 7 + pi/2, joint 6 +- tilt

so that each pose turns gravity in the sensor frame as ``Plan.poses`` says (a rotation
by +-tilt about the sensor's axis; checked against the Panda's forward kinematics). The
verification pose ``VERIFY_POSE`` is one no plan has: joint 7 turned by pi/4 and joint 6
by ``VERIFY_TILT``, a tilt about the sensor's diagonal, between the y and x axes.

Motion times give each joint at most ``speed`` rad/s on average with the quintic
profile's peak (1.875x the mean) under the joint's limit, with a floor, so tilts stay
smooth and the dynamic wrench small; the sequencer waits ``settle`` s after every motion
before a window starts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from com_core.planner import HOME, Plan

__all__ = [
    "PANDA_VELOCITY_LIMITS",
    "TILT_JOINT",
    "VERIFY_POSE",
    "VERIFY_TILT",
    "WRIST_TURN",
    "motion_time",
    "pose_joints",
    "verify_joints",
]

WRIST_TURN = math.pi / 2
VERIFY_POSE, VERIFY_TILT = "diagonal", math.radians(20.0)
TILT_JOINT, _TURN_JOINT = 5, 6  # indices of panda_joint6 and panda_joint7


def pose_joints(plan: Plan, home: Sequence[float]) -> list[tuple[str, list[float]]]:
    """(pose name, 7 joint positions in rad) for every pose of ``plan``, home first.

    The order is home, tilt_y+, tilt_y-, tilt_x-, tilt_x+ (of those the plan has): the
    wrist turns once, between tilt_y- and tilt_x-, which share joint 6, so the pass is
    short.
    """
    out = []
    names = [name for name, _ in plan.poses()]
    for name in sorted(
        names, key=lambda n: (n != HOME, n[-2:-1] != "y", n[-1] == "+" and "x" in n)
    ):
        q = list(home)
        if name != HOME:
            axis, sign = name[-2], 1.0 if name[-1] == "+" else -1.0
            if axis == "x":
                q[_TURN_JOINT] += WRIST_TURN
            elif axis != "y":
                raise ValueError(f"this arm tilts about the sensor's x and y only, not {axis}")
            q[TILT_JOINT] += sign * plan.tilt
        out.append((name, q))
    return out


def verify_joints(home: Sequence[float], tilt: float = VERIFY_TILT) -> list[float]:
    """7 joint positions (rad) of the verification pose: ``home`` tilted by ``tilt`` (rad)
    about the sensor's diagonal (joint 7 a half wrist turn, joint 6 ``tilt``)."""
    q = list(home)
    q[_TURN_JOINT] += WRIST_TURN / 2
    q[TILT_JOINT] += tilt
    return q


PANDA_VELOCITY_LIMITS = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
"""rad/s per joint (Franka Panda datasheet)."""
QUINTIC_PEAK = 1.875
"""Peak over mean speed of a quintic (rest-to-rest) profile."""


def motion_time(
    start: Sequence[float], goal: Sequence[float], speed: float = 1.35, floor: float = 0.4
) -> float:
    """s for a smooth joint motion: each joint at most ``speed`` rad/s on average and its
    peak under the Panda's limit; at least ``floor`` s."""
    caps = [min(speed, limit / QUINTIC_PEAK) for limit in PANDA_VELOCITY_LIMITS]
    steps = [abs(a - b) / cap for a, b, cap in zip(start, goal, caps, strict=True)]
    return max(floor, *steps)
