"""Joint positions that turn the sensor frame to a wanted orientation about a point that
stays put (pinocchio): the poses of an exploration on any arm of a URDF.

A pose is a rotation of the sensor frame relative to its orientation at ``home``,
R_rel, expressed in the sensor's own home axes: the wanted orientation is
R_target = R_home R_rel (R_* the sensor frame's axes in the world frame of the URDF's
root). The rotation is about a ``pivot`` p, a point fixed in the sensor frame (m; e.g. the
grasped object's centre 0.1 m along the sensor's z): it stays at its home position
x_home = t_home + R_home p, so the wanted origin is t_target = x_home - R_target p.

``solve_pose`` is damped least squares on the 6-D error of (pivot position,
orientation), both in the world frame: e_p = x_home - x (m) and
e_R = R log3(R^T R_target) (rad), the rotation vector that turns R into R_target.
Their Jacobian follows from the sensor frame's (pinocchio, LOCAL_WORLD_ALIGNED): the pivot
moves at v + w x (R p). Each iteration takes the step

    dq = J^T (J J^T + lambda^2 I)^-1 e + (I - J^+ J) (q_home - q),

lambda^2 = damping |e|^2 + 1e-12: the Levenberg-Marquardt step on the error (Newton's
near the solution), and in its null space (an arm with more joints than the 6
constraints) the pull back to home, so among the solutions of the pose the iteration
settles on the one nearest home (a local minimum of |q - q_home| over them). It starts
at home, limits each joint's change per iteration (``max_step``, rad or m), and keeps
the joints within their URDF limits (model.lowerPositionLimit, upperPositionLimit): a
joint that would cross its limit stops at it, and a joint at its limit that the step
would push further is held for that iteration while the others take the step without
it. Only the ``joints`` that may move do (default: the joints between the root and the
sensor frame; fingers and anything beyond the sensor hold their home positions). The
iteration ends when no joint moves by more than 1e-12 rad (m), after ``max_iterations``,
or, with the errors outside the tolerances, after 20 iterations that did not lower |e|.
Nothing here knows the shapes of the arm, the object or the scene: a pose reached may
still collide (a turn of 170 deg about the Panda's hand x is reached, hand up).

Nothing raises for a pose the arm cannot take: ``IkResult.reachable`` is False and
``reason`` names why (a joint at its limit, the pivot off its home position, no
convergence). Malformed input (not a rotation, a joint the URDF lacks) is a ValueError.
The iteration has no randomness: the same input gives the same output to the bit.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.wrench_model import rotation_about, skew

__all__ = ["IkResult", "largest_reachable_tilt", "solve_pose"]

_ROTATION_TOLERANCE = 1e-6
"""A rotation matrix's R^T R may differ from I, and det R from 1, by this much."""
_LIMIT_MARGIN = 1e-9
"""rad or m: a joint this close to a limit is at it."""
_HOME_BEYOND_LIMIT = 1e-6
"""rad or m: a home position this far beyond a limit is malformed; closer, it is clamped."""
_DAMPING_FLOOR = 1e-12
"""The Levenberg-Marquardt lambda^2 at zero error."""
_CONVERGED_STEP = 1e-12
"""rad or m: an iteration that moves no joint more than this has converged."""
_PROGRESS, _PATIENCE = 1e-3, 20
"""An iteration that lowers |e|^2 below (1 - _PROGRESS) of its least so far progresses;
outside the tolerances, _PATIENCE iterations without progress end the iteration."""
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
_RANK_CUTOFF = 1e-6
"""A singular value of the task Jacobian below this fraction of the largest does not
count towards its rank (the null space the pull towards home may use)."""


@dataclass(frozen=True)
class IkResult:
    """What ``solve_pose`` found.

    joints : position of every joint of the model (rad, m) by name; joints that do not move
    keep their home positions. orientation_error : rad, the angle between the sensor
    frame's orientation there and the wanted one. position_error : m, the distance of the
    pivot from its home position. iterations : the iterations taken. distance : the
    joint-space distance from home, the Euclidean norm of the moving joints' changes
    (rad; m for a prismatic joint). reachable : both errors are within the tolerances
    asked for. reason : why not ("" when reachable). at_limit : the joints that ended at a
    limit which the solution pushed against (blocked), in model order.
    """

    joints: dict[str, float]
    orientation_error: float
    position_error: float
    iterations: int
    distance: float
    reachable: bool
    reason: str
    at_limit: tuple[str, ...] = ()


def solve_pose(
    robot: RobotModel,
    home: Mapping[str, float],
    rotation_sensor: ArrayLike | None = None,
    pivot: ArrayLike = (0.0, 0.0, 0.0),
    *,
    joints: Iterable[str] | None = None,
    max_position_error: float = 1e-3,
    tolerance: float = 1e-4,
    max_iterations: int = 200,
    max_step: float = 0.2,
    damping: float = 1e-3,
) -> IkResult:
    """Joint positions at which the sensor frame has turned by ``rotation_sensor`` from its
    home orientation about ``pivot``, starting from ``home``.

    robot : the arm's model; its sensor frame is the frame turned. home : joint positions
    (rad, m) by name, every joint of the model (extra names are ignored).
    rotation_sensor : (3, 3) rotation relative to the home orientation, in the sensor's
    home axes (R_target = R_home rotation_sensor); None is no rotation. pivot : (3,) m, the
    point in the sensor frame that keeps its home position. joints : the joints that may
    move (default: those between the root and the sensor frame). max_position_error : m,
    how far the pivot may end from its home position. tolerance : rad, the orientation
    error allowed. max_iterations, max_step (rad or m per joint and iteration), damping
    (lambda^2 / |e|^2 of the Levenberg-Marquardt step): the iteration's settings.

    Raises ValueError (``KinematicsError`` for joints) for malformed input; a pose the arm
    cannot take is an ``IkResult`` with ``reachable`` False and the reason.
    """
    rotation = _rotation(np.eye(3) if rotation_sensor is None else rotation_sensor)
    p = np.asarray(pivot, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"pivot must be 3 finite numbers (m), got {pivot!r}")
    for name, value in (
        ("max_position_error", max_position_error),
        ("tolerance", tolerance),
        ("max_step", max_step),
    ):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be > 0, got {value}")
    if not (math.isfinite(damping) and damping >= 0.0):
        raise ValueError(f"damping must be >= 0, got {damping}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations}")
    problem = _Problem(robot, home, joints)
    R_home, x_home = problem.pivot_pose(problem.home, p)
    return problem.solve(
        R_home @ rotation,
        x_home,
        p,
        max_position_error=max_position_error,
        tolerance=tolerance,
        max_iterations=max_iterations,
        max_step=max_step,
        damping=damping,
    )


def largest_reachable_tilt(
    robot: RobotModel,
    home: Mapping[str, float],
    axis: ArrayLike,
    pivot: ArrayLike = (0.0, 0.0, 0.0),
    max_tilt: float = math.pi / 2,
    step: float = 0.05,
    resolution: float = 1e-3,
    **solve_options: Any,
) -> float:
    """The largest tilt (rad, 0..``max_tilt``) about ``axis`` that ``solve_pose`` reaches.

    axis : (3,) the tilt's axis in the sensor's home axes (a positive tilt turns the
    sensor about it by the right-hand rule; -axis gives the other way). pivot : (3,) m in
    the sensor frame. Tilts are tried from ``step`` (rad) upwards in steps of ``step``
    until one fails, then the boundary between the last reached and the first failed is
    bisected to ``resolution`` (rad): the answer is a reached tilt and a tilt
    ``resolution`` larger is not (a limit below ``max_tilt``), or ``max_tilt`` itself is
    reached. 0.0 if not even a tilt of min(step, max_tilt) is. ``solve_options`` go to
    ``solve_pose``.
    """
    u = np.asarray(axis, dtype=np.float64)
    if u.shape != (3,) or not np.all(np.isfinite(u)) or not np.linalg.norm(u) > 0.0:
        raise ValueError(f"axis must be 3 finite numbers, not all zero, got {axis!r}")
    for name, value in (("max_tilt", max_tilt), ("step", step), ("resolution", resolution)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be > 0 (rad), got {value}")

    def reached(tilt: float) -> bool:
        rotation = rotation_about(u, tilt)
        return solve_pose(robot, home, rotation, pivot, **solve_options).reachable

    good, bad = 0.0, None
    n_steps = math.ceil(max_tilt / step)
    for k in range(1, n_steps + 1):
        tilt = min(k * step, max_tilt)
        if not reached(tilt):
            bad = tilt
            break
        good = tilt
    if bad is None:
        return good
    while bad - good > resolution:
        middle = 0.5 * (good + bad)
        if reached(middle):
            good = middle
        else:
            bad = middle
    return good


def _rotation(value: ArrayLike) -> NDArray[np.float64]:
    R = np.asarray(value, dtype=np.float64)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"rotation_sensor must be a finite (3, 3) matrix, got shape {R.shape}")
    if (
        np.max(np.abs(R.T @ R - np.eye(3))) > _ROTATION_TOLERANCE
        or abs(np.linalg.det(R) - 1.0) > _ROTATION_TOLERANCE
    ):
        raise ValueError("rotation_sensor is not a rotation matrix (R^T R != I or det R != 1)")
    return R


class _Problem:
    """One arm's joints for ``solve_pose``: the moving joints' columns and limits."""

    def __init__(
        self, robot: RobotModel, home: Mapping[str, float], joints: Iterable[str] | None
    ) -> None:
        import pinocchio

        self.pin, self.robot, self.model = pinocchio, robot, robot.model
        self.data = self.model.createData()  # the robot's own data stays untouched
        self.frame_id = self.model.getFrameId(robot.sensor_frame)
        missing = robot.missing_joints(home)
        if missing:
            raise KinematicsError(f"home has no position for joint(s) {', '.join(missing)}")
        self.names = robot.joint_names
        self.home = np.array([float(home[name]) for name in self.names])
        if not np.all(np.isfinite(self.home)):
            raise ValueError("home joint positions must be finite")
        if joints is None:
            chain = set(self.model.supports[self.model.frames[self.frame_id].parentJoint])
            moving = [n for n in self.names if self.model.getJointId(n) in chain]
        else:
            moving = list(dict.fromkeys(joints))
            unknown = [name for name in moving if name not in self.names]
            if unknown:
                raise KinematicsError(
                    f"joint(s) {', '.join(unknown)} are not joints of the model "
                    f"(joints: {', '.join(self.names)})"
                )
        order = {name: i for i, name in enumerate(self.names)}
        moving.sort(key=order.__getitem__)
        self.moving = tuple(moving)
        self.index = np.array([order[name] for name in moving], dtype=np.intp)
        columns, lower, upper, units = [], [], [], []
        for name in moving:
            jid = self.model.getJointId(name)
            units.append("m" if self.model.joints[jid].shortname() in _PRISMATIC else "rad")
            if self.model.nvs[jid] != 1:
                raise KinematicsError(
                    f"joint {name} has {self.model.nvs[jid]} degrees of freedom; only "
                    "1-DoF joints can move"
                )
            columns.append(self.model.idx_vs[jid])
            if self.model.nqs[jid] == 1:  # revolute or prismatic with limits
                at = self.model.idx_qs[jid]
                lower.append(self.model.lowerPositionLimit[at])
                upper.append(self.model.upperPositionLimit[at])
            else:  # continuous: an angle without limits
                lower.append(-np.inf)
                upper.append(np.inf)
        self.columns = np.array(columns, dtype=np.intp)
        self.units = tuple(units)
        self.lower, self.upper = np.array(lower), np.array(upper)
        start = self.home[self.index]
        beyond = (start < self.lower - _HOME_BEYOND_LIMIT) | (
            start > self.upper + _HOME_BEYOND_LIMIT
        )
        if np.any(beyond):
            name = moving[int(np.flatnonzero(beyond)[0])]
            raise ValueError(f"home position of joint {name} is beyond its limits")
        self.home[self.index] = np.clip(start, self.lower, self.upper)

    def _kinematics(
        self, positions: NDArray[np.float64], jacobian: bool
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
        """R (3, 3), t (3,) m of the sensor frame in the world and, if asked, its
        LOCAL_WORLD_ALIGNED Jacobian's moving columns (6, n)."""
        pin, model, data = self.pin, self.model, self.data
        q = self.robot.configuration(dict(zip(self.names, positions.tolist(), strict=True)))
        if jacobian:
            pin.computeJointJacobians(model, data, q)
        else:
            pin.forwardKinematics(model, data, q)
        placement = pin.updateFramePlacement(model, data, self.frame_id)
        J = None
        if jacobian:
            J = pin.getFrameJacobian(
                model, data, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
            )[:, self.columns]
        return placement.rotation.copy(), placement.translation.copy(), J

    def pivot_pose(
        self, positions: NDArray[np.float64], pivot: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The sensor frame's R (3, 3) and the pivot's position (3,) m in the world."""
        R, t, _ = self._kinematics(positions, jacobian=False)
        return R, t + R @ pivot

    def _error(
        self,
        positions: NDArray[np.float64],
        R_target: NDArray[np.float64],
        x_target: NDArray[np.float64],
        pivot: NDArray[np.float64],
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """e (6,): the pivot's error (m) and the orientation's (rad), world frame; and its
        Jacobian A (6, n): the pivot's velocity v + w x r and the angular velocity w."""
        R, t, J = self._kinematics(positions, jacobian=True)
        assert J is not None
        r = R @ pivot
        e = np.concatenate([x_target - (t + r), R @ self.pin.log3(R.T @ R_target)])
        return e, np.vstack([J[:3] - skew(r) @ J[3:], J[3:]])

    def _step(
        self,
        q: NDArray[np.float64],
        q_home: NDArray[np.float64],
        A: NDArray[np.float64],
        e: NDArray[np.float64],
        lam2: float,
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """One step of the moving joints (rad, m; before ``max_step``) and the joints at a
        limit that the error's step pushed against (held for it)."""
        at_upper = q >= self.upper - _LIMIT_MARGIN
        at_lower = q <= self.lower + _LIMIT_MARGIN

        def pushing(dq: NDArray[np.float64]) -> NDArray[np.bool_]:
            return (at_upper & (dq > 0.0)) | (at_lower & (dq < 0.0))

        # the error's step, without the joints it would push beyond a limit
        free = np.ones(q.size, dtype=bool)
        while True:
            task = np.zeros(q.size)
            if np.any(free):
                task[free] = _damped_step(A[:, free], e, lam2)
            pushed = pushing(task) & free
            if not np.any(pushed):
                break
            free &= ~pushed
        # the pull towards home, in the null space of the joints it may move
        pulled = free.copy()
        while True:
            dq = task.copy()
            if np.any(pulled):
                dq[pulled] += _null_projection(A[:, pulled], (q_home - q)[pulled])
            pushed = pushing(dq) & pulled
            if not np.any(pushed):
                return dq, ~free
            pulled &= ~pushed

    def solve(
        self,
        R_target: NDArray[np.float64],
        x_target: NDArray[np.float64],
        pivot: NDArray[np.float64],
        *,
        max_position_error: float,
        tolerance: float,
        max_iterations: int,
        max_step: float,
        damping: float,
    ) -> IkResult:
        """The iteration of ``solve_pose`` towards R_target (3, 3) and the pivot at
        x_target (3,) m, both in the world frame."""
        positions = self.home.copy()
        q_home = positions[self.index]
        q = q_home.copy()
        blocked = np.zeros(q.size, dtype=bool)
        iterations, stalled = 0, False
        best, since_best = math.inf, 0
        e, A = self._error(positions, R_target, x_target, pivot)
        while iterations < max_iterations:
            cost = float(e @ e)
            within = (
                float(np.linalg.norm(e[3:])) <= tolerance
                and float(np.linalg.norm(e[:3])) <= max_position_error
            )
            if cost < (1.0 - _PROGRESS) * best:
                best, since_best = cost, 0
            else:
                since_best += 1
            if not within and since_best >= _PATIENCE:
                stalled = True
                break
            dq, blocked = self._step(q, q_home, A, e, damping * cost + _DAMPING_FLOOR)
            largest = float(np.max(np.abs(dq))) if dq.size else 0.0
            if largest > max_step:
                dq *= max_step / largest
            q_next = np.clip(q + dq, self.lower, self.upper)
            change = float(np.max(np.abs(q_next - q))) if q.size else 0.0
            q = q_next
            positions[self.index] = q
            iterations += 1
            e, A = self._error(positions, R_target, x_target, pivot)
            if change < _CONVERGED_STEP:
                break
        orientation_error = float(np.linalg.norm(e[3:]))
        position_error = float(np.linalg.norm(e[:3]))
        reachable = orientation_error <= tolerance and position_error <= max_position_error
        reason = ""
        if not reachable:
            errors = (
                f"orientation error {orientation_error:.3g} rad, pivot "
                f"{position_error:.3g} m from its home position"
            )
            if np.any(blocked):
                limits = ", ".join(self._at_limit(i, q[i]) for i in np.flatnonzero(blocked))
                reason = f"joint limit: {limits} ({errors})"
            elif orientation_error <= tolerance:
                reason = (
                    f"position error: the pivot ends {position_error:.3g} m from its home "
                    f"position (more than {max_position_error:.3g} m)"
                )
            elif stalled:
                reason = f"no convergence: the error stopped decreasing ({errors})"
            else:
                reason = f"no convergence in {iterations} iterations ({errors})"
        return IkResult(
            joints=dict(zip(self.names, positions.tolist(), strict=True)),
            orientation_error=orientation_error,
            position_error=position_error,
            iterations=iterations,
            distance=float(np.linalg.norm(q - q_home)),
            reachable=reachable,
            reason=reason,
            at_limit=tuple(self.moving[i] for i in np.flatnonzero(blocked)),
        )

    def _at_limit(self, i: int, value: float) -> str:
        """'<joint> at its upper limit <value> <unit>' for moving joint i."""
        side = "upper" if value >= self.upper[i] - _LIMIT_MARGIN else "lower"
        return f"{self.moving[i]} at its {side} limit {value:.4g} {self.units[i]}"


def _damped_step(
    A: NDArray[np.float64], e: NDArray[np.float64], lam2: float
) -> NDArray[np.float64]:
    """The damped least-squares step A^T (A A^T + lam2 I)^-1 e through ``A`` (6, n)."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    return Vt.T @ ((s / (s * s + lam2)) * (U.T @ e))


def _null_projection(A: NDArray[np.float64], z: NDArray[np.float64]) -> NDArray[np.float64]:
    """``z`` (n,) projected on the null space of ``A`` (6, n): (I - A^+ A) z."""
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.count_nonzero(s > _RANK_CUTOFF * s[0])) if s.size and s[0] > 0.0 else 0
    null = Vt[rank:]
    return null.T @ (null @ z)
