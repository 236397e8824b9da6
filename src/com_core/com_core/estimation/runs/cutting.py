"""Windows cut from an exploration's inbox by its labels' stamps, the sensor noise learnt
from them, and the windows reduced to their means.

A label (``com_core.contract``) opens a window at its stamp that ends at the next label's
stamp (labels sorted by stamp; ties keep their arrival order); the last window ends at
the ``done`` label (``com_core.contract.done_stamp``), else after the last sample.
``tare/<pose>``, ``object/<pose>`` and ``verify/<pose>`` name static windows; any other
label only closes the current one. Samples belong to the windows their own header stamps
fall in, [start, stop) in ns; the windows of one label are merged. A window's
orientation under the kinematic information is R_base_sensor of the mean joint state
within it (the URDF's forward kinematics, ``com_core.robot.model``), and its time the
mean of its samples' stamps (s): the bias drift's clock (``known_gravity``). Each joint's
mean is over the joint states that name it, so that publishers of some joints each (an
arm's broadcaster, a gripper's) count for theirs, whatever order their messages came in.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from com_core.contract import (
    MOTION_PREFIX,
    OBJECT_PREFIX,
    STATIC_PREFIXES,
    TARE_PREFIX,
)
from com_core.estimation.fits.errors import WindowError
from com_core.estimation.fits.windows import Window, reduce_window
from com_core.estimation.runs.inbox import Inbox, shorten
from com_core.robot.model import RobotModel
from com_core.sensing.noise import NoiseModel, learn_noise
from com_core.sensing.wrench_model import SensorModel

__all__ = [
    "JOINT_MOTION",
    "JOINT_STATE_GAP",
    "Segments",
    "label_spans",
    "motion_spans",
    "noise_model",
    "reduced_windows",
    "segments",
    "spans",
    "window_rotation",
    "window_sample_counts",
    "window_time",
]

JOINT_STATE_GAP = 0.1
"""s; a window without a joint state in it takes the nearest this close to it."""
JOINT_MOTION = 2e-3
"""rad (or m); joints that move more than this within a window leave it out."""

Segments = list[tuple[str, NDArray[np.float64]]]
"""(label, samples (n, 6) N and N m, sensor frame) per window label."""


def spans(
    inbox: Inbox,
    until_ns: int | None = None,
    prefixes: tuple[str, ...] = STATIC_PREFIXES,
) -> dict[str, list[tuple[int, int]]]:
    """[start, stop) stamps (ns) of every window whose label starts with one of
    ``prefixes`` (the static windows: tare, object and verify), per label.

    Windows run from a label's stamp to the next label's; ``until_ns`` ends the last
    one (default: the ``done`` label, else after the last sample).
    """
    end = inbox.done_stamp() if until_ns is None else until_ns
    return label_spans(inbox.labels, end, prefixes)


def label_spans(
    labels: list[tuple[int, str]], end: int | None, prefixes: tuple[str, ...] = STATIC_PREFIXES
) -> dict[str, list[tuple[int, int]]]:
    """``spans`` of (stamp ns, label) in arrival order, the last ending at ``end`` (None:
    after the last sample)."""
    labels = sorted(labels, key=lambda sl: sl[0])  # stable: ties keep arrival order
    if end is not None:
        labels = [(s, lbl) for s, lbl in labels if s <= end]
    if not labels:
        return {}
    bounds = [s for s, _ in labels[1:]] + [end if end is not None else 2**62]
    out: dict[str, list[tuple[int, int]]] = {}
    for (start, label), stop in zip(labels, bounds, strict=True):
        if label.startswith(prefixes):
            out.setdefault(label, []).append((start, stop))
    return out


def window_sample_counts(
    stamps: NDArray[np.int64], labels: list[tuple[int, str]], end: int | None
) -> dict[str, int]:
    """The samples stamped (``stamps``, ns) in each window and motion span of ``labels``
    (the ones ``Solution.window_samples`` counts), by label: a bag's, to hold against the
    estimator's."""
    parts = label_spans(labels, end, (*STATIC_PREFIXES, MOTION_PREFIX))
    return {
        label: int(sum(np.count_nonzero((stamps >= a) & (stamps < b)) for a, b in spans))
        for label, spans in parts.items()
    }


def motion_spans(inbox: Inbox, until_ns: int | None = None) -> dict[str, list[tuple[int, int]]]:
    """``spans`` of the ``motion/`` labels (``com_core.contract``)."""
    return spans(inbox, until_ns, (MOTION_PREFIX,))


def segments(inbox: Inbox, until_ns: int | None = None) -> Segments:
    """(label, samples (n, 6), N and N m) of every window of ``spans``, merged per label."""
    stamps, wrenches = inbox.samples()
    return [
        (label, np.concatenate([wrenches[(stamps >= a) & (stamps < b)] for a, b in parts]))
        for label, parts in spans(inbox, until_ns).items()
    ]


def window_rotation(
    inbox: Inbox, robot: RobotModel, label: str, until_ns: int | None = None
) -> NDArray[np.float64]:
    """R_base_sensor (3, 3) over window ``label`` from ``robot`` and the joint states in
    its span, at each joint's mean over the states that name it there (or the nearest that
    names it within JOINT_STATE_GAP s of the span). Raises WindowError with the reason when
    there is none or a joint moved more than JOINT_MOTION. Each joint's states are taken
    in stamp order (ties by position), so the result is the same whatever order the
    messages of several publishers arrived in."""
    parts = spans(inbox, until_ns)[label]
    joint_states = inbox.joint_states
    stamps = np.array([t for t, _ in joint_states], dtype=np.int64)
    # distance (ns) of each joint state to the window: 0 inside it
    distance = np.full(len(stamps), np.inf)
    for a, b in parts:
        distance = np.minimum(distance, np.maximum(a - stamps, 0) + np.maximum(stamps - b + 1, 0))
    gap = JOINT_STATE_GAP * 1e9
    if not len(stamps) or distance.min() > gap:
        raise WindowError(f"no joint state within {JOINT_STATE_GAP:g} s of window {label!r}")

    def naming(name: str, indices: list[int]) -> list[tuple[float, int, float]]:
        """(distance ns, stamp ns, position) of the states of ``indices`` that name
        joint ``name``."""
        return [(distance[k], stamps[k], joint_states[k][1][name]) for k in indices
                if name in joint_states[k][1]]  # fmt: skip

    inside = np.flatnonzero(distance == 0).tolist()
    near = np.flatnonzero(distance <= gap).tolist()
    positions, moved = {}, 0.0
    for name in robot.chain_names:  # what moves the sensor
        own = sorted(naming(name, inside))
        if not own:  # none inside: the nearest that names it
            nearest = naming(name, near)
            if not nearest:
                raise WindowError(f"window {label!r}: the joint states lack {name!r}")
            own = [min(nearest)]
        q = np.array([position for _, _, position in own], dtype=np.float64)
        moved = max(moved, float(np.ptp(q)))
        positions[name] = float(np.mean(q))
    if moved > JOINT_MOTION:
        raise WindowError(f"window {label!r}: the joints moved {moved * 1e3:.1f} mrad")
    return robot.sensor_rotation(positions)


def window_time(
    inbox: Inbox, label: str, stamps: NDArray[np.int64], until_ns: int | None = None
) -> float:
    """The mean stamp (s) of the samples of window ``label``; ``stamps`` (ns) are every
    kept sample's (``Inbox.samples``), taken once by a caller that asks for many windows."""
    inside = np.zeros(len(stamps), dtype=bool)
    for a, b in spans(inbox, until_ns)[label]:
        inside |= (stamps >= a) & (stamps < b)
    return float(np.mean(stamps[inside])) * 1e-9


def noise_model(
    inbox: Inbox,
    prior: NoiseModel | None,
    until_ns: int | None = None,
    cut: Segments | None = None,
) -> NoiseModel | None:
    """The sensor's noise learnt from the second halves of every static window (``cut``,
    default ``segments(inbox, until_ns)``; the arm's ringing has settled there;
    ``com_core.sensing.noise``), at the rate of the kept samples' stamps; ``prior`` (the
    noise known from before) when they are too few; None without either."""
    if cut is None:
        cut = segments(inbox, until_ns)
    stamps = inbox.samples()[0]
    steps = np.diff(stamps)
    steps = steps[steps > 0]
    rate = 1e9 / float(np.median(steps)) if len(steps) else 1000.0
    learnt = learn_noise([x[len(x) // 2 :] for _, x in cut], rate)
    return learnt if learnt is not None else prior


def reduced_windows(
    cut: Segments, sensor: SensorModel | None, noise: NoiseModel | None
) -> tuple[dict[str, Window], list[Window], list[Window], list[str]]:
    """Every window of ``cut`` reduced to its mean wrench (N, N m, sensor frame) and the
    covariance of that mean with the sensor's ``noise`` (``windows.reduce_window``;
    ``sensor`` for the saturation and motion tests): (tare windows by pose, object
    windows, verify windows, notes on the windows refused: empty, motion, NaN,
    saturation)."""
    tares: dict[str, Window] = {}
    objects: list[Window] = []
    verifies: list[Window] = []
    notes: list[str] = []
    for label, samples in cut:
        kind, pose = label.split("/", 1)
        if len(samples) == 0:
            notes.append(f"window {shorten(label)!r} has no samples")
            continue
        try:
            window = reduce_window(pose, samples, sensor, noise)
        except (WindowError, ValueError) as exc:
            notes.append(f"{kind} {exc}")
            continue
        if kind + "/" == TARE_PREFIX:
            tares[pose] = window
        elif kind + "/" == OBJECT_PREFIX:
            objects.append(window)
        else:
            verifies.append(window)
    return tares, objects, verifies, notes
