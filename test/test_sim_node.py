"""The sim node as a process: topics, a commanded tilt, pushes, bad commands that change
nothing, the xArm6 from its parameters file and a robot configuration that does not serve.

Starts install/wrench_sim/lib/wrench_sim/sim_node (no launch file), subscribes to its topics,
grasps the object and tilts the wrist through the ros2_control-style command topics, and
compares the mean static wrench with the analytic gravity wrench of hand + object from the
ground-truth topics and the orientation from the published joint states; pushes the held
object and compares the wrench's change with what the sim says it applied.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pybullet
import pybullet_data
import pytest
from conftest import log_tail, spin_until
from numpy.testing import assert_allclose

from com_core.contract import (
    APPLIED_WRENCH_TOPIC,
    APPLY_WRENCH_TOPIC,
    ARM_COMMAND_TOPIC,
    CLOCK_TOPIC,
    HAND_COMMAND_TOPIC,
    HAND_TRUTH_TOPIC,
    JOINT_STATES_TOPIC,
    OBJECT_TOPIC,
    ROBOT_DESCRIPTION_TOPIC,
    TRUTH_TOPIC,
    WRENCH_TOPIC,
)
from com_core.robot.config import CONFIG_DIR, read_robot_config
from com_core.sensing.wrench_model import gravity_in_sensor, gravity_wrench

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.system

from builtin_interfaces.msg import Duration  # noqa: E402
from geometry_msgs.msg import InertiaStamped, WrenchStamped  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray, String  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

PANDA = read_robot_config("panda")
HOME_JOINTS, PICK_JOINTS, ARM_JOINTS = PANDA.home_joints, PANDA.pick_joints, PANDA.arm_joints
SIGMA_F, SIGMA_TAU, RATE = 0.05, 0.002, 250.0
PARAMS = {
    "object": "box",
    "object_mass": 0.1,
    "object_com_offset": [0.01, -0.005, 0.02],
    "seed": 4,
    "sensor_profile": "white",  # exact gravity wrenches under white noise (the parts: tests)
    "sigma_f": SIGMA_F,
    "sigma_tau": SIGMA_TAU,
    "rate": RATE,
    "real_time_factor": 4.0,
}
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SENSOR_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def sensor_rotation(arm_positions: list[float]) -> np.ndarray:
    """R_world_sensor of panda_hand (ft_sensor) from the arm joints, by pybullet FK."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        robot = pybullet.loadURDF(
            f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf",
            useFixedBase=True,
            physicsClientId=client,
        )
        for joint, q in enumerate(arm_positions):
            pybullet.resetJointState(robot, joint, q, physicsClientId=client)
        orientation = pybullet.getLinkState(
            robot, 8, computeForwardKinematics=True, physicsClientId=client
        )[5]
        return np.array(pybullet.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    finally:
        pybullet.disconnect(client)


class Client:
    """The test's view of the sim: latest messages per topic and a command interface."""

    def __init__(self, context) -> None:
        self.node = rclpy.create_node("sim_node_test", context=context)
        self.truth: list[InertiaStamped] = []
        self.hand_truth: list[InertiaStamped] = []
        self.objects: list[str] = []
        self.joint_state: JointState | None = None  # the arm's publisher's latest
        self.gripper_state: JointState | None = None  # the gripper's publisher's latest
        self.wrenches: list[tuple[int, np.ndarray]] = []
        node = self.node
        node.create_subscription(InertiaStamped, TRUTH_TOPIC, self.truth.append, LATCHED)
        node.create_subscription(InertiaStamped, HAND_TRUTH_TOPIC, self.hand_truth.append, LATCHED)
        node.create_subscription(
            String, OBJECT_TOPIC, lambda m: self.objects.append(m.data), LATCHED
        )
        node.create_subscription(JointState, JOINT_STATES_TOPIC, self._joint_state_callback, 10)
        node.create_subscription(WrenchStamped, WRENCH_TOPIC, self._wrench_callback, SENSOR_QOS)
        self.arm = node.create_publisher(JointTrajectory, ARM_COMMAND_TOPIC, 10)
        self.gripper = node.create_publisher(Float64MultiArray, HAND_COMMAND_TOPIC, 10)
        self.push = node.create_publisher(WrenchStamped, APPLY_WRENCH_TOPIC, 10)

    def _joint_state_callback(self, msg: JointState) -> None:
        if msg.name[0] == ARM_JOINTS[0] or msg.name[0] == "joint1":  # the Panda's, the xArm's
            self.joint_state = msg
        else:
            self.gripper_state = msg

    def _wrench_callback(self, msg: WrenchStamped) -> None:
        f, t = msg.wrench.force, msg.wrench.torque
        wrench = np.array([f.x, f.y, f.z, t.x, t.y, t.z])
        self.wrenches.append((stamp_ns(msg.header.stamp), wrench))

    def spin_until(self, predicate, timeout: float) -> bool:
        return spin_until(self.node, predicate, timeout)

    @property
    def sim_time(self) -> float:
        return stamp_ns(self.joint_state.header.stamp) * 1e-9 if self.joint_state else 0.0

    def arm_positions(self) -> np.ndarray:
        return np.array(self.joint_state.position[:7])

    def send_trajectory(
        self, names, points: list[tuple[float, list[float]]], at_rest: bool = False
    ) -> None:
        """Points (s from now, positions); ``at_rest``: each with zero velocities and
        accelerations (else positions only: linear)."""
        msg = JointTrajectory(joint_names=list(names))
        for t, positions in points:
            sec = math.floor(t)
            zeros = [0.0] * len(positions) if at_rest else []
            msg.points.append(
                JointTrajectoryPoint(
                    positions=positions,
                    velocities=zeros,
                    accelerations=zeros,
                    time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9)),
                )
            )
        self.arm.publish(msg)

    def move(self, goal: list[float], duration: float, timeout: float = 20.0) -> None:
        self.send_trajectory(ARM_JOINTS, [(duration, list(goal))], at_rest=True)

        def arrived() -> bool:
            state = self.joint_state
            return (
                state is not None
                and np.abs(np.array(state.position[:7]) - goal).max() < 2e-3
                and np.abs(np.array(state.velocity[:7])).max() < 1e-2
            )

        assert self.spin_until(arrived, timeout), f"arm did not reach {goal}"

    def wait_sim(self, seconds: float, timeout: float = 20.0) -> None:
        """Spin until ``seconds`` of sim time have passed on the joint states and, once
        any came, on the wrenches: the executor takes one sample per stream a turn, so
        on a slow machine the 1 kHz wrenches queue behind the 100 Hz joint states."""
        end = self.sim_time + seconds

        def passed() -> bool:
            wrenches_in = not self.wrenches or self.wrenches[-1][0] * 1e-9 >= end
            return self.sim_time >= end and wrenches_in

        assert self.spin_until(passed, timeout)

    def grasp(self) -> None:
        """Pick the object from its stand and lift it to the home pose."""
        self.move(list(PICK_JOINTS), 3.0)
        self.gripper.publish(Float64MultiArray(data=[0.0]))
        assert self.spin_until(lambda: "state=held" in self.objects[-1], 20.0), self.objects
        self.move(list(HOME_JOINTS), 3.0)

    def send_push(self, frame: str, force, torque, start_ns: int = 0) -> None:
        """Publish a push (N, N m) in ``frame`` from ``start_ns`` (sim time; 0 = now)."""
        assert self.spin_until(lambda: self.push.get_subscription_count() > 0, 10.0)
        msg = WrenchStamped()
        msg.header.frame_id = frame
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in force)
        msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = (float(v) for v in torque)
        self.push.publish(msg)


@pytest.fixture
def sim(start_node, rclpy_context):
    process = start_node("sim_node", "wrench_sim", PARAMS)
    client = Client(rclpy_context)
    ready = client.spin_until(
        lambda: client.truth and client.hand_truth and client.objects and client.joint_state,
        timeout=40.0,
    )
    assert ready, f"sim did not come up:\n{log_tail(process.log_path)}"
    yield process, client
    client.node.destroy_node()


def test_clock_runs_in_sim_time(sim, rclpy_context):
    process, client = sim
    clocks: list[int] = []
    subscription = client.node.create_subscription(
        Clock, CLOCK_TOPIC, lambda m: clocks.append(stamp_ns(m.clock)), 10
    )
    assert client.spin_until(lambda: len(clocks) >= 20, 10.0)
    client.node.destroy_subscription(subscription)
    assert all(b > a for a, b in itertools.pairwise(clocks))
    # Real-time factor 4: sim time runs ~4x the wall clock (loosely: the machine is shared).
    start_sim, start_wall = client.sim_time, time.monotonic()
    client.wait_sim(2.0)
    factor = (client.sim_time - start_sim) / (time.monotonic() - start_wall)
    assert 1.0 < factor < 4.5
    # Wrenches at `rate` in sim time, frame ft_sensor.
    stamps = [s for s, _ in client.wrenches[-100:]]
    assert np.median(np.diff(stamps)) == pytest.approx(1e9 / RATE)
    hand = client.hand_truth[-1]
    assert hand.header.frame_id == "ft_sensor"
    assert hand.inertia.m == pytest.approx(1.01)
    assert client.objects[-1].startswith("shape=box")
    assert process.poll() is None


def test_the_robot_description_is_the_urdf_the_sim_loaded(sim):
    """Latched on /robot_description (as robot_state_publisher does): a late subscriber
    gets the URDF with the fixed fingers of rigid mode, and it parses."""
    from com_core.robot.model import RobotModel

    process, client = sim
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    texts: list[str] = []
    client.node.create_subscription(
        String, ROBOT_DESCRIPTION_TOPIC, lambda m: texts.append(m.data), latched
    )
    assert client.spin_until(lambda: texts, 10.0), "no /robot_description"
    robot = RobotModel(texts[0], "panda_hand")
    assert len(robot.joint_names) == 7  # rigid mode: the fingers are fixed joints
    assert process.poll() is None


def test_commanded_tilt_gives_the_gravity_wrench_of_hand_and_object(sim):
    process, client = sim
    client.move(list(PICK_JOINTS), 3.0)
    client.gripper.publish(Float64MultiArray(data=[0.0]))
    assert client.spin_until(lambda: "state=held" in client.objects[-1], 20.0), client.objects
    client.move(list(HOME_JOINTS), 3.0)
    tilt = np.array(HOME_JOINTS)
    tilt[5] += 0.4  # joint 6: about hand y
    tilt[4] -= 0.3  # joint 5: about an axis in the hand's x-z plane
    client.move(tilt.tolist(), 2.0)
    client.wait_sim(0.3)
    start = round(client.sim_time * 1e9)
    client.wait_sim(1.0)
    window = np.array([w for s, w in client.wrenches if s > start])
    assert len(window) > 0.8 * RATE

    g_sensor = gravity_in_sensor(sensor_rotation(client.arm_positions().tolist()))
    hand, load = client.hand_truth[-1].inertia, client.truth[-1].inertia
    assert client.truth[-1].header.frame_id == "ft_sensor"
    assert load.m == pytest.approx(0.1)
    expected = gravity_wrench(hand.m, [hand.com.x, hand.com.y, hand.com.z], g_sensor)
    expected += gravity_wrench(load.m, [load.com.x, load.com.y, load.com.z], g_sensor)
    error = window.mean(axis=0) - expected
    n = len(window)
    assert np.abs(error[:3]).max() < 5 * SIGMA_F / n**0.5 + 2e-3, error
    assert np.abs(error[3:]).max() < 5 * SIGMA_TAU / n**0.5 + 2e-4, error
    assert window[:, :3].std(axis=0) == pytest.approx([SIGMA_F] * 3, rel=0.3)
    assert process.poll() is None


def test_malformed_commands_are_logged_and_ignored(sim):
    process, client = sim
    goal_before = client.arm_positions()
    nan = float("nan")
    client.send_trajectory(["panda_joint1", "elbow"], [(1.0, [0.0, 0.0])])
    client.send_trajectory(["panda_joint1"], [(1.0, [nan])])
    client.send_trajectory(["panda_joint4"], [(1.0, [1.0])])  # beyond its upper limit 0
    client.send_trajectory(["panda_joint1"], [(1.0, [0.1]), (0.5, [0.2])])
    client.send_trajectory(["panda_joint1"], [(1.0, [0.1, 0.2])])
    client.gripper.publish(Float64MultiArray(data=[0.01, 0.01]))
    client.gripper.publish(Float64MultiArray(data=[0.3]))
    client.wait_sim(1.0)
    assert process.poll() is None
    assert np.abs(client.arm_positions() - goal_before).max() < 1e-3
    log = process.log_path.read_text()
    assert log.count("rejected joint trajectory") == 5, log_tail(process.log_path)
    assert log.count("rejected gripper command") == 2, log_tail(process.log_path)
    # Still obeys a good command afterwards.
    goal = goal_before.copy()
    goal[0] += 0.1
    client.move(goal.tolist(), 1.0)


def test_invalid_parameter_is_refused_with_a_message(start_node):
    process = start_node("sim_node", "wrench_sim", {"object": "sphere"})
    assert process.wait(timeout=30) != 0
    log = process.log_path.read_text()
    assert (
        "cannot start: object='sphere' refused: must be one of ['box', 'cylinder', 'mug']\n" in log
    ), log


def test_a_com_offset_the_sim_cannot_hold_is_refused_with_the_range(start_node):
    # Inside the cylinder, but on its stand the cylinder tips over with this COM.
    process = start_node(
        "sim_node",
        "wrench_sim",
        {"object": "cylinder", "object_com_offset": [0.0175, 0.0175, 0.0]},
    )
    assert process.wait(timeout=30) != 0
    log = process.log_path.read_text()
    assert "outside what the sim can hold for the cylinder" in log, log
    assert "hypot(x, y) <= 0.0200 m and |z| <= 0.0400 m" in log, log
    assert "Traceback" not in log, log


def test_saturation_clips_and_is_logged_once_per_episode(start_node, rclpy_context):
    # The hand alone weighs 9.9 N: a 5 N force range saturates fz from the start.
    process = start_node(
        "sim_node", "wrench_sim", {"limit_f": 5.0, "rate": 100.0, "real_time_factor": 4.0}
    )
    client = Client(rclpy_context)
    try:
        assert client.spin_until(lambda: len(client.wrenches) >= 100, 40.0)
        forces = np.array([w[:3] for _, w in client.wrenches])
        assert np.all(np.abs(forces) <= 5.0)
        assert np.any(np.abs(forces) == 5.0)
        assert process.log_path.read_text().count("F/T sensor saturated") == 1
    finally:
        client.node.destroy_node()


PUSH_DURATION = 0.6  # s
PUSH_PARAMS = {
    "sensor_profile": "ideal",  # the push read to the physics' exactness
    "object": "box",
    "object_mass": 0.1,
    "object_com_offset": [0.01, -0.005, 0.02],
    "rate": RATE,
    "real_time_factor": 4.0,
    "sensor_mount_rpy": [0.3, -0.2, 0.5],
    "push_duration": PUSH_DURATION,
}
WORLD_PUSH = ((1.2, -1.0, 1.3), (0.03, 0.02, -0.035))  # N, N m
SENSOR_PUSH = ((0.5, 1.0, -1.5), (-0.02, 0.04, 0.01))
PUSH_SETTLE = 0.1  # s; the held arm gives way at a push's start and recovers within it
# Zero noise, rigid grasp: the wrench's change minus the applied wrench from PUSH_SETTLE on,
# measured <= 1.2e-5 N, 1.8e-6 N m by test_sim_physics; the same bound here.
PUSH_FORCE_TOL = 5e-5  # N
PUSH_TORQUE_TOL = 5e-6  # N m


def test_a_push_changes_the_wrench_by_what_the_sim_reports_it_applied(start_node, rclpy_context):
    """A push in world and one in ft_sensor (here a sensor mounted off its URDF frame): from
    0.1 s after its start the wrench minus the one before equals the applied wrench, which
    comes with the wrench samples' stamps while the push lasts and ends with a zero. Pushes
    in another frame, with NaN, or with nothing held are refused with an ERROR."""
    process = start_node("sim_node", "wrench_sim", PUSH_PARAMS)
    client = Client(rclpy_context)
    applied: list[tuple[int, np.ndarray]] = []

    def on_applied(msg: WrenchStamped) -> None:
        assert msg.header.frame_id == "ft_sensor"
        f, t = msg.wrench.force, msg.wrench.torque
        applied.append((stamp_ns(msg.header.stamp), np.array([f.x, f.y, f.z, t.x, t.y, t.z])))

    client.node.create_subscription(WrenchStamped, APPLIED_WRENCH_TOPIC, on_applied, 1000)
    try:
        ready = client.spin_until(lambda: client.truth and client.joint_state, timeout=40.0)
        assert ready, f"sim did not come up:\n{log_tail(process.log_path)}"
        client.send_push("ft_sensor", *SENSOR_PUSH)  # nothing held yet
        client.grasp()
        client.send_push("tool0", *WORLD_PUSH)
        client.send_push("world", (float("nan"), 0.0, 0.0), (0.0, 0.0, 0.0))
        client.wait_sim(0.3)
        assert not applied

        def zeros() -> int:
            return sum(not w.any() for _, w in applied)

        client.send_push("world", *WORLD_PUSH)  # stamp 0: now
        assert client.spin_until(lambda: zeros() == 1, 20.0), log_tail(process.log_path)
        start_ns = round((client.sim_time + 0.3) * 1e9)
        client.send_push("ft_sensor", *SENSOR_PUSH, start_ns=start_ns)
        assert client.spin_until(lambda: zeros() == 2, 20.0), log_tail(process.log_path)
        last = applied[-1][0] + round(0.3e9)  # the wrenches to 0.3 s after, whenever they come
        assert client.spin_until(lambda: client.wrenches[-1][0] > last, 20.0)

        wrenches = dict(client.wrenches)
        period = round(1e9 / RATE)
        ends = [k for k, (_, w) in enumerate(applied) if not w.any()]
        pushes = [applied[: ends[0] + 1], applied[ends[0] + 1 : ends[1] + 1]]
        assert len(applied) == ends[1] + 1
        for push in pushes:
            stamps = [s for s, _ in push]
            # one per wrench sample, with its stamp, for the whole duration, then one zero
            assert set(stamps) <= set(wrenches)
            assert np.all(np.diff(stamps) == period), stamps
            assert len(push) == round(PUSH_DURATION * RATE) + 1
            first = stamps[0]
            before = np.mean([w for s, w in wrenches.items() if first - 0.2e9 < s < first], axis=0)
            settled = [(s, w) for s, w in push[:-1] if s > first + PUSH_SETTLE * 1e9]
            error = np.array([wrenches[s] - before - w for s, w in settled])
            assert np.abs(error[:, :3]).max() < PUSH_FORCE_TOL, error
            assert np.abs(error[:, 3:]).max() < PUSH_TORQUE_TOL, error
            # once the arm has recovered from the push's end, the wrench is back where it was
            after = [
                w for s, w in wrenches.items() if stamps[-1] + 0.1e9 < s <= stamps[-1] + 0.25e9
            ]
            assert len(after) > 0.1 * RATE
            back = np.array(after) - before
            assert np.abs(back[:, :3]).max() < PUSH_FORCE_TOL, back
            assert np.abs(back[:, 3:]).max() < PUSH_TORQUE_TOL, back
        # the later push starts at its stamp (the first wrench sample after it carries it);
        # in ft_sensor (the mounted frame) its force reads as given, its torque about the
        # sensor origin adds p x F (p: the object's COM)
        assert pushes[1][0][0] == (start_ns // period + 1) * period
        force, torque = np.array(SENSOR_PUSH[0]), np.array(SENSOR_PUSH[1])
        com = client.truth[-1].inertia.com
        p = np.array([com.x, com.y, com.z])
        for _, w in pushes[1][:-1]:
            assert_allclose(w[:3], force, atol=1e-9)
            # (the COM moves < 5 um in ft_sensor under the push: the grasp's compliance)
            assert_allclose(w[3:], torque + np.cross(p, force), atol=1e-5)
        log = process.log_path.read_text()
        assert log.count("rejected push") == 3, log_tail(process.log_path)
        assert "rejected push: no object is held" in log
        assert "rejected push: frame must be one of ['world', 'ft_sensor'], got 'tool0'" in log
        assert "rejected push: force and torque must be finite" in log
        assert log.count("push accepted") == 2, log
        assert log.count("push started") == 2 and log.count("ended") == 2, log
        assert process.poll() is None
    finally:
        client.node.destroy_node()


XARM_FILE = CONFIG_DIR / "xarm6.yaml"


def test_the_xarm6_runs_from_its_parameters_file(start_node, rclpy_context):
    """``--params-file config/xarm6.yaml``: its joints on /joint_states, its URDF on
    /robot_description (sensor frame xarm_gripper_base_link), at rest the wrench is the
    gravity wrench of the gripper's ground truth, and driven into the ground it warns of the
    collision."""
    from com_core.robot.model import RobotModel

    xarm = read_robot_config("xarm6")
    process = start_node(
        "sim_node",
        "wrench_sim",
        {"rate": RATE, "real_time_factor": 4.0, "sensor_profile": "ideal"},
        args=["--ros-args", "--params-file", str(XARM_FILE)],
    )
    client = Client(rclpy_context)
    texts: list[str] = []
    client.node.create_subscription(
        String, ROBOT_DESCRIPTION_TOPIC, lambda m: texts.append(m.data), LATCHED
    )
    try:
        ready = client.spin_until(
            lambda: texts and client.hand_truth and client.joint_state and client.gripper_state,
            timeout=40.0,
        )
        assert ready, f"sim did not come up:\n{log_tail(process.log_path)}"
        assert tuple(client.joint_state.name) == xarm.arm_joints
        assert_allclose(client.joint_state.position, xarm.home_joints, atol=1e-3)
        assert tuple(client.gripper_state.name) == xarm.gripper_joints
        assert client.gripper_state.position[0] == xarm.gripper_open
        robot = RobotModel(texts[0], xarm.sensor_frame, xarm.base_frame)
        assert robot.joint_names == xarm.arm_joints  # rigid mode: the gripper's joints fixed
        client.wait_sim(0.3)
        start = round(client.sim_time * 1e9)
        client.wait_sim(0.5)
        window = np.array([w for s, w in client.wrenches if s > start])
        assert len(window) > 0.4 * RATE
        state = client.joint_state
        g_sensor = robot.gravity_in_sensor(dict(zip(state.name, state.position, strict=True)))
        hand = client.hand_truth[-1].inertia
        assert hand.m == pytest.approx(0.7514296, abs=1e-6)
        expected = gravity_wrench(hand.m, [hand.com.x, hand.com.y, hand.com.z], g_sensor)
        error = window.mean(axis=0) - expected
        assert np.abs(error[:3]).max() < 2e-3, error
        assert np.abs(error[3:]).max() < 2e-4, error
        assert "ready: robot xarm6" in process.log_path.read_text()
        # beside the stand (joint 1 a quarter turn), then the fingertips into the ground
        beside = list(xarm.pick_joints)
        beside[0] = math.pi / 2
        into = list(beside)
        into[1] += 0.6
        client.send_trajectory(xarm.arm_joints, [(3.0, beside), (5.0, into)])

        def warned() -> bool:
            return any(
                "[WARN]" in line and "collision: link" in line
                for line in process.log_path.read_text().splitlines()
            )

        assert client.spin_until(warned, 30.0), log_tail(process.log_path)
        assert process.poll() is None
    finally:
        client.node.destroy_node()


def test_a_robot_configuration_that_does_not_serve_stops_the_node(start_node, tmp_path):
    """A parameters file naming a sensor frame its URDF lacks: an ERROR naming it, exit 1."""
    text = XARM_FILE.read_text().replace(
        "sensor_frame: xarm_gripper_base_link", "sensor_frame: ft_flange"
    )
    assert "ft_flange" in text
    bad = tmp_path / "bad_robot.yaml"
    bad.write_text(text)
    process = start_node("sim_node", "wrench_sim", args=["--ros-args", "--params-file", str(bad)])
    assert process.wait(timeout=30) == 1
    log = process.log_path.read_text()
    assert "[ERROR]" in log and "sensor_frame 'ft_flange' is not a frame of the URDF" in log, log
    assert "Traceback" not in log, log
