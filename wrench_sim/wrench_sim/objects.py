"""Graspable test objects: box, cylinder and mug, with a chosen mass and centre of mass.

Every shape has its own frame ``object``: origin at the geometric centre of its body (for the
mug: the centre of the cup, handle excluded), z along the height, y the axis the fingers close
along when it stands on the stand. The centre of mass (COM) is the geometric centre plus
``com_offset`` (m, object frame); pybullet places the body's inertial frame there through
``createMultiBody(baseInertialFramePosition=...)``, so ``getBasePositionAndOrientation``
returns the COM, not the geometric centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "SHAPES",
    "ObjectSpec",
    "ShapeGeometry",
    "create_object_body",
    "object_spec",
    "random_com_offset",
]

_MUG_RADIUS = 0.028
_MUG_HEIGHT = 0.09
_HANDLE_BAR = (0.004, 0.006, 0.025)  # half extents, m
_HANDLE_ARM = (0.009, 0.006, 0.004)
_LATERAL_FRICTION = 1.0
_SPINNING_FRICTION = 0.001


@dataclass(frozen=True)
class ShapeGeometry:
    """Size of a shape's body, m.

    Attributes
    ----------
    half_extents : shape (3,); m; half size of the body's bounding box in the object frame
        (the mug's handle excluded).
    grasp_half_width : m; half the width the fingers close on (along object y).
    """

    half_extents: tuple[float, float, float]
    grasp_half_width: float

    @property
    def height(self) -> float:
        """Height of the body, m."""
        return 2.0 * self.half_extents[2]


SHAPES: dict[str, ShapeGeometry] = {
    "box": ShapeGeometry((0.025, 0.025, 0.04), 0.025),
    "cylinder": ShapeGeometry((0.025, 0.025, 0.04), 0.025),
    "mug": ShapeGeometry((_MUG_RADIUS, _MUG_RADIUS, _MUG_HEIGHT / 2.0), _MUG_RADIUS),
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


def random_com_offset(shape: str, rng: np.random.Generator) -> NDArray[np.float64]:
    """Draw a COM offset uniformly inside the shape's inner half.

    The offset is uniform in the box of half the body's half extents, which lies inside the
    body for every shape (for round bodies: its corners are at 0.71 of the radius).

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

    Raises ValueError naming the bad value.
    """
    if shape not in SHAPES:
        raise ValueError(f"object must be one of {sorted(SHAPES)}, got {shape!r}")
    if not (np.isfinite(mass) and mass > 0.0):
        raise ValueError(f"object_mass must be a finite number > 0 kg, got {mass}")
    if com_offset is None or len(np.atleast_1d(com_offset)) == 0:
        offset = random_com_offset(shape, rng)
    else:
        offset = np.asarray(com_offset, dtype=np.float64)
        if offset.shape != (3,) or not np.all(np.isfinite(offset)):
            raise ValueError(f"object_com_offset must be 3 finite values (m), got {com_offset}")
        if np.any(np.abs(offset) > np.asarray(SHAPES[shape].half_extents)):
            raise ValueError(
                f"object_com_offset {offset.tolist()} m lies outside the {shape}'s body "
                f"(half extents {list(SHAPES[shape].half_extents)} m)"
            )
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
