"""The arm's trajectories of a run as a trajectory controller runs them: what in them would
move the arm through a static window or jolt it (``/exploration_sequencer/arm_trajectory``,
each trajectory as sent, against the pose labels).

A Jazzy joint_trajectory_controller starts a trajectory when it arrives and runs from the
arm's state then to its first point at stamp + time_from_start; between points it
interpolates by what they carry, linearly for positions alone (a velocity step). So a
trajectory that arrives while a static window is open moves the arm in it, unless its
first point holds the arm where it rests (at rest, due no earlier than the window's end);
and a point without velocities jolts the arm.
"""

from __future__ import annotations

from dataclasses import dataclass

from com_core.contract import MOVING, STATIC_PREFIXES

__all__ = ["SentTrajectory", "trajectory_problems"]


@dataclass(frozen=True)
class SentTrajectory:
    """One trajectory as sent: ``labels_before`` pose labels had been recorded before it
    (the bag's order); its header stamp (ns, sim time; 0: on arrival); ``first_ns`` its
    first point's time_from_start (ns); ``first_at_rest``: its first point carries zero
    velocities; ``positions_only``: some point carries no velocities."""

    labels_before: int
    stamp_ns: int
    first_ns: int
    first_at_rest: bool
    positions_only: bool


def trajectory_problems(
    trajectories: list[SentTrajectory], labels: list[tuple[int, str]]
) -> list[str]:
    """What in ``trajectories`` a trajectory controller would run through a static window
    or as a velocity step, one line each; ``labels`` (stamp ns, label) in the bag's order."""
    problems = []
    for k, sent in enumerate(trajectories, start=1):
        if sent.positions_only:
            problems.append(
                f"arm trajectory {k}: a point with positions only (the controller "
                "interpolates it linearly: a velocity step)"
            )
        if not sent.labels_before:
            continue
        stamp, label = labels[sent.labels_before - 1]
        if not label.startswith(STATIC_PREFIXES):
            continue
        ends = [s for s, name in labels[sent.labels_before :] if name == MOVING]
        holds = (
            sent.first_at_rest
            and sent.stamp_ns > 0
            and bool(ends)
            and sent.stamp_ns + sent.first_ns >= ends[0]
        )
        if not holds:
            problems.append(
                f"arm trajectory {k}: arrived while the window {label} (from t = "
                f"{stamp * 1e-9:.3f} s) was open; a trajectory controller moves the arm on "
                "arrival"
            )
    return problems
