"""The gripper, in either grasp mode.

``rigid`` (``RigidGripper``): the gripper's joints are fixed open in the loaded URDF
(``wrench_sim.urdf``) and the gripper is virtual: its position (the gripper command's units,
m or rad) runs between ``gripper_open`` and ``gripper_closed`` in 0.4 s, each pad's distance
from the grasp centre is linear in it (``finger_gap``), and the pads span 0.03 to 0.005 m
before the grasp centre along the sensor's z. An object between the pads is grasped
(attached to the sensor's link by a fixed constraint) when the pads reach its
``grasp_half_width`` and released when they open 1 mm beyond it. ``/joint_states`` reports
each gripper joint at the virtual position.

``friction`` (``FrictionGripper``): the gripper is simulated: two prismatic fingers under
position control at ``grip_force``, which a gear constraint couples as the URDF's mimic does
(the Panda's hand); the object is held while both fingers touch it, and may slip.

A command's ``max_effort`` (N; 0: none) caps the force the fingers push with (friction: each
finger's force limit, at most ``grip_force``; rigid: the effort reported while the pads
press the object). ``GripperGoal`` judges a GripperCommand goal as ros2_control's gripper
action controller does: reached within ``GOAL_TOLERANCE`` of the stroke, stalled when the
fingers stay slower than ``STALL_SPEED`` for ``STALL_TIME`` short of the goal.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pybullet
from numpy.typing import NDArray

from wrench_sim.config import TIME_STEP
from wrench_sim.scene import Scene

__all__ = [
    "GOAL_TOLERANCE",
    "STALL_SPEED",
    "STALL_TIME",
    "FrictionGripper",
    "Gripper",
    "GripperGoal",
    "GripperOutcome",
    "RigidGripper",
]

_PAD_SPAN = (-0.03, -0.005)  # m along sensor z from the grasp centre: the finger pads
_GRIPPER_STROKE_TIME = 0.4  # s from open to closed
_GEAR_FORCE = 50.0  # N
_GRASP_CENTRE_TOLERANCE = 0.02  # m; object centre off the grasp centre across sensor z
_RELEASE_GAP = 1e-3  # m; pads this far beyond the object's half width release it
GOAL_TOLERANCE = 0.02
"""Of the stroke (|gripper_closed - gripper_open|): a goal this near is reached (0.8 mm on the
Panda's fingers)."""
STALL_SPEED = 0.01
"""Of the stroke per s: fingers slower than this are still (0.4 mm/s on the Panda's)."""
STALL_TIME = 0.1
"""s (sim): fingers still this long short of their goal have stalled (on an object)."""


@dataclass(frozen=True)
class GripperOutcome:
    """A GripperCommand goal's state: ``position`` (the command's units, m or rad),
    ``effort`` (N or N m), ``stalled`` and ``reached_goal``."""

    position: float
    effort: float
    stalled: bool
    reached_goal: bool


class GripperGoal:
    """One goal's progress toward ``target`` (m or rad) for a gripper of ``stroke`` (its
    |closed - open|, same units), from sim time ``start`` (s): ``update`` with the gripper's
    state at each check says whether it has ended (reached or stalled)."""

    def __init__(self, target: float, stroke: float, start: float) -> None:
        self.target = target
        self._tolerance = GOAL_TOLERANCE * abs(stroke)
        self._still = STALL_SPEED * abs(stroke)
        self._moved = start  # s: the last time the fingers moved
        self.outcome = GripperOutcome(float("nan"), 0.0, False, False)

    def update(self, time: float, position: float, speed: float, effort: float) -> bool:
        """The gripper at sim time ``time`` (s): ``position`` (m or rad), ``speed`` (m/s or
        rad/s), ``effort`` (N or N m); True once the goal has ended (``outcome`` says how)."""
        reached = abs(position - self.target) <= self._tolerance
        if abs(speed) > self._still:
            self._moved = time
        stalled = not reached and time - self._moved >= STALL_TIME
        self.outcome = GripperOutcome(position, effort, stalled, reached)
        return reached or stalled


class Gripper:
    """What both grasp modes share: the command and whether the object is held.

    ``event`` records a line for the user (``ArmWorld.events``).
    """

    def __init__(self, scene: Scene, event: Callable[[str], None]) -> None:
        self._scene = scene
        self._event = event
        self.held = False
        """The object is in the gripper."""
        self._closure_target = 0.0  # 0 open .. 1 closed
        self._force = scene.config.grip_force  # N the fingers push with

    def command(self, position: float, max_effort: float = 0.0) -> None:
        """Move the gripper to ``position``, in its command's units (m or rad): from the
        configuration's ``gripper_open`` to ``gripper_closed``, pushing with at most
        ``max_effort`` N (0: ``grip_force``). Raises ValueError for a value outside that
        range or not finite, or a negative or non-finite ``max_effort``."""
        robot = self._scene.config.robot
        low, high = sorted((robot.gripper_open, robot.gripper_closed))
        if not (np.isfinite(position) and low <= position <= high):
            raise ValueError(
                f"gripper position must be in [{low}, {high}] (open {robot.gripper_open}, "
                f"closed {robot.gripper_closed}), got {position}"
            )
        if not (np.isfinite(max_effort) and max_effort >= 0.0):
            raise ValueError(f"max_effort must be >= 0 N (0: no limit), got {max_effort}")
        grip_force = self._scene.config.grip_force
        self._force = min(grip_force, max_effort) if max_effort > 0.0 else grip_force
        self._closure_target = robot.gripper_closed_fraction(float(position))

    def state(self) -> tuple[float, float, float]:
        """The gripper's position (m or rad; its joints' mean), speed (m/s or rad/s) and
        effort (N: what the fingers push with)."""
        positions, velocities, efforts = self.joint_state()
        return (float(np.mean(positions)), float(np.mean(velocities)),
                float(np.mean(np.abs(efforts))))  # fmt: skip

    def step(self) -> None:
        """Before each physics step."""

    def check_contact(self) -> None:
        """At each bookkeeping step (every 10 ms)."""

    def joint_state(self) -> tuple[list[float], list[float], list[float]]:
        """Positions (m or rad), velocities and efforts (N or N m) of ``gripper_joints``."""
        raise NotImplementedError


class RigidGripper(Gripper):
    """The virtual gripper of ``rigid`` mode (see module).

    ``on_grasp`` is called when the object is grasped, before the event is recorded.
    """

    def __init__(
        self, scene: Scene, event: Callable[[str], None], on_grasp: Callable[[], None]
    ) -> None:
        super().__init__(scene, event)
        self._on_grasp = on_grasp
        self._constraint: int | None = None
        self._closure = 0.0
        self._closure_step = TIME_STEP / _GRIPPER_STROKE_TIME
        gap_open, gap_closed = scene.config.robot.finger_gap
        self._held_closure = (gap_open - scene.object.geometry.grasp_half_width) / (
            gap_open - gap_closed
        )  # the pads on the object

    def step(self) -> None:
        """Move the virtual gripper one step toward its command: grasp when its pads reach
        the object, release when they open beyond it."""
        if self._closure == self._closure_target:
            return
        step, target, closure = self._closure_step, self._closure_target, self._closure
        closure = min(target, closure + step) if target > closure else max(target, closure - step)
        width = self._scene.object.geometry.grasp_half_width
        if self.held:
            if self._gap(closure) > width + _RELEASE_GAP:
                self._release()
            else:
                closure = min(closure, self._held_closure)
        elif (
            self._gap(self._closure) > width >= self._gap(closure) and self._object_between_pads()
        ):
            closure = self._held_closure
            self.attach()
        self._closure = closure

    def joint_state(self) -> tuple[list[float], list[float], list[float]]:
        """Each gripper joint at the virtual position (stopping where the pads meet the object
        when it is grasped), its speed while it moves, and as effort the force the pads
        press a grasped object with (N; else 0)."""
        robot = self._scene.config.robot
        stroke = robot.gripper_closed - robot.gripper_open
        count = len(robot.gripper_joints)
        target, closure = self._closure_target, self._closure
        on_object = self.held and closure == self._held_closure < target
        speed = float(np.sign(target - closure)) * stroke / _GRIPPER_STROKE_TIME
        positions = [robot.gripper_open + closure * stroke] * count
        velocities = [0.0 if closure == target or on_object else speed] * count
        return positions, velocities, [self._force if on_object else 0.0] * count

    def _gap(self, closure: float) -> float:
        """m; each pad's distance from the grasp centre at ``closure`` (0 open, 1 closed)."""
        gap_open, gap_closed = self._scene.config.robot.finger_gap
        return gap_open + closure * (gap_closed - gap_open)

    def _object_between_pads(self) -> bool:
        centre = self._object_centre_in_sensor() - self._scene.grasp
        z_half = self._scene.object.geometry.half_extents[2]
        return (
            abs(centre[0]) <= _GRASP_CENTRE_TOLERANCE
            and abs(centre[1]) <= _GRASP_CENTRE_TOLERANCE
            and centre[2] - z_half < _PAD_SPAN[1]
            and centre[2] + z_half > _PAD_SPAN[0]
        )

    def _object_centre_in_sensor(self) -> NDArray[np.float64]:
        """m, ``ft_sensor``; the object's geometric centre."""
        scene = self._scene
        origin, R = scene.sensor_pose()
        com_world, orientation = scene.client.getBasePositionAndOrientation(scene.object_body)
        R_object = np.array(scene.client.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        centre_world = np.asarray(com_world) - R_object @ np.asarray(scene.object.com_offset)
        return R.T @ (centre_world - origin)

    def attach(self) -> None:
        """Fix the object to the sensor's link where it is now; a first attach grasps it."""
        scene = self._scene
        c = scene.client
        hand_position, hand_orientation = c.getLinkState(scene.robot_body, scene.sensor)[:2]
        object_position, object_orientation = c.getBasePositionAndOrientation(scene.object_body)
        inverse = c.invertTransform(hand_position, hand_orientation)
        relative = c.multiplyTransforms(*inverse, object_position, object_orientation)
        for link in scene.load_links:
            c.setCollisionFilterPair(scene.robot_body, scene.object_body, link, -1, 0)
        self._constraint = c.createConstraint(
            scene.robot_body,
            scene.sensor,
            scene.object_body,
            -1,
            pybullet.JOINT_FIXED,
            [0.0, 0.0, 0.0],
            parentFramePosition=relative[0],
            childFramePosition=[0.0, 0.0, 0.0],
            parentFrameOrientation=relative[1],
            childFrameOrientation=[0.0, 0.0, 0.0, 1.0],
        )
        if not self.held:
            self.held = True
            self._on_grasp()
            self._event(f"grasped the {scene.object.shape} (rigid constraint)")

    def detach(self) -> None:
        """Remove the fixed constraint of a held object, which stays held (``attach`` it
        again where it has been moved)."""
        assert self._constraint is not None
        self._scene.client.removeConstraint(self._constraint)

    def _release(self) -> None:
        scene = self._scene
        c = scene.client
        if self._constraint is not None:
            c.removeConstraint(self._constraint)
            self._constraint = None
        for link in scene.load_links:
            c.setCollisionFilterPair(scene.robot_body, scene.object_body, link, -1, 1)
        self.held = False
        self._event(f"released the {scene.object.shape}")


class FrictionGripper(Gripper):
    """The simulated two-finger gripper of ``friction`` mode (see module), put open."""

    def __init__(self, scene: Scene, event: Callable[[str], None]) -> None:
        super().__init__(scene, event)
        c, body, fingers = scene.client, scene.robot_body, scene.fingers
        robot = scene.config.robot
        for joint in fingers:
            c.resetJointState(body, joint, robot.gripper_open)
        # The real gripper's fingers are coupled (the URDF's mimic tag, which pybullet
        # ignores): without the gear, both fingers pushing at their force limit would let
        # fingers and object slide together along the finger axis to one finger's limit.
        gear = c.createConstraint(
            body,
            fingers[0],
            body,
            fingers[1],
            pybullet.JOINT_GEAR,
            c.getJointInfo(body, fingers[0])[13],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
        )
        c.changeConstraint(gear, gearRatio=-1.0, erp=0.1, maxForce=_GEAR_FORCE)
        self._drive_fingers(robot.gripper_open)

    def command(self, position: float, max_effort: float = 0.0) -> None:
        """Move both fingers to ``position`` (m per finger), between ``gripper_open`` and
        ``gripper_closed``, at the gripper's speed, each pushing with at most ``max_effort``
        N (0: ``grip_force``; ValueError outside these ranges)."""
        super().command(position, max_effort)
        self._drive_fingers(float(position))

    def check_contact(self) -> None:
        """The object is held while both fingers touch it; record each change."""
        scene = self._scene
        touching = all(
            scene.client.getContactPoints(scene.robot_body, scene.object_body, finger, -1)
            for finger in scene.fingers
        )
        if touching != self.held:
            self.held = touching
            state = "grasped (finger contact)" if touching else "released (no finger contact)"
            self._event(f"{scene.object.shape} {state}")

    def joint_state(self) -> tuple[list[float], list[float], list[float]]:
        """The finger joints' positions (m), velocities (m/s) and efforts (N)."""
        scene = self._scene
        fingers = scene.client.getJointStates(scene.robot_body, list(scene.fingers))
        return [s[0] for s in fingers], [s[1] for s in fingers], [s[3] for s in fingers]

    def _drive_fingers(self, position: float) -> None:
        """Both finger joints to ``position`` (m) at the gripper's speed."""
        scene = self._scene
        robot = scene.config.robot
        speed = abs(robot.gripper_closed - robot.gripper_open) / _GRIPPER_STROKE_TIME
        for joint in scene.fingers:
            scene.client.setJointMotorControl2(
                scene.robot_body,
                joint,
                pybullet.POSITION_CONTROL,
                targetPosition=position,
                force=self._force,
                maxVelocity=speed,
            )
