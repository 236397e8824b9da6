"""The wrench a rigid load exerts on the wrist sensor while the arm moves, linear in the
load's 10 inertial parameters.

Newton-Euler in the sensor frame s, with pinocchio's spatial vectors: a rigid body of
inertial parameters pi moving with the sensor's spatial velocity v and acceleration a
(gravity included as an acceleration of the base, as RNEA does) needs the wrench
Y(v, a) pi (``pinocchio.frameBodyRegressor``); the sensor reads the opposite, the load's
wrench on it::

    w_s = -Y(v_s, a_s - g_s) pi

At rest this is f = m g_s, tau = m c x g_s: the static model the estimators fit
(``sensing.wrench_model``, the paper's eq. (1)-(2)). ``pi`` is pinocchio's order
(``Inertia.toDynamicParameters``): m (kg), m c (kg m, 3), and the inertia about the
sensor origin in s (kg m^2): I_xx, I_xy, I_yy, I_xz, I_yz, I_zz.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.robot.model import RobotModel

__all__ = [
    "INERTIA_ELEMENTS",
    "inertia_elements",
    "inertia_matrix",
    "inertial_parameters",
    "links_beyond",
    "load_of",
    "sensor_regressor",
    "sensor_regressors",
]

INERTIA_ELEMENTS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
"""A symmetric inertia's six elements in geometry_msgs/Inertia's order: the order of every
vector of them this project gives (estimates, covariances, the Explore result); pi keeps
pinocchio's own (module)."""
_ROWS, _COLUMNS = (0, 0, 0, 1, 1, 2), (0, 1, 2, 1, 2, 2)


def inertia_elements(inertia: ArrayLike) -> NDArray[np.float64]:
    """(6,) ``INERTIA_ELEMENTS`` of the symmetric ``inertia`` (3, 3)."""
    return np.asarray(inertia, dtype=np.float64)[_ROWS, _COLUMNS]


def inertia_matrix(elements: ArrayLike) -> NDArray[np.float64]:
    """(3, 3) the symmetric inertia of its six ``INERTIA_ELEMENTS``."""
    e = np.asarray(elements, dtype=np.float64)
    out = np.zeros((3, 3))
    out[_ROWS, _COLUMNS] = e
    out[_COLUMNS, _ROWS] = e
    return out


def sensor_regressor(
    robot: RobotModel,
    positions: Sequence[float],
    velocities: Sequence[float],
    accelerations: Sequence[float],
) -> NDArray[np.float64]:
    """Y (6, 10) with w_s = Y @ pi: the wrench (N, N m; force first, in the sensor frame,
    about its origin) a rigid load of parameters pi exerts on the sensor at these joint
    positions (rad, m), velocities and accelerations (per s, per s^2), each in
    ``robot.joint_names`` order, under ``robot.gravity``."""
    import pinocchio

    model, data = robot.model, robot.data
    q = robot._configuration(positions)
    v, a = np.zeros(model.nv), np.zeros(model.nv)
    for at, dq, ddq in zip(robot._velocity_index, velocities, accelerations, strict=True):
        v[at], a[at] = dq, ddq
    pinocchio.framesForwardKinematics(model, data, q)
    model.gravity.linear = data.oMf[robot._base_id].rotation @ robot.gravity  # in the root
    pinocchio.rnea(model, data, q, v, a)
    return -pinocchio.frameBodyRegressor(model, data, robot._sensor_id)


def sensor_regressors(
    robot: RobotModel,
    positions: ArrayLike,
    velocities: ArrayLike,
    accelerations: ArrayLike,
) -> NDArray[np.float64]:
    """(n, 6, 10): ``sensor_regressor`` at each row of ``positions``, ``velocities`` and
    ``accelerations`` (n, joints; ``robot.joint_names`` order), the same numbers: the
    configurations and the velocity vectors are laid out for all rows at once."""
    import pinocchio

    model, data = robot.model, robot.data
    x = [np.asarray(rows, dtype=np.float64) for rows in (positions, velocities, accelerations)]
    n = len(x[0])
    if any(rows.shape != (n, len(robot.joint_names)) for rows in x):
        raise ValueError(
            f"positions, velocities and accelerations must each be (n, "
            f"{len(robot.joint_names)}), got {', '.join(str(rows.shape) for rows in x)}"
        )
    q = np.tile(robot._pin.neutral(model), (n, 1))
    for j, (at, nq) in enumerate(robot._slots):
        if nq == 2:  # (cos, sin), each as ``_configuration`` computes it
            q[:, at] = [np.cos(value) for value in x[0][:, j]]
            q[:, at + 1] = [np.sin(value) for value in x[0][:, j]]
        else:
            q[:, at] = x[0][:, j]
    v, a = np.zeros((n, model.nv)), np.zeros((n, model.nv))
    v[:, robot._velocity_index], a[:, robot._velocity_index] = x[1], x[2]
    # a base frame on the root joint stays where it is: gravity in the root is the same at
    # every row (the frames are placed at the first row, and left at the last as after a
    # call of sensor_regressor; the regressor needs the joints' kinematics alone, rnea's)
    fixed_base = model.frames[robot._base_id].parentJoint == 0
    out = np.empty((n, 6, 10))
    for k in range(n):
        if k in (0, n - 1) or not fixed_base:
            pinocchio.framesForwardKinematics(model, data, q[k])
            model.gravity.linear = data.oMf[robot._base_id].rotation @ robot.gravity
        pinocchio.rnea(model, data, q[k], v[k], a[k])
        out[k] = -pinocchio.frameBodyRegressor(model, data, robot._sensor_id)
    return out


def inertial_parameters(
    mass: float, com: ArrayLike, inertia_at_com: ArrayLike
) -> NDArray[np.float64]:
    """pi (10,): a body of ``mass`` (kg) with its centre of mass at ``com`` (m, sensor
    frame) and inertia ``inertia_at_com`` (3, 3; kg m^2, about the COM, sensor axes)."""
    import pinocchio

    inertia = pinocchio.Inertia(
        float(mass),
        np.asarray(com, dtype=np.float64),
        np.asarray(inertia_at_com, dtype=np.float64),
    )
    return np.asarray(inertia.toDynamicParameters(), dtype=np.float64)


def load_of(pi: ArrayLike) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """(mass kg, COM m, inertia about the COM kg m^2 (3, 3)) of the parameters ``pi``
    (``inertial_parameters``' inverse; ValueError for a mass that is not > 0)."""
    p = np.asarray(pi, dtype=np.float64).reshape(10)
    mass = float(p[0])
    if not mass > 0:
        raise ValueError(f"mass {mass} kg is not > 0")
    com = p[1:4] / mass
    ixx, ixy, iyy, ixz, iyz, izz = p[4:]
    about_origin = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    shift = mass * (np.dot(com, com) * np.eye(3) - np.outer(com, com))  # parallel axes
    return mass, com, about_origin - shift


def links_beyond(urdf: str, link: str) -> NDArray[np.float64]:
    """pi (10,): the inertial parameters of ``link`` and every link the URDF attaches
    beyond it (a hand and its fingers beyond the sensor's link), their joints at zero, in
    ``link``'s frame (the URDF's ``<inertial>``: mass kg, origin m and rpy rad, inertia
    kg m^2 about the COM). ValueError when ``link`` is not a link of the URDF."""
    import xml.etree.ElementTree as ElementTree

    import pinocchio

    root = ElementTree.fromstring(urdf)
    links = {e.get("name"): e for e in root.findall("link")}
    if link not in links:
        raise ValueError(f"{link!r} is not a link of the URDF")
    children: dict[str, list[ElementTree.Element]] = {}
    for joint in root.findall("joint"):  # not a transmission's
        children.setdefault(joint.find("parent").get("link"), []).append(joint)

    def placement(element: ElementTree.Element | None) -> tuple[NDArray, NDArray]:
        """(R, p) of an ``<origin>`` (identity when absent)."""
        if element is None:
            return np.eye(3), np.zeros(3)
        xyz = np.array([float(v) for v in element.get("xyz", "0 0 0").split()])
        rpy = [float(v) for v in element.get("rpy", "0 0 0").split()]
        return np.asarray(pinocchio.rpy.rpyToMatrix(*rpy)), xyz

    total = np.zeros(10)
    stack = [(link, np.eye(3), np.zeros(3))]  # each link's pose in ``link``'s frame
    while stack:
        name, rotation, origin = stack.pop()
        inertial = links[name].find("inertial")
        if inertial is not None and inertial.find("mass") is not None:
            r, p = placement(inertial.find("origin"))
            e = inertial.find("inertia")
            ixx, ixy, ixz, iyy, iyz, izz = (float(e.get(k, 0.0)) for k in INERTIA_ELEMENTS)
            at_com = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            turn = rotation @ r
            mass = float(inertial.find("mass").get("value"))
            total += inertial_parameters(mass, origin + rotation @ p, turn @ at_com @ turn.T)
        for joint in children.get(name, []):
            r, p = placement(joint.find("origin"))
            stack.append((joint.find("child").get("link"), rotation @ r, origin + rotation @ p))
    return total
