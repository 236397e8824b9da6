"""Graspable test objects: box, cylinder and mug, with a chosen mass and centre of mass.

Every shape has its own frame ``object``: origin at the geometric centre of its body (for the
mug: the centre of the cup, handle excluded), z along the height, y the axis the fingers close
along when it stands on the stand. The centre of mass (COM) is the geometric centre plus
``com_offset`` (m, object frame); pybullet places the body's inertial frame there through
``createMultiBody(baseInertialFramePosition=...)``, so ``getBasePositionAndOrientation``
returns the COM, not the geometric centre. Only the inertial frame moves: the body (and so what
the fingers close on) is where it would be without an offset.

The object stands on a stand, on its bottom face, from start-up until the fingers close on it,
so it can be grasped only if it stays upright there: its COM must lie above that footprint.
``holdable_com_range`` gives the COM offsets the simulator accepts for each shape.

A reference weight (a calibration in place) is an object whose mass the user states: its
true mass is off that nominal within its class's tolerance (``reference_weight_mass``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.runs.settings import REFERENCE_MASS_TOLERANCE
from wrench_sim.sensor import random_streams

__all__ = [
    "SHAPES",
    "ComRange",
    "ObjectSpec",
    "ShapeGeometry",
    "com_offset_problem",
    "create_object_body",
    "holdable_com_range",
    "object_spec",
    "random_com_offset",
    "reference_weight_mass",
]

_MUG_RADIUS = 0.028
_MUG_HEIGHT = 0.09
_HANDLE_BAR = (0.004, 0.006, 0.025)  # half extents, m
_HANDLE_ARM = (0.009, 0.006, 0.004)
_LATERAL_FRICTION = 1.0
_SPINNING_FRICTION = 0.001
_FOOTPRINT_FRACTION = 0.8  # of the footprint's half width / radius the COM may be off-centre


@dataclass(frozen=True)
class ShapeGeometry:
    """Size of a shape's body, m.

    Attributes
    ----------
    half_extents : shape (3,); m; half size of the body's bounding box in the object frame
        (the mug's handle excluded).
    grasp_half_width : m; half the width the fingers close on (along object y).
    round : the body stands on a disc of radius ``half_extents[0]`` (cylinder, mug) rather
        than on a rectangle of half extents ``half_extents[:2]`` (box).
    """

    half_extents: tuple[float, float, float]
    grasp_half_width: float
    round: bool = False

    @property
    def height(self) -> float:
        """Height of the body, m."""
        return 2.0 * self.half_extents[2]


SHAPES: dict[str, ShapeGeometry] = {
    "box": ShapeGeometry((0.025, 0.025, 0.04), 0.025),
    "cylinder": ShapeGeometry((0.025, 0.025, 0.04), 0.025, round=True),
    "mug": ShapeGeometry((_MUG_RADIUS, _MUG_RADIUS, _MUG_HEIGHT / 2.0), _MUG_RADIUS, round=True),
}
"""The shapes the simulator offers, by name."""


@dataclass(frozen=True)
class ObjectSpec:
    """A test object: shape, mass and where its COM lies.

    Attributes
    ----------
    shape : one of ``SHAPES``.
    mass : kg, > 0.
    com_offset : shape (3,); m; COM minus geometric centre, object frame.
    """

    shape: str
    mass: float
    com_offset: tuple[float, float, float]

    @property
    def geometry(self) -> ShapeGeometry:
        """The shape's size."""
        return SHAPES[self.shape]


@dataclass(frozen=True)
class ComRange:
    """The COM offsets (COM minus geometric centre, m, object frame) the simulator can hold.

    Attributes
    ----------
    shape : one of ``SHAPES``.
    half_xy : m; bound of the horizontal offset: |x| <= half_xy and |y| <= half_xy, or for a
        round shape hypot(x, y) <= half_xy.
    half_z : m; bound of the vertical offset, |z| <= half_z.
    round : the horizontal bound is a disc (cylinder, mug) rather than a square (box).
    """

    shape: str
    half_xy: float
    half_z: float
    round: bool

    def contains(self, offset: ArrayLike, tolerance: float = 1e-12) -> bool:
        """Whether ``offset`` (3,), m, object frame, lies in the range (``tolerance`` m)."""
        x, y, z = np.asarray(offset, dtype=np.float64)
        horizontal = np.hypot(x, y) if self.round else max(abs(x), abs(y))
        return bool(horizontal <= self.half_xy + tolerance and abs(z) <= self.half_z + tolerance)

    def __str__(self) -> str:
        horizontal = "hypot(x, y)" if self.round else "|x|, |y|"
        return f"{horizontal} <= {self.half_xy:.4f} m and |z| <= {self.half_z:.4f} m"


def holdable_com_range(shape: str) -> ComRange:
    """The COM offsets the simulator can hold for ``shape``, the same in both grasp modes.

    Only the inertial frame moves with the offset (``create_object_body``): whatever the
    offset, the body stands centred on the stand between the open pads (Panda 0.04 m, xArm6
    0.0415 m from the centre, against a half width of 0.025 m, mug 0.028 m) and the pads
    (``gripper``) close on it 0.01-0.035 m below its top, so the grasp reaches every
    offset. What limits the offset is the stand: the object rests there on its bottom face
    until the fingers close, and it stays upright only while its COM lies above that
    footprint, the
    box's 0.05 m square, the cylinder's 0.025 m and the mug's 0.028 m radius disc (the handle
    ends 0.02 m above the bottom). Bullet rocks it over a little inside the edge (16
    directions at the bottom, middle and top of the body: the cylinder and mug stay upright
    at 0.9 of the radius and tip over at 0.95; the box stays up at 0.95 and tips over at the
    edge), so the range keeps 0.8 of the footprint: box |x|, |y| <= 0.02 m, cylinder
    hypot(x, y) <= 0.02 m, mug hypot(x, y) <= 0.0224 m. Along z the footprint sets no limit:
    the range is the body's half height (0.04 m, mug 0.045 m).

    In friction mode a grasped object can still slip or drop when gravity's torque about the
    finger pads exceeds what ``grip_force`` holds; that depends on the mass and grip force
    as well as the offset, and is not refused here.

    Raises ValueError for an unknown shape.
    """
    if shape not in SHAPES:
        raise ValueError(f"object must be one of {sorted(SHAPES)}, got {shape!r}")
    geometry = SHAPES[shape]
    footprint = min(geometry.half_extents[0], geometry.half_extents[1])
    return ComRange(
        shape, _FOOTPRINT_FRACTION * footprint, geometry.half_extents[2], geometry.round
    )


def com_offset_problem(shape: str, offset: ArrayLike) -> str | None:
    """Why the simulator cannot hold ``shape`` with COM offset ``offset``, or None.

    Parameters
    ----------
    shape : one of ``SHAPES``.
    offset : shape (3,); m; COM minus geometric centre, object frame.
    """
    values = np.asarray(offset, dtype=np.float64)
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        return f"object_com_offset must be 3 finite values (m), got {offset}"
    reach = holdable_com_range(shape)
    if reach.contains(values):
        return None
    return (
        f"object_com_offset {values.tolist()} m is outside what the sim can hold for the "
        f"{shape}: {reach} (object frame); the {shape} stands on its "
        f"{'round ' if reach.round else ''}base until grasped and tips over when its COM "
        "is near or beyond the base's edge"
    )


def random_com_offset(shape: str, rng: np.random.Generator) -> NDArray[np.float64]:
    """Draw a COM offset uniformly inside the shape's inner half.

    The offset is uniform in the box of half the body's half extents, which lies inside
    ``holdable_com_range(shape)`` for every shape (its corners are at 0.71 of the footprint's
    half width or radius, the range reaches 0.8).

    Returns
    -------
    shape (3,); m; object frame.
    """
    half = 0.5 * np.asarray(SHAPES[shape].half_extents)
    return rng.uniform(-half, half)


def object_spec(
    shape: str, mass: float, com_offset: ArrayLike | None, rng: np.random.Generator
) -> ObjectSpec:
    """Validate an object's description, drawing the COM offset from ``rng`` if not given.

    Raises ValueError naming the bad value; for a COM offset outside
    ``holdable_com_range(shape)`` it states the range.
    """
    if shape not in SHAPES:
        raise ValueError(f"object must be one of {sorted(SHAPES)}, got {shape!r}")
    if not (np.isfinite(mass) and mass > 0.0):
        raise ValueError(f"object_mass must be a finite number > 0 kg, got {mass}")
    if com_offset is None or len(np.atleast_1d(com_offset)) == 0:
        offset = random_com_offset(shape, rng)
    else:
        problem = com_offset_problem(shape, com_offset)
        if problem is not None:
            raise ValueError(problem)
        offset = np.asarray(com_offset, dtype=np.float64)
    return ObjectSpec(shape, float(mass), (float(offset[0]), float(offset[1]), float(offset[2])))


def create_object_body(client, spec: ObjectSpec, centre_world: ArrayLike) -> int:
    """Create the object in pybullet, upright, its geometric centre at ``centre_world`` (m).

    Parameters
    ----------
    client : a ``pybullet_utils.bullet_client.BulletClient``.
    spec : the object.
    centre_world : shape (3,); m; world frame.

    Returns
    -------
    The pybullet body id.
    """
    geometry = spec.geometry
    colour = [0.85, 0.35, 0.2, 1.0]
    if spec.shape == "box":
        collision = client.createCollisionShape(client.GEOM_BOX, halfExtents=geometry.half_extents)
        visual = client.createVisualShape(
            client.GEOM_BOX, halfExtents=geometry.half_extents, rgbaColor=colour
        )
    elif spec.shape == "cylinder":
        radius, height = geometry.half_extents[0], geometry.height
        collision = client.createCollisionShape(client.GEOM_CYLINDER, radius=radius, height=height)
        visual = client.createVisualShape(
            client.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=colour
        )
    else:
        collision, visual = _mug_shapes(client)
    body = client.createMultiBody(
        baseMass=spec.mass,
        baseCollisionShapeIndex=collision,
        baseVisualShapeIndex=visual,
        basePosition=list(centre_world),
        baseInertialFramePosition=list(spec.com_offset),
    )
    client.changeVisualShape(body, -1, rgbaColor=colour)
    client.changeDynamics(
        body, -1, lateralFriction=_LATERAL_FRICTION, spinningFriction=_SPINNING_FRICTION
    )
    return body


def _mug_shapes(client) -> tuple[int, int]:
    """Compound collision and visual shapes of a mug: a cup and a handle on its +x side."""
    bar_x = _MUG_RADIUS + 2.0 * _HANDLE_ARM[0] - _HANDLE_BAR[0]
    arm_x = _MUG_RADIUS + _HANDLE_ARM[0] - 0.002
    arm_z = _HANDLE_BAR[2] - _HANDLE_ARM[2]
    parts = [
        (client.GEOM_CYLINDER, (0.0, 0.0, 0.0), None),
        (client.GEOM_BOX, (bar_x, 0.0, 0.0), _HANDLE_BAR),
        (client.GEOM_BOX, (arm_x, 0.0, arm_z), _HANDLE_ARM),
        (client.GEOM_BOX, (arm_x, 0.0, -arm_z), _HANDLE_ARM),
    ]
    types = [kind for kind, _, _ in parts]
    positions = [list(position) for _, position, _ in parts]
    half_extents = [list(half) if half else [0.0, 0.0, 0.0] for _, _, half in parts]
    radii = [_MUG_RADIUS, 0.0, 0.0, 0.0]
    lengths = [_MUG_HEIGHT, 0.0, 0.0, 0.0]
    collision = client.createCollisionShapeArray(
        shapeTypes=types,
        radii=radii,
        halfExtents=half_extents,
        lengths=lengths,
        collisionFramePositions=positions,
    )
    visual = client.createVisualShapeArray(
        shapeTypes=types,
        radii=radii,
        halfExtents=half_extents,
        lengths=lengths,
        visualFramePositions=positions,
    )
    return collision, visual


def reference_weight_mass(nominal: float, seed: int) -> float:
    """The true mass (kg) of a reference weight stated as ``nominal`` kg: off it by an
    error drawn uniformly within its class's tolerance (``REFERENCE_MASS_TOLERANCE`` of
    it, OIML class M1; the estimator's default sigma is that rectangle's), from the
    "reference" stream of ``seed``'s ``random_streams``. No real weight is its nominal."""
    rng = random_streams(seed)["reference"]
    return nominal * (1.0 + REFERENCE_MASS_TOLERANCE * rng.uniform(-1.0, 1.0))
