"""The pybullet scene: the arm of a robot configuration on a fixed base, the ground, and a stand
carrying the graspable object.

The arm is the one a robot configuration (``com_core.robot.config``) describes, loaded from
its URDF as ``wrench_sim.urdf`` prepares it (``rigid`` mode: the gripper fixed open). Gravity
is (0, 0, -``STANDARD_GRAVITY``) in the world, the step ``TIME_STEP``.

The solver runs a fixed number of iterations (``solverResidualThreshold=0``): with pybullet's
default early exit the held arm settles into a 2- or 3-step limit cycle on the sensor instead
of reading the static wrench (bench/README.md, Simulation rate). The joint sensor reports its
moment about the joint origin (``JOINT_FEEDBACK_IN_JOINT_FRAME``; ``wrench_sim.load``).

A stand carries the object upright. At the configuration's ``pick_joints`` the object's
geometric centre lies on the grasp centre (``com_core.robot.config.grasp_point``) across the
sensor's z, and its top 0.04 m before the grasp centre along it (Panda: grasp centre 0.115 m
from the flange, the top 0.075 m); the object's axes are the world's.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET

import numpy as np
import pybullet
import pybullet_data
from numpy.typing import NDArray
from pybullet_utils.bullet_client import BulletClient

from com_core.sensing.wrench_model import STANDARD_GRAVITY
from wrench_sim.config import TIME_STEP, SimConfig
from wrench_sim.objects import ObjectSpec, create_object_body
from wrench_sim.urdf import checked_urdf, fix_open

__all__ = ["Scene"]

_OBJECT_TOP = -0.04  # m along sensor z from the grasp centre: the object's top at pick
_STAND_HALF_WIDTH = 0.03  # m
_SOLVER_ITERATIONS = {"rigid": 20, "friction": 50}  # finger contacts need more


class Scene:
    """The arm, the ground, the stand and the object in a new pybullet client.

    Parameters
    ----------
    config : the scene's settings.
    spec : the object (``wrench_sim.objects.object_spec``).
    home : rad; the arm's home joints, checked against the joint limits (the arm is left at
        ``pick_joints``: the caller puts it home).

    Raises
    ------
    ValueError naming what does not serve (``wrench_sim.urdf.checked_urdf``), or pick joints
    at which the sensor's z does not point down or the grasp centre is too low for the object.

    Attributes
    ----------
    client : the pybullet client.
    urdf_text : the URDF loaded, as ``/robot_description`` publishes it.
    robot_body, plane, stand, object_body : pybullet body ids.
    arm : pybullet joint indices of ``robot.arm_joints``.
    sensor : pybullet index of the sensor's joint, also its child link's (``ft_sensor``).
    load_links : link indices beyond the sensor (the sensor's child link first).
    fingers : joint indices of the gripper joints in ``friction`` mode; () in ``rigid``.
    base_links : link indices fixed to the base (-1 the base): they never move.
    link_names : link name by index.
    grasp : m, ``ft_sensor``; the grasp centre.
    """

    def __init__(self, config: SimConfig, spec: ObjectSpec, home: NDArray[np.float64]) -> None:
        self.config = config
        self.object = spec
        self.rigid = config.grasp_mode == "rigid"
        urdf = checked_urdf(config.robot, home, self.rigid)
        self.grasp = urdf.grasp
        self.client = BulletClient(pybullet.GUI if config.gui else pybullet.DIRECT)
        c = self.client
        c.setAdditionalSearchPath(pybullet_data.getDataPath())
        c.setGravity(0.0, 0.0, -STANDARD_GRAVITY)
        c.setTimeStep(TIME_STEP)
        c.setPhysicsEngineParameter(
            numSolverIterations=_SOLVER_ITERATIONS[config.grasp_mode],
            solverResidualThreshold=0.0,
            jointFeedbackMode=pybullet.JOINT_FEEDBACK_IN_JOINT_FRAME,
        )
        if config.gui:
            c.configureDebugVisualizer(pybullet.COV_ENABLE_GUI, 0)
            c.resetDebugVisualizerCamera(1.2, 60.0, -25.0, [0.4, 0.0, 0.3])
        if self.rigid:
            fix_open(urdf, config.robot)
        self.robot_body = self._load_robot(urdf.root, urdf.sensor_joint, urdf.beyond)
        self._scale_hand_mass()
        self.plane = c.loadURDF("plane.urdf")
        self.stand, self.object_body = self._load_stand_and_object()
        # Bullet drags every moving body by default (0.04 of its momentum per s, and more
        # with speed); a real arm and its load in air feel nothing of that size
        for body in (self.robot_body, self.object_body):
            c.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0)

    def _load_robot(
        self, root: ET.Element, sensor_joint: ET.Element, beyond: list[ET.Element]
    ) -> int:
        """Load the robot from ``root``; set ``urdf_text`` and the joint and link indices."""
        c, robot = self.client, self.config.robot
        self.urdf_text = ET.tostring(root, encoding="unicode")
        with tempfile.TemporaryDirectory(prefix="wrench_sim_") as directory:
            path = os.path.join(directory, f"{robot.robot}.urdf")
            with open(path, "w", encoding="utf-8") as stream:
                stream.write(self.urdf_text)
            body = c.loadURDF(path, useFixedBase=True)
        infos = [c.getJointInfo(body, j) for j in range(c.getNumJoints(body))]
        joints = {info[1].decode(): info[0] for info in infos}
        links = {info[12].decode(): info[0] for info in infos}
        self.link_names = {index: name for name, index in links.items()}
        self.arm = [joints[name] for name in robot.arm_joints]
        self.sensor = joints[sensor_joint.get("name")]  # also its child link's index
        beyond_links = [links[j.find("child").get("link")] for j in beyond]
        self.load_links = (self.sensor, *beyond_links)
        self.fingers = () if self.rigid else tuple(joints[n] for n in robot.gripper_joints)
        # links fixed to the base: they never move, their contact with the ground is expected
        self.base_links = {-1}
        for info in infos:
            if info[2] == pybullet.JOINT_FIXED and info[16] in self.base_links:
                self.base_links.add(info[0])
        return body

    def _scale_hand_mass(self) -> None:
        """Scale the masses and inertias of the links beyond the sensor alike to total
        ``hand_mass`` (kg; 0 keeps the URDF's), so their COM is unchanged."""
        if self.config.hand_mass <= 0.0:
            return
        c, body = self.client, self.robot_body
        urdf_mass = sum(c.getDynamicsInfo(body, link)[0] for link in self.load_links)
        factor = self.config.hand_mass / urdf_mass
        for link in self.load_links:
            info = c.getDynamicsInfo(body, link)
            if info[0] > 0.0:
                c.changeDynamics(
                    body,
                    link,
                    mass=info[0] * factor,
                    localInertiaDiagonal=[i * factor for i in info[2]],
                )

    def _load_stand_and_object(self) -> tuple[int, int]:
        """The stand and the object on it (see module); the arm is at pick_joints meanwhile.
        Returns their pybullet body ids."""
        c = self.client
        for joint, q in zip(self.arm, self.config.robot.pick_joints, strict=True):
            c.resetJointState(self.robot_body, joint, q)
        origin, R = self.sensor_pose()
        grasp = origin + R @ self.grasp  # m, world
        if R[2, 2] > -0.99:
            raise ValueError(
                f"pick_joints {list(self.config.robot.pick_joints)}: the sensor's z must point "
                f"down at pick (it is {np.degrees(np.arccos(-R[2, 2])):.1f} deg off)"
            )
        top_z = (
            grasp[2] + _OBJECT_TOP * R[2, 2]
        )  # the top on the sensor's z through the grasp centre
        height = self.object.geometry.height
        bottom_z = top_z - height
        if bottom_z <= 0.0:
            raise ValueError(
                f"pick_joints {list(self.config.robot.pick_joints)}: the grasp centre is "
                f"{grasp[2]:.3f} m above the ground, too low for a {height:.3f} m object"
            )
        half = [_STAND_HALF_WIDTH, _STAND_HALF_WIDTH, bottom_z / 2.0]
        stand = c.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half),
            baseVisualShapeIndex=c.createVisualShape(
                pybullet.GEOM_BOX, halfExtents=half, rgbaColor=[0.5, 0.5, 0.55, 1.0]
            ),
            basePosition=[grasp[0], grasp[1], bottom_z / 2.0],
        )
        c.changeDynamics(stand, -1, lateralFriction=1.0)
        centre = [grasp[0], grasp[1], bottom_z + height / 2.0]
        return stand, create_object_body(c, self.object, centre)

    def sensor_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Origin (3,) in m and rotation R_world_sensor (3, 3) of ``ft_sensor`` in the world."""
        state = self.client.getLinkState(
            self.robot_body, self.sensor, computeForwardKinematics=True
        )
        R = np.array(self.client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        return np.array(state[4]), R

    def close(self) -> None:
        """Disconnect from pybullet."""
        if self.client._client >= 0:
            self.client.disconnect()
