"""The simulated world: a fixed-base arm with a wrist F/T sensor, its gripper and a graspable
object on a stand, stepped at 1 kHz. ROS-free; the node (``sim_node``) is a thin adapter
around ``ArmWorld`` and tests drive it directly.

``ArmWorld`` composes the parts, each in its own module:

- ``config``: the physics step, the frames and ``SimConfig``;
- ``urdf``: the robot configuration's URDF, checked, its gripper fixed open in ``rigid`` mode;
- ``scene``: the pybullet client, the arm, the ground, the stand and the object on it;
- ``arm``: the arm's joint trajectories and whether it has come to rest;
- ``gripper``: the virtual gripper of ``rigid`` mode and the simulated fingers of ``friction``;
- ``slip``: the grasp shifts of ``rigid`` mode at each new tilt;
- ``pushes``: pushes on the held object and the push as the sensor reads it;
- ``collisions``: contacts of the arm and the held object with the ground and the stand;
- ``load``: the wrench the load exerts on the sensor and the load's ground truth.

Each step: the arm's motors take the trajectory's point, the virtual gripper moves, the pushes
acting are applied, pybullet steps and the joint sensor is read. Every 10 ms (the bookkeeping
step) the friction grasp's contacts, the arm's rest, the grasp shifts, the collisions and the
load the ringing acts on are looked at, in that order.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
import pybullet
from numpy.typing import NDArray

from com_core.sensing.wrench_model import gravity_in_sensor
from wrench_sim.arm import ArmDriver
from wrench_sim.collisions import CollisionWatch
from wrench_sim.config import (
    GRASP_MODES,
    PUSH_FRAMES,
    SENSOR_FRAME,
    STEP_NS,
    TIME_STEP,
    WORLD_FRAME,
    SimConfig,
    check_slip_sigma,
)
from wrench_sim.gripper import FrictionGripper, Gripper, RigidGripper
from wrench_sim.load import GroundTruth, LoadWrench
from wrench_sim.objects import ObjectSpec, object_spec
from wrench_sim.pushes import Pushes
from wrench_sim.scene import Scene
from wrench_sim.sensor import random_streams
from wrench_sim.slip import GraspShifts
from wrench_sim.vibration import Vibration

__all__ = [
    "GRASP_MODES",
    "PUSH_FRAMES",
    "SENSOR_FRAME",
    "STEP_NS",
    "TIME_STEP",
    "WORLD_FRAME",
    "ArmWorld",
    "SimConfig",
]

_BOOKKEEPING_STEPS = 10  # grasp, settle, slip and collision checks every 10 ms
_WARM_UP_STEPS = 200


class ArmWorld:
    """An arm on a fixed base with its gripper, a stand with an object, stepped at 1 kHz.

    Parameters
    ----------
    config : the scene.

    Raises
    ------
    ValueError naming what does not serve: a URDF that cannot be read, a frame or joint of
    the robot configuration it lacks, home (or pick) joints outside the joint limits,
    ``friction`` mode with a gripper other than two prismatic fingers, a COM offset the stand
    cannot hold.

    Attributes
    ----------
    config : the scene's settings.
    object : the object (shape, mass, COM offset, geometry).
    urdf_text : the URDF loaded, as ``/robot_description`` publishes it (``rigid`` mode: the
        gripper's joints fixed open).
    robot_body, object_body : pybullet body ids.
    events : lines for the user, each with the sim time (the node logs and clears them).

    Notes
    -----
    After construction the world has run 0.2 s of warm-up (not counted in ``time_ns``) so the
    arm holds its home joints and the object rests on its stand.
    """

    def __init__(self, config: SimConfig | None = None) -> None:
        self.config = config or SimConfig()
        streams = random_streams(self.config.seed)
        self.object: ObjectSpec = object_spec(
            self.config.object_shape,
            self.config.object_mass,
            self.config.object_com_offset,
            streams["object"],
        )
        self._rigid = self.config.grasp_mode == "rigid"
        home = np.asarray(self.config.home, dtype=np.float64)
        scene = self._scene = Scene(self.config, self.object, home)
        self.urdf_text = scene.urdf_text
        self.robot_body, self.object_body = scene.robot_body, scene.object_body
        # Bound once: BulletClient looks the function up on every call (~2 us), hot paths here.
        self._step_simulation = functools.partial(
            pybullet.stepSimulation, physicsClientId=scene.client._client
        )
        self.events: list[str] = []
        self._steps = 0
        self._arm = ArmDriver(scene, home)
        self._shifts = GraspShifts(scene, streams["slip"], self.config.slip_sigma, self._event)
        self._gripper: Gripper = (
            RigidGripper(scene, self._event, self._shifts.grasped)
            if self._rigid
            else FrictionGripper(scene, self._event)
        )
        self._pushes = Pushes(scene, self._event)
        self._collisions = CollisionWatch(scene, self._event)
        self._truth = GroundTruth(scene)
        modes = self.config.vibration
        gain = self.config.vibration_gain
        vibration = Vibration(modes, TIME_STEP, gain) if modes else None
        self._load = LoadWrench(scene, self._truth, vibration)
        for _ in range(_WARM_UP_STEPS):
            self._physics_step()
        self._load.restart_filter()
        self.events.clear()

    # ----------------------------------------------------------------- stepping
    @property
    def time_ns(self) -> int:
        """Simulated time since start, integer ns."""
        return self._steps * STEP_NS

    @property
    def time(self) -> float:
        """Simulated time since start, s."""
        return self._steps * TIME_STEP

    def step(self) -> None:
        """Advance the world by one 1 ms physics step and read the sensor."""
        self._arm.update(self.time)
        self._gripper.step()
        self._pushes.apply(self._steps, self._gripper.held)
        self._physics_step()
        self._steps += 1
        if self._steps % _BOOKKEEPING_STEPS == 0:
            self._bookkeeping()

    def run(self, duration: float) -> None:
        """Step for ``duration`` s of simulated time."""
        for _ in range(round(duration / TIME_STEP)):
            self.step()

    def _physics_step(self) -> None:
        self._step_simulation()
        self._load.read(self._arm.moving)

    def _bookkeeping(self) -> None:
        """Every 10 ms: friction grasp state, arm settling, the rigid grasp's shifts,
        collisions and the load the ringing acts on."""
        gripper = self._gripper
        gripper.check_contact()
        self._arm.track_rest(_BOOKKEEPING_STEPS)
        shifting = isinstance(gripper, RigidGripper) and self._shifts.sigma > 0.0
        if shifting and gripper.held and self.arm_settled:
            self._shifts.check(gripper)
        self._collisions.look(gripper.held)
        self._load.update_load(gripper.held)

    def _event(self, text: str) -> None:
        """Record something a user cares about, with the sim time, for the node to log."""
        self.events.append(f"t = {self.time:.3f} s: {text}")

    @property
    def wrench(self) -> NDArray[np.float64]:
        """True wrench (6,) the load exerts on the sensor, 2-tap mean; N, N m; ft_sensor."""
        return self._load.wrench

    @property
    def raw_wrench(self) -> NDArray[np.float64]:
        """The last step's single reading (6,), unfiltered; N, N m; ft_sensor."""
        return self._load.raw_wrench

    # ----------------------------------------------------------------- arm
    def command_arm(
        self,
        joint_names: Sequence[str],
        times: Sequence[float],
        positions: Sequence[Sequence[float]],
        stamp: float = 0.0,
        velocities: Sequence[Sequence[float] | None] | None = None,
        accelerations: Sequence[Sequence[float] | None] | None = None,
    ) -> float:
        """Follow a joint trajectory as ros2_control's joint_trajectory_controller does: it
        replaces any running one now, from the measured state (``wrench_sim.trajectory``).

        Parameters
        ----------
        joint_names : a subset of the robot's ``arm_joints``, any order.
        times : s from the start (time_from_start), >= 0, strictly increasing.
        positions : rad, one row per time, one value per name.
        stamp : s, simulated; the header stamp: when ``times`` count from (0: now).
        velocities, accelerations : rad/s, rad/s^2 per point, like a row of ``positions``,
            or None where a point carries none (None: no point does).

        Returns
        -------
        s; simulated time at which the last waypoint is reached.

        Raises
        ------
        ValueError if the command is malformed or unreachable; the arm then keeps its
        current motion.
        """
        return self._arm.command(
            joint_names, times, positions, stamp, self.time, velocities, accelerations
        )

    def plan_arm(self, **command) -> None:
        """Check a command of ``command_arm``'s keyword arguments as if it arrived now,
        without running it: ValueError says what is wrong."""
        self._arm.plan(now=self.time, **command)

    def hold_arm(self) -> None:
        """Stop the arm where it is (the running trajectory ends)."""
        self._arm.hold()

    @property
    def arm_final(self) -> NDArray[np.float64]:
        """rad (``arm_joints`` order); where the running trajectory ends, else the held
        position."""
        return self._arm.final

    def command_move(self, positions: Sequence[float], duration: float) -> float:
        """Move every arm joint from where it is to ``positions`` (rad, ``arm_joints`` order)
        in ``duration`` s, rest to rest: two points with zero velocities and accelerations,
        one quintic. Returns the simulated time (s) it ends."""
        names = self.config.robot.arm_joints
        here = self._arm.joint_state()[0]
        rest = [[0.0] * len(names)] * 2
        return self.command_arm(names, [0.0, duration], [here, positions], 0.0, rest, rest)

    def move_arm(self, positions: Sequence[float], duration: float) -> None:
        """``command_move`` and wait until settled."""
        self.command_move(positions, duration)
        self.run(duration)
        while not self.arm_settled:
            self.step()

    @property
    def arm_set_point(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The arm controller's desired positions (rad) and velocities (rad/s) now."""
        return self._arm.set_point

    @property
    def arm_trajectory_end(self) -> float | None:
        """s; when the running trajectory's last waypoint is due (None: none runs)."""
        return self._arm.end_time

    @property
    def arm_settled(self) -> bool:
        """No trajectory is running and the joints have been still for 20 ms."""
        return self._arm.settled

    # ----------------------------------------------------------------- gripper
    def command_gripper(self, position: float, max_effort: float = 0.0) -> None:
        """Move the gripper to ``position``, in its command's units (m or rad): from the
        configuration's ``gripper_open`` to ``gripper_closed``, pushing with at most
        ``max_effort`` N (0: the configured ``grip_force``).

        Closing on the object grasps it; opening releases it. Raises ValueError for a value
        outside that range or not finite, or a negative ``max_effort``.
        """
        self._gripper.command(position, max_effort)

    def gripper_state(self) -> tuple[float, float, float]:
        """The gripper's position (m or rad), speed (m/s or rad/s) and effort (N) now."""
        return self._gripper.state()

    def set_slip_sigma(self, sigma: float) -> None:
        """Change the grasp-shift sigma (m) of the rigid mode from now on."""
        self._shifts.sigma = check_slip_sigma(sigma, self._rigid)

    @property
    def object_held(self) -> bool:
        """The object is in the gripper (rigid: attached; friction: touched by both
        fingers)."""
        return self._gripper.held

    # ----------------------------------------------------------------- pushes
    def apply_wrench(
        self,
        force: Sequence[float],
        torque: Sequence[float],
        frame: str = WORLD_FRAME,
        start_time: float = 0.0,
        duration: float = 1.0,
    ) -> tuple[float, float]:
        """Push the held object from ``start_time`` for ``duration`` s of simulated time.

        Pushes add up: one given while another acts or waits acts on top of it.

        Parameters
        ----------
        force : N, shape (3,); applied at the object's COM.
        torque : N m, shape (3,); a pure couple on the object.
        frame : 'world' (the push keeps its direction in the world) or 'ft_sensor' (the push
            turns with the hand; the configuration's ``sensor_frame``).
        start_time : s, simulated; now if earlier than now (0 = now), else the first 1 ms step
            starting at or after it.
        duration : s, > 0; rounded to whole 1 ms steps (at least one).

        Returns
        -------
        (start, end) in s, simulated: the push acts on the steps between them, so the readings
        stamped in (start, end] carry it. Its start and end are recorded in ``events``; a push
        acting when the object is released ends then, and one whose start comes after the
        release is dropped.

        Raises
        ------
        ValueError if the frame is neither, a value is not finite, ``duration`` is not > 0, or
        no object is held.
        """
        return self._pushes.schedule(
            force, torque, frame, start_time, duration, self._steps, self._gripper.held
        )

    @property
    def push_active(self) -> bool:
        """A push acted on the object during the last step."""
        return self._pushes.active

    @property
    def push_scheduled(self) -> bool:
        """A push is acting or waiting for its start time."""
        return self._pushes.scheduled

    def applied_wrench(self) -> NDArray[np.float64]:
        """The pushes of the last step as the sensor reads them (6,); N, N m; ``ft_sensor``;
        zero when no push acted (``wrench_sim.pushes.Pushes.applied_wrench``)."""
        return self._pushes.applied_wrench()

    @property
    def collisions(self) -> int:
        """How many contacts of the arm with the ground or the stand, or of the held object
        with the ground, have begun since the start (``wrench_sim.collisions``)."""
        return self._collisions.count

    # ----------------------------------------------------------------- state and truth
    def sensor_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Origin (3,) in m and rotation R_world_sensor (3, 3) of ``ft_sensor`` in the world."""
        return self._scene.sensor_pose()

    def gravity_in_sensor(self) -> NDArray[np.float64]:
        """Gravity (3,) in m/s^2 expressed in ``ft_sensor`` at the current pose
        (``com_core.sensing.wrench_model.gravity_in_sensor`` of R_world_sensor)."""
        return gravity_in_sensor(self._scene.sensor_pose()[1])

    def hand_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the links beyond the sensor (hand or
        gripper, fingers; URDF inertials, scaled by ``hand_mass``).

        Constant in rigid mode (fixed fingers); in friction mode it follows the fingers.
        """
        return self._truth.hand()

    def object_ground_truth(self) -> tuple[float, NDArray[np.float64]]:
        """Mass (kg) and COM (3,) in m, ``ft_sensor``, of the object, wherever it is."""
        return self._truth.object()

    def inertia_ground_truth(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The inertias (3, 3), kg m^2, about their COMs in ``ft_sensor`` axes, of the links
        beyond the sensor together and of the object."""
        return self._truth.inertias()

    def load_parameters(self) -> NDArray[np.float64]:
        """pi (10,) of everything beyond the sensor now (the hand and the object when held;
        ``com_core.robot.dynamics``), as pybullet simulates it."""
        return self._truth.inertial_parameters(self._gripper.held)

    def arm_motion(self) -> tuple[list[float], list[float]]:
        """Positions (rad) and velocities (rad/s) of the configuration's ``arm_joints``."""
        return self._arm.joint_state()[:2]

    def joint_state(
        self,
    ) -> tuple[tuple[str, ...], list[float], list[float], list[float]]:
        """Names (the configuration's ``arm_joints`` then ``gripper_joints``), positions
        (rad, m), velocities and efforts (N m, N) of arm and gripper.

        In rigid mode the gripper's links are fixed; each gripper joint reports the virtual
        gripper's position (stopping where the pads meet the object when it is grasped).
        """
        positions, velocities, efforts = self._arm.joint_state()
        gripper_positions, gripper_velocities, gripper_efforts = self._gripper.joint_state()
        return (
            self.config.robot.arm_joints + self.config.robot.gripper_joints,
            positions + gripper_positions,
            velocities + gripper_velocities,
            efforts + gripper_efforts,
        )

    def close(self) -> None:
        """Disconnect from pybullet."""
        self._scene.close()
