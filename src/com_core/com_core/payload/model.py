"""What compensates a wrist F/T sensor's readings for the payload it holds.

A ``Payload`` is the kinematic fit of an exploration (``known_gravity``) kept for use:
the object's mass and COM with their covariance, the hand's mass and COM, the sensor's
bias (its zero) and mounting, the base's tilt and gravity, and the frames they are in.
At an orientation R = R_base_sensor of the URDF's sensor frame (``kinematics``) it
predicts what the sensor reads when nothing touches the load (docs/design.md,
Conventions: the wrench the load exerts on the sensor, in the sensor frame):

    g_s = R(mount)^T R^T R(base_tilt) g                               (m/s^2)
    w   = bias + [(m_h + m_o) g_s ; (m_h p_h + m_o p_o) x g_s]        (N, N m)

and ``compensate`` subtracts it from a reading: what is left is the contact wrench.
The files that carry a payload to other programs: ``com_core.payload.files``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.known_gravity import _rotation
from com_core.estimation.runs.solution import Solution
from com_core.robot.model import DEFAULT_GRAVITY, RobotModel
from com_core.sensing.noise import NoiseModel
from com_core.sensing.wrench_model import gravity_in_sensor, skew

__all__ = [
    "Payload",
    "PayloadError",
    "compensate",
    "payload_from_solution",
    "payload_gravity",
    "payload_wrench",
]


class PayloadError(ValueError):
    """A payload that cannot serve: a field out of range, a file that does not parse or
    lacks a field, another frame or hand than expected, a solution without a kinematic
    fit. ``field`` names the field (None: the payload as a whole), ``source`` the file."""

    def __init__(self, problem: str, field: str | None = None, source: str | None = None):
        self.problem, self.field, self.source = problem, field, source
        text = problem if field is None else f"field {field!r} {problem}"
        super().__init__(text if source is None else f"{source}: {text}")


@dataclass(frozen=True, kw_only=True, eq=False)
class Payload:
    """What compensates a sensor's readings for a held payload; in the sensor frame (the
    axes of the wrenches, ``frame``) unless stated.

    Attributes
    ----------
    mass : kg, the object.
    com : (3,), m, the object's COM.
    cov : (4, 4), covariance of (mass, com_x, com_y, com_z); kg, m.
    hand_mass : kg; hand_com : (3,), m: the hand (all beyond the sensor but the object).
    bias : (6,), N and N m: the sensor's zero (fx, fy, fz, tx, ty, tz) at ``time``.
    mount : (3,), rad, a rotation vector: the sensor's axes in its URDF frame are
        R(mount); zeros when not fitted.
    base_tilt : (3,), rad, a rotation vector in the base frame: the base's gravity is
        R(base_tilt) gravity; zeros when not fitted.
    gravity : (3,), m/s^2 in the base frame, as the robot model has it.
    frame : the wrenches' frame_id (e.g. 'ft_sensor').
    sensor_frame : the sensor's URDF frame (e.g. 'panda_hand'); base_frame : the URDF's
        base frame (e.g. 'panda_link0'); rotations given to this module are
        R_base_sensor between the two.
    information : the information model of the fit (e.g. 'kinematics+mount').
    time : ISO 8601 (UTC) of the estimate; '' unknown.
    hand_id : names the hand the payload was held by; '' unknown.
    noise : the sensor's noise the estimate learnt (``com_core.sensing.noise``); None unknown.
    inertia, hand_inertia : (3, 3), kg m^2, the object's and the hand's inertia about
        their own COMs (an exploration in motion); None not estimated (the object's: or
        not identified, a point mass at its COM). With the hand's, the compensation
        removes the inertial wrench in motion too (``compensation``).
    delay : s, how much later the wrenches are stamped than the joint states of the same
        instant (an exploration in motion estimates it; 0 unknown).

    Keyword arguments only; arrays are kept as read-only copies, and what the compensation
    needs of them (R(mount), R(base_tilt) g, the wrench per unit gravity) is computed
    once here. Raises PayloadError naming the field when a value is not finite or has
    another shape, the object's mass or the hand's and the object's together is not
    positive, a variance is negative, gravity is zero, a frame or the information is
    empty, or the time is not ISO 8601.
    """

    mass: float
    com: NDArray[np.float64]
    cov: NDArray[np.float64]
    hand_mass: float
    hand_com: NDArray[np.float64]
    bias: NDArray[np.float64]
    mount: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    base_tilt: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    gravity: NDArray[np.float64] = field(default_factory=lambda: np.array(DEFAULT_GRAVITY))
    frame: str
    sensor_frame: str
    base_frame: str
    information: str
    time: str = ""
    hand_id: str = ""
    noise: NoiseModel | None = None
    inertia: NDArray[np.float64] | None = None
    hand_inertia: NDArray[np.float64] | None = None
    delay: float = 0.0
    _mount_rotation: NDArray[np.float64] = field(init=False, repr=False)
    _base_gravity: NDArray[np.float64] = field(init=False, repr=False)
    _wrench_map: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name, shape in (
            ("com", (3,)),
            ("cov", (4, 4)),
            ("hand_com", (3,)),
            ("bias", (6,)),
            ("mount", (3,)),
            ("base_tilt", (3,)),
            ("gravity", (3,)),
        ):
            object.__setattr__(self, name, _finite_array(getattr(self, name), shape, name))
        for name in ("inertia", "hand_inertia"):
            if getattr(self, name) is not None:
                value = _finite_array(getattr(self, name), (3, 3), name)
                if not np.allclose(value, value.T, rtol=1e-9, atol=1e-15):
                    raise PayloadError(f"must be symmetric, got {value.tolist()}", name)
                object.__setattr__(self, name, value)
        for name in ("mass", "hand_mass", "delay"):
            object.__setattr__(self, name, _finite_number(getattr(self, name), name))
        self._check_values()
        mount = _rotation(self.mount)
        base_gravity = _rotation(self.base_tilt) @ self.gravity
        object.__setattr__(self, "_mount_rotation", _frozen(mount))
        object.__setattr__(self, "_base_gravity", _frozen(base_gravity))
        object.__setattr__(self, "_wrench_map", _frozen(self._gravity_to_wrench()))

    def _check_values(self) -> None:
        """The checks beyond finite values of the right shape."""
        if not self.mass > 0:
            raise PayloadError(f"must be > 0 kg, got {self.mass!r}", "mass")
        if not self.hand_mass + self.mass > 0:
            raise PayloadError(
                f"must leave the hand and the object a positive mass, got {self.hand_mass!r} "
                f"with an object of {self.mass!r} kg",
                "hand_mass",
            )
        if np.any(np.diag(self.cov) < 0):
            raise PayloadError(f"must have a diagonal >= 0, got {np.diag(self.cov)}", "cov")
        if not np.linalg.norm(self.gravity) > 0:
            raise PayloadError("must not be zero", "gravity")
        for name in ("frame", "sensor_frame", "base_frame", "information"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                value = getattr(self, name)
                raise PayloadError(f"must be a non-empty string, got {value!r}", name)
        if not isinstance(self.hand_id, str):
            raise PayloadError(f"must be a string, got {self.hand_id!r}", "hand_id")
        if not isinstance(self.time, str) or (self.time and not _is_iso_time(self.time)):
            raise PayloadError(f"must be an ISO 8601 time or '', got {self.time!r}", "time")

    def _gravity_to_wrench(self) -> NDArray[np.float64]:
        """(3, 6) W with g_s^T W the wrench of hand and object at gravity g_s (m/s^2,
        sensor frame) as a row: f = M g_s, tau = c x g_s = [c]_x g_s, with M the total
        mass (kg) and c the total first moment of mass (kg m)."""
        return np.hstack([self.total_mass * np.eye(3), skew(self.first_moment).T])

    @property
    def in_motion(self) -> bool:
        """The hand's inertia is known (an exploration in motion): the inertial wrench can
        be compensated too, the object's with its inertia or as a point mass at its COM."""
        return self.hand_inertia is not None

    @property
    def total_mass(self) -> float:
        """kg: the hand and the object."""
        return self.hand_mass + self.mass

    @property
    def first_moment(self) -> NDArray[np.float64]:
        """(3,), kg m, sensor frame: m_h p_h + m_o p_o."""
        return self.hand_mass * self.hand_com + self.mass * self.com

    @property
    def total_com(self) -> NDArray[np.float64]:
        """(3,), m, sensor frame: the COM of the hand and the object together."""
        return self.first_moment / self.total_mass

    @property
    def sigma_mass(self) -> float:
        """kg."""
        return math.sqrt(self.cov[0, 0])

    @property
    def sigma_com(self) -> NDArray[np.float64]:
        """(3,), m."""
        return np.sqrt(np.diag(self.cov)[1:])


def _frozen(array: NDArray[np.float64]) -> NDArray[np.float64]:
    """``array`` made read-only, so a frozen Payload's numbers stay as validated."""
    array.flags.writeable = False
    return array


def _finite_array(value: ArrayLike, shape: tuple[int, ...], name: str) -> NDArray[np.float64]:
    """``value`` as a read-only float64 copy of ``shape``; PayloadError naming ``name``."""
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise PayloadError(f"must be numbers of shape {shape}, got {value!r}", name) from None
    if array.shape != shape:
        raise PayloadError(f"must have shape {shape}, got {array.shape}", name)
    if not np.all(np.isfinite(array)):
        raise PayloadError(f"must be finite, got {array.tolist()}", name)
    return _frozen(array)


def _finite_number(value: object, name: str) -> float:
    """``value`` as a finite float; PayloadError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise PayloadError(f"must be a number, got {value!r}", name)
    if not math.isfinite(value):
        raise PayloadError(f"must be finite, got {value!r}", name)
    return float(value)


def _is_iso_time(text: str) -> bool:
    try:
        datetime.fromisoformat(text)
    except ValueError:
        return False
    return True


# --- compensation ---------------------------------------------------------------------


def payload_gravity(payload: Payload, rotations: ArrayLike) -> NDArray[np.float64]:
    """g_s = R(mount)^T R^T R(base_tilt) g: gravity in the sensor frame (the wrenches'
    axes) as the payload has the sensor's mounting and the base's tilt, m/s^2: the
    gravity of the tilted base in the URDF's sensor frame
    (``wrench_model.gravity_in_sensor``), turned into the sensor's axes.

    rotations : R_base_sensor of the URDF's sensor frame, (3, 3) or (n, 3, 3).
    Returns (3,) or (n, 3).
    """
    urdf_frame = gravity_in_sensor(rotations, payload._base_gravity)
    return urdf_frame @ payload._mount_rotation  # as rows: R(mount)^T g, one or a stack


def payload_wrench(payload: Payload, rotations: ArrayLike) -> NDArray[np.float64]:
    """What the sensor reads with nothing touching the load: the bias plus the wrench of
    the hand and the object, f = (m_h + m_o) g_s, tau = (m_h p_h + m_o p_o) x g_s.

    rotations : R_base_sensor (3, 3) or (n, 3, 3) (``payload_gravity``).
    Returns (6,) or (n, 6); N and N m; sensor frame.
    """
    return payload_gravity(payload, rotations) @ payload._wrench_map + payload.bias


def compensate(payload: Payload, wrenches: ArrayLike, rotations: ArrayLike) -> NDArray[np.float64]:
    """The contact wrench: readings ``wrenches`` (6,) or (n, 6) (N, N m, sensor frame)
    less ``payload_wrench`` at ``rotations`` (3, 3) or (n, 3, 3); one rotation serves
    every reading."""
    return np.asarray(wrenches, dtype=np.float64) - payload_wrench(payload, rotations)


# --- from an exploration --------------------------------------------------------------


def _utc_now() -> str:
    """The current time, ISO 8601 UTC to the second (e.g. '2026-11-23T05:01:41Z')."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def payload_from_solution(
    solution: Solution,
    robot: RobotModel,
    *,
    frame: str,
    hand_id: str,
    time: str | None = None,
) -> Payload:
    """The payload of a solved exploration with kinematic information: the object from
    the fit's estimate, the hand, this run's bias at its latest window
    (``KinematicFit.latest_bias``), the mounting and the tilt when fitted; the robot's
    gravity and frames. ``frame`` is the wrenches'
    frame_id, ``time`` ISO 8601 (None: now, UTC).

    Raises PayloadError with the reason when the solution has no usable estimate, no
    kinematic fit (the wrenches alone model no bias nor hand), or a fit without
    empty-hand windows (no bias nor hand either).
    """
    if solution.estimate is None or not solution.usable:
        raise PayloadError(
            f"no usable estimate ({solution.status}: {solution.reason}): nothing to save"
        )
    if solution.motion is not None:
        return _payload_in_motion(solution, robot, frame, hand_id, time)
    fit = solution.fit
    if fit is None:
        raise PayloadError(
            f"the information {solution.information!r} has no kinematic fit, so no model of "
            "the sensor's bias nor of the hand to compensate with; explore with the "
            "'kinematics' or 'kinematics+mount' information"
        )
    if fit.hand is None or len(fit.bias) == 0:
        raise PayloadError(
            "the kinematic fit had no empty-hand window with joint positions, so no model of "
            "the sensor's bias nor of the hand to compensate with"
        )
    return Payload(
        hand_mass=fit.hand.mass,
        hand_com=fit.hand.com,
        bias=fit.latest_bias(),
        mount=np.zeros(3) if fit.mount is None else fit.mount,
        base_tilt=np.zeros(3) if fit.base_tilt is None else fit.base_tilt,
        **_of_solution(solution, robot, frame, hand_id, time),
    )


def _of_solution(
    solution: Solution, robot: RobotModel, frame: str, hand_id: str, time: str | None
) -> dict:
    """What a payload takes of any solution: the object's estimate, the robot's gravity
    and frames, the information, the time (None: now), the hand, the noise."""
    estimate = solution.estimate
    assert estimate is not None
    return {
        "mass": estimate.mass,
        "com": estimate.com,
        "cov": estimate.cov,
        "gravity": robot.gravity,
        "frame": frame,
        "sensor_frame": robot.sensor_frame,
        "base_frame": robot.base_frame,
        "information": solution.information,
        "time": _utc_now() if time is None else time,
        "hand_id": hand_id,
        "noise": solution.noise,
    }


def _payload_in_motion(
    solution: Solution, robot: RobotModel, frame: str, hand_id: str, time: str | None
) -> Payload:
    """``payload_from_solution`` of an exploration in motion: the object's and the empty
    hand's mass, COM and inertia from their motion fits, the bias of the object's motion;
    no mounting nor tilt fitted."""
    result = solution.motion
    assert result is not None
    hand_mass, hand_com, hand_inertia = result.hand.load()
    return Payload(
        hand_mass=hand_mass,
        hand_com=hand_com,
        bias=result.object.bias,
        **_of_solution(solution, robot, frame, hand_id, time),
        inertia=result.inertia if result.inertia_identified else None,
        hand_inertia=hand_inertia,
        delay=result.object.delay,
    )
