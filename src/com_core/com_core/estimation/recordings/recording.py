"""A recording without pose labels, as the fit of any recording takes it
(``recordings.recording_fit``): each wrench sample (N, N m, sensor frame, stamped s)
with R_base_sensor and its design, the wrench per unit of the load's mass and first
moment (m, c): from joint states through the robot's kinematics and dynamics
(``recording_from_joint_states``; ``recording_from_bag`` for a rosbag2,
``recording_from_inbox`` for one already fed to an exploration), or from logged
orientations (``recording_from_orientations``; CSV and NumPy logs:
``read_recording_file``, columns ``CSV_COLUMNS``).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.bags.reader import BagReading
from com_core.contract import WRENCH_TOPIC
from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.known_gravity import gravity_designs
from com_core.estimation.fits.motion import (
    ORDER,
    WINDOW,
    joint_motion,
)
from com_core.estimation.runs.feed import feed_bag
from com_core.estimation.runs.inbox import Inbox
from com_core.estimation.runs.motion_solution import joint_arrays
from com_core.estimation.runs.settings import exploration_from, robot_from
from com_core.robot.dynamics import sensor_regressors
from com_core.robot.model import DEFAULT_GRAVITY, RobotModel

__all__ = [
    "CSV_COLUMNS",
    "Recording",
    "read_recording_file",
    "recording_from_bag",
    "recording_from_inbox",
    "recording_from_joint_states",
    "recording_from_orientations",
]

CSV_COLUMNS = {
    "wrench": ("fx", "fy", "fz", "tx", "ty", "tz"),
    "quaternion": ("qx", "qy", "qz", "qw"),
    "rotation": tuple(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)),
}
"""A CSV log's columns (header row): ``time`` (s), the wrench (N, N m, sensor frame), and
R_base_sensor either as a unit quaternion (x, y, z, w: ROS's order) or row-major."""


@dataclass(frozen=True)
class Recording:
    """Samples of one recording, each with what the fit needs (module).

    times (n,) s; wrenches (n, 6) N, N m; rotations (n, 3, 3) R_base_sensor; designs
    (n, 6, 4) the wrench per unit of (m, c), with the motion's inertial forces where the
    joint states give them (else the static A(g)); omega and alpha (n,) the sensor's
    angular speed (rad/s) and acceleration (rad/s^2); dynamic: the designs hold the
    motion (joint states) or not (orientations only); source: what it was read from;
    inertia_designs (n, 6, 6): with joint states, the wrench per unit of the load's
    inertia about the sensor origin (``robot.dynamics``' last six columns)."""

    times: NDArray[np.float64]
    wrenches: NDArray[np.float64]
    rotations: NDArray[np.float64]
    designs: NDArray[np.float64]
    omega: NDArray[np.float64]
    alpha: NDArray[np.float64]
    dynamic: bool
    source: str
    notes: tuple[str, ...] = ()
    inertia_designs: NDArray[np.float64] | None = None

    @property
    def rates(self) -> NDArray[np.float64]:
        """(n, 6, 4): the designs' rate of change (per s), central differences: a design
        ``delay`` s earlier is D - delay dD/dt, to first order."""
        return np.gradient(self.designs, self.times, axis=0)


def _angular_rates(
    times: NDArray[np.float64], rotations: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(|omega| rad/s, |alpha| rad/s^2) (n,) of R_base_sensor ``rotations`` (n, 3, 3) at
    ``times``: central differences of the rotation, smoothed over 50 ms."""
    n = len(times)
    if n < 3:
        return np.zeros(n), np.zeros(n)
    relative = np.einsum("kji,kjl->kil", rotations[:-2], rotations[2:])  # R_{k-1}^T R_{k+1}
    vee = 0.5 * np.stack(
        [
            relative[:, 2, 1] - relative[:, 1, 2],
            relative[:, 0, 2] - relative[:, 2, 0],
            relative[:, 1, 0] - relative[:, 0, 1],
        ],
        axis=1,
    )
    dt = (times[2:] - times[:-2])[:, None]
    omega = np.concatenate([vee[:1], vee, vee[-1:]]) / np.concatenate([dt[:1], dt, dt[-1:]])
    period = float(np.median(np.diff(times)))
    width = max(1, round(0.05 / period))
    kernel = np.ones(width) / width
    omega = np.stack([np.convolve(omega[:, a], kernel, mode="same") for a in range(3)], axis=1)
    alpha = np.gradient(omega, times, axis=0)
    return np.linalg.norm(omega, axis=1), np.linalg.norm(alpha, axis=1)


def _static_designs(rotations: NDArray[np.float64], gravity: NDArray[np.float64]):
    """(n, 6, 4): A(g_k) at each R_base_sensor, g_k = R_k^T g_base."""
    return gravity_designs(np.einsum("kji,j->ki", rotations, gravity))


def _checked_samples(
    times: ArrayLike, wrenches: ArrayLike, orientations: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.intp], list[str]]:
    """(the indices of the samples kept, in time order; notes): a sample whose stamp,
    wrench or orientation (``orientations``, one row per sample) is not finite is
    dropped, and counted in the notes."""
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    w = np.asarray(wrenches, dtype=np.float64).reshape(len(t), 6)
    good = np.isfinite(t) & np.isfinite(w).all(axis=1)
    if orientations is not None:
        good &= np.isfinite(orientations.reshape(len(t), -1)).all(axis=1)
    notes = [f"{int((~good).sum())} samples not finite, dropped"] if not good.all() else []
    kept = np.flatnonzero(good)
    return kept[np.argsort(t[kept], kind="stable")], notes


def recording_from_orientations(
    times: ArrayLike,
    wrenches: ArrayLike,
    rotations: ArrayLike,
    gravity: ArrayLike = DEFAULT_GRAVITY,
    source: str = "orientations",
) -> Recording:
    """A recording of ``wrenches`` (n, 6; N, N m, sensor frame) stamped ``times`` (s) with
    R_base_sensor ``rotations`` (n, 3, 3) or unit quaternions (n, 4; x, y, z, w) at the
    same stamps, under ``gravity`` (m/s^2, base frame). Quasi-static: the designs are
    A(g) (the sensor's linear acceleration is unknown)."""
    r = np.asarray(rotations, dtype=np.float64)
    r = _quaternion_matrices(r) if r.ndim == 2 and r.shape[1] == 4 else r.reshape(-1, 3, 3)
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if len(r) != len(t):
        raise ValueError(f"{len(r)} orientations for {len(t)} wrench stamps")
    kept, notes = _checked_samples(t, wrenches, r)
    t, w, r = t[kept], np.asarray(wrenches, dtype=np.float64)[kept], r[kept]
    omega, alpha = _angular_rates(t, r)
    g = np.asarray(gravity, dtype=np.float64).reshape(3)
    return Recording(t, w, r, _static_designs(r, g), omega, alpha, False, source, tuple(notes))


def _quaternion_matrices(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 3, 3) of unit quaternions (n, 4; x, y, z, w), normalised."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], 1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], 1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], 1),
        ],
        axis=1,
    )


def recording_from_joint_states(
    robot: RobotModel,
    joint_times: ArrayLike,
    joint_positions: ArrayLike,
    times: ArrayLike,
    wrenches: ArrayLike,
    source: str = "joint states",
) -> Recording:
    """A recording of ``wrenches`` (n, 6; N, N m, sensor frame) stamped ``times`` (s) with
    the arm's joint positions (samples, ``robot.joint_names``; rad, m) stamped
    ``joint_times`` (s; interpolated at their median period unless evenly stamped): the
    rotations and the designs with the motion's inertial forces (``motion.joint_motion``'s
    q, dq, ddq). Wrenches outside the joint states' span (less the differentiation's
    half window) are dropped, and counted in the notes."""
    kept, notes = _checked_samples(times, wrenches)
    t = np.asarray(times, dtype=np.float64).reshape(-1)[kept]
    w = np.asarray(wrenches, dtype=np.float64).reshape(-1, 6)[kept]
    jt = np.asarray(joint_times, dtype=np.float64).reshape(-1)
    jq = np.asarray(joint_positions, dtype=np.float64).reshape(len(jt), -1)
    order = np.argsort(jt, kind="stable")
    jt, jq = jt[order], jq[order]
    unique = np.concatenate([[True], np.diff(jt) > 0])
    jt, jq = jt[unique], jq[unique]
    if len(jt) < 20:
        raise ValueError(f"{len(jt)} joint states: too few to follow the motion")
    period = float(np.median(np.diff(jt)))
    even = jt[0] + period * np.arange(round((jt[-1] - jt[0]) / period) + 1)
    if len(even) != len(jt) or np.max(np.abs(even - jt)) > 0.01 * period:
        gap = float(np.max(np.diff(jt)))
        even = np.arange(jt[0], jt[-1], period)  # the Savitzky-Golay fit wants even stamps
        jq = np.stack([np.interp(even, jt, jq[:, j]) for j in range(jq.shape[1])], axis=1)
        jt = even
        notes.append(
            f"joint states not evenly stamped (longest gap {gap * 1e3:.0f} ms): resampled at "
            f"their median period, {period * 1e3:.1f} ms"
        )
    half = max(round(WINDOW / 2 / period), ORDER // 2 + 1) * period
    inside = (t > jt[0] + half) & (t < jt[-1] - half)
    if not inside.all():
        notes.append(f"{int((~inside).sum())} wrenches outside the joint states' span, dropped")
    t, w = t[inside], w[inside]
    q, dq, ddq = joint_motion(jt, jq, t)
    regressors = sensor_regressors(robot, q, dq, ddq)
    designs = regressors[:, :, :4]
    rotations = np.stack([robot.sensor_rotation_of(row) for row in q])
    omega, alpha = _angular_rates(t, rotations)
    if period > WINDOW / (ORDER + 1):
        notes.append(
            f"joint states at {1 / period:.0f} Hz: too slow to differentiate twice over "
            f"{WINDOW * 1e3:.0f} ms; the motion's inertial forces are left to the "
            "quasi-static windows' bound"
        )
        designs = _static_designs(rotations, robot.gravity)
        return Recording(t, w, rotations, designs, omega, alpha, False, source, tuple(notes))
    return Recording(
        t, w, rotations, designs, omega, alpha, True, source, tuple(notes), regressors[:, :, 4:]
    )


def recording_from_inbox(inbox: Inbox, robot: RobotModel, source: str) -> Recording:
    """``recording_from_joint_states`` of every wrench and joint state an inbox holds (a
    bag fed to an exploration, ``feed.feed_bag``). EstimationError without joint states
    that give every joint moving the sensor."""
    stamps, wrenches = inbox.samples()
    if not len(stamps):
        raise EstimationError("no wrench samples")
    joint_times, positions = joint_arrays(
        inbox, robot, int(stamps[0]) - 10**9, int(stamps[-1]) + 10**9
    )
    return recording_from_joint_states(
        robot, joint_times, positions, stamps * 1e-9, wrenches, source
    )


def recording_from_bag(
    bag: Path | str, settings: Mapping[str, Any], wrench_topic: str = WRENCH_TOPIC
) -> Recording:
    """``recording_from_inbox`` of a rosbag2's wrenches and joint states, fed as the replay
    feeds a run (``runs.feed.feed_bag``), with the robot model of the estimator
    ``settings`` (frames, gravity; its robot_description, else the bag's
    /robot_description). EstimationError without a robot model or joint states."""
    exploration = exploration_from(settings)
    reading = BagReading()
    feed_bag(bag, exploration, wrench_topic, reading=reading)
    robot, problem = robot_from(settings, reading.robot_description)
    if robot is None:
        raise EstimationError(f"{bag}: no kinematics: {problem}")
    return recording_from_inbox(exploration, robot, str(bag))


def read_recording_file(path: Path | str, gravity: ArrayLike = DEFAULT_GRAVITY) -> Recording:
    """A CSV (``CSV_COLUMNS``, a header row) or NumPy ``.npz`` log (arrays ``time`` (n,),
    ``wrench`` (n, 6) and ``quaternion`` (n, 4) or ``rotation`` (n, 3, 3)) as a
    ``Recording``. ValueError naming what is missing."""
    path = Path(path)
    if path.suffix == ".npz":
        with np.load(path) as data:
            arrays = {name: data[name] for name in data.files}
        missing = [name for name in ("time", "wrench") if name not in arrays]
        orientation = arrays.get("quaternion", arrays.get("rotation"))
        if missing or orientation is None:
            raise ValueError(
                f"{path}: needs arrays time, wrench and quaternion or rotation; "
                f"has {', '.join(arrays) or 'none'}"
            )
        return recording_from_orientations(
            arrays["time"], arrays["wrench"], orientation, gravity, str(path)
        )
    with path.open(newline="") as stream:
        reader = csv.reader(stream)
        header = [name.strip() for name in next(reader, [])]
        rows = np.array([[float(v) for v in row] for row in reader if row], dtype=np.float64)
    index = {name: k for k, name in enumerate(header)}
    kind = next(
        (k for k in ("quaternion", "rotation") if set(CSV_COLUMNS[k]) <= index.keys()), None
    )
    needed = ("time", *CSV_COLUMNS["wrench"])
    if kind is None or not set(needed) <= index.keys() or rows.ndim != 2:
        raise ValueError(
            f"{path}: needs the columns time, {', '.join(CSV_COLUMNS['wrench'])} and "
            f"{', '.join(CSV_COLUMNS['quaternion'])} or r11..r33; has {', '.join(header)}"
        )

    def columns(names: Sequence[str]) -> NDArray[np.float64]:
        return rows[:, [index[name] for name in names]]

    orientation = columns(CSV_COLUMNS[kind])
    return recording_from_orientations(
        rows[:, index["time"]], columns(CSV_COLUMNS["wrench"]), orientation, gravity, str(path)
    )
