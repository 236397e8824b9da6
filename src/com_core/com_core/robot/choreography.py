"""Joint-space targets and motion times of an exploration on any arm (no ROS).

Each pose of a plan is a target orientation of the sensor frame: home, or home turned by
R_rel = rotation_about(axis, +-tilt) in the sensor's own home axes (``Plan.poses``), so
gravity in the sensor frame turns as the plan says. The turn is about the grasp centre
(the robot configuration's ``grasp_frame`` and ``grasp_offset``), which stays within
``MAX_PIVOT_SHIFT`` of its home position: the object swings little. The joints come from
``inverse_kinematics.solve_pose`` (damped least squares from home, within the URDF's
joint limits, the solution nearest home); only the configuration's ``arm_joints`` move.
A pose no solution reaches is ``PoseUnreachable``, raised before anything moves, with
the reason and the largest tilt the arm reaches about that axis.

The pass visits home, tilt_y+, tilt_y-, tilt_x-, tilt_x+ (of those the plan has): the
negative tilts are neighbours, so the pass is short. The verification pose
``VERIFY_POSE`` is one no plan has: ``VERIFY_TILT`` about the sensor's diagonal, between
its x and y axes.

Motion times give each joint at most ``speed`` rad/s on average and keep the quintic
profile's peak (1.875x the mean) under the joint's velocity limit in the URDF, with a
floor, so tilts stay smooth and the dynamic wrench small; the sequencer waits ``settle``
s after every motion before a window starts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from com_core.robot.config import RobotConfig, RobotConfigError, grasp_point, robot_problems
from com_core.robot.dynamics import links_beyond
from com_core.robot.inverse_kinematics import largest_reachable_tilt, solve_pose
from com_core.robot.model import KinematicsError, RobotModel
from com_core.sensing.wrench_model import rotation_about

__all__ = [
    "AXES",
    "MAX_PIVOT_SHIFT",
    "QUINTIC_ACCELERATION",
    "QUINTIC_PEAK",
    "VERIFY_AXIS",
    "VERIFY_POSE",
    "VERIFY_TILT",
    "Choreography",
    "PoseUnreachable",
    "TiltPlan",
]


class TiltPlan(Protocol):
    """What the choreography takes of a plan (``com_core.planning.Plan`` is one; the
    planning wing stands above this one): its tilt (rad) and its poses, home first."""

    tilt: float

    def poses(self) -> list[tuple[str, NDArray[np.float64]]]: ...


VERIFY_POSE, VERIFY_TILT = "diagonal", math.radians(20.0)
VERIFY_AXIS = (math.sqrt(0.5), math.sqrt(0.5), 0.0)
"""The verification tilt's axis in the sensor's home axes: between x and y."""
MAX_PIVOT_SHIFT = 1e-3
"""m; how far the grasp centre may end from its home position at a pose."""
QUINTIC_PEAK = 1.875
"""Peak over mean speed of a quintic (rest-to-rest) profile."""
QUINTIC_ACCELERATION = 10.0 / math.sqrt(3.0)
"""Peak acceleration of a quintic (rest-to-rest) profile, over its distance / duration^2."""
AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0)}
"""The sensor's axes a plan tilts about, in its home axes."""


class PoseUnreachable(ValueError):  # noqa: N818 (a pose, refused)
    """A pose of the plan that no joint solution reaches; ``largest`` is the largest
    tilt (rad) the arm reaches about that pose's axis and direction."""

    def __init__(self, pose: str, tilt: float, reason: str, largest: float) -> None:
        super().__init__(
            f"pose {pose} at {tilt:.3f} rad is out of reach ({reason}); the largest tilt "
            f"the arm reaches there is {largest:.3f} rad"
        )
        self.pose, self.reason, self.largest = pose, reason, largest


@dataclass(frozen=True)
class Choreography:
    """The poses and motions of one arm: its robot model (the sensor frame is the one
    turned), the configuration's arm joints and home (rad), and the grasp centre (m, in
    the sensor frame) the tilts turn about."""

    robot: RobotModel
    arm_joints: tuple[str, ...]
    home: tuple[float, ...]
    pivot: NDArray[np.float64]
    others: dict[str, float]
    """The model's joints that do not move (the gripper's, at open): their positions."""
    hand: NDArray[np.float64]
    """(10,) the inertial parameters of what the URDF attaches beyond the sensor (the hand;
    ``robot.dynamics.links_beyond``), in the sensor frame."""
    acceleration_limits: tuple[float, ...]
    """rad/s^2 per arm joint: the arm's own (the configuration's ``max_joint_acceleration``;
    empty: it states none)."""
    _turns: dict[tuple[tuple[float, ...], float], tuple[tuple[float, ...] | None, str]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    """``turned``'s answers by (axis, tilt): a plan's poses are solved once (planning
    reaches the tare pass's poses, then times the pass's same poses)."""

    @classmethod
    def of(cls, config: RobotConfig, urdf: str) -> Choreography:
        """The choreography of ``config`` on the arm of ``urdf`` (its text).
        RobotConfigError names every frame or joint the URDF lacks and a home or pick
        pose outside the joint limits."""
        try:
            robot = RobotModel(urdf, config.sensor_frame, config.base_frame)
        except KinematicsError as error:  # the URDF does not parse, a frame it lacks
            raise RobotConfigError(f"robot {config.robot!r}: {error}") from error
        problems = robot_problems(config, robot)
        if problems:
            raise RobotConfigError(f"robot {config.robot!r}: {'; '.join(problems)}")
        others = {
            name: config.gripper_open if name in config.gripper_joints else 0.0
            for name in robot.joint_names
            if name not in config.arm_joints
        }
        hand = links_beyond(urdf, config.sensor_frame)
        return cls(robot, config.arm_joints, config.home_joints, grasp_point(config, robot),
                   others, hand, config.max_joint_acceleration)  # fmt: skip

    def home_positions(self) -> dict[str, float]:
        """Every joint of the model at home (rad, m), by name."""
        return dict(zip(self.arm_joints, self.home, strict=True)) | self.others

    def turned(self, axis: Sequence[float], tilt: float) -> tuple[list[float] | None, str]:
        """(arm joints, rad, that turn the sensor by ``tilt`` rad about ``axis`` (its home
        axes) about the grasp centre, or None; the reason when None)."""
        key = (tuple(float(a) for a in axis), float(tilt))
        if key not in self._turns:
            result = solve_pose(
                self.robot,
                self.home_positions(),
                rotation_about(np.asarray(key[0]), key[1]),
                self.pivot,
                joints=self.arm_joints,
                max_position_error=MAX_PIVOT_SHIFT,
            )
            joints = tuple(result.joints[name] for name in self.arm_joints)
            self._turns[key] = (joints, "") if result.reachable else (None, result.reason)
        joints, reason = self._turns[key]
        return (None if joints is None else list(joints)), reason

    def pose_joints(self, plan: TiltPlan) -> list[tuple[str, list[float]]]:
        """(pose name, arm joints in rad) for every pose of ``plan``, home first, in the
        pass's order (see module). PoseUnreachable for the first pose no solution
        reaches."""
        names = [name for name, _ in plan.poses()]
        home = names[0]  # ``Plan.poses``: home first
        order = sorted(
            names, key=lambda n: (n != home, n[-2:-1] != "y", n[-1] == "+" and "x" in n)
        )
        out = []
        for name in order:
            if name == home:
                out.append((name, list(self.home)))
                continue
            axis = np.asarray(AXES[name[-2]]) * (1.0 if name[-1] == "+" else -1.0)
            joints, reason = self.turned(axis, plan.tilt)
            if joints is None:
                largest = largest_reachable_tilt(
                    self.robot,
                    self.home_positions(),
                    axis,
                    self.pivot,
                    max_tilt=plan.tilt,
                    joints=self.arm_joints,
                    max_position_error=MAX_PIVOT_SHIFT,
                )
                raise PoseUnreachable(name, plan.tilt, reason, largest)
            out.append((name, joints))
        return out

    def verify_joints(self, tilt: float = VERIFY_TILT) -> tuple[list[float] | None, str]:
        """(arm joints of the verification pose, home turned by ``tilt`` rad about the
        sensor's diagonal, or None; the reason when None)."""
        return self.turned(VERIFY_AXIS, tilt)

    def velocity_limits(self) -> list[float]:
        """rad/s (m/s) of each arm joint, from the URDF."""
        limits = self.robot.joint_limits()
        return [limits[name][2] for name in self.arm_joints]

    def motion_time(
        self,
        start: Sequence[float],
        goal: Sequence[float],
        speed: float = 1.35,
        floor: float = 0.4,
    ) -> float:
        """s for a smooth motion: each joint at most ``speed`` rad/s on average, its quintic
        peak under its URDF velocity limit and its peak acceleration under the arm's own
        limit (``acceleration_limits``, when it states them: Franka's controller aborts a
        motion beyond them); at least ``floor`` s."""
        caps = [
            min(speed, limit / QUINTIC_PEAK) if limit > 0 else speed  # 0: none in the URDF
            for limit in self.velocity_limits()
        ]
        steps = [abs(a - b) / cap for a, b, cap in zip(start, goal, caps, strict=True)]
        accelerations = self.acceleration_limits or (math.inf,) * len(caps)
        steps += [math.sqrt(QUINTIC_ACCELERATION * abs(a - b) / limit)
                  for a, b, limit in zip(start, goal, accelerations, strict=True)]  # fmt: skip
        return max(floor, *steps)
