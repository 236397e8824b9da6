"""The wire contract: every name the nodes, the replay, the recorder, the benchmarks and
the tests share, written once (docs/design.md, Wire contract).

Topics, services, message types, the estimator's status names and keys, the pose labels
and the diagnostic levels; the arm's joints and gripper are its robot configuration's
(``robot_config``). Nothing here imports rclpy; QoS profiles
stay with the nodes that create them (docs/design.md lists them).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Protocol

__all__ = [
    "APPLIED_WRENCH_TOPIC",
    "APPLY_WRENCH_TOPIC",
    "ARM_COMMAND_TOPIC",
    "ARM_SENT_TOPIC",
    "BEST_EFFORT_TOPICS",
    "CANCELLED",
    "CLOCK_TOPIC",
    "COMPENSATED_TOPIC",
    "COMPENSATION_STATUS_NAME",
    "DIAGNOSTICS_TOPIC",
    "DIAGNOSTIC_NAME",
    "DONE",
    "ERROR",
    "ESTIMATE_TOPIC",
    "ESTIMATOR_PARAMETERS_SERVICE",
    "ESTIMATOR_RESET_SERVICE",
    "ESTIMATOR_SAVE_PAYLOAD_SERVICE",
    "ESTIMATOR_SET_PARAMETERS_SERVICE",
    "ESTIMATOR_SOLVE_SERVICE",
    "EXPLORE_SERVICE",
    "GRIPPER_SENT_TOPIC",
    "HAND_COMMAND_TOPIC",
    "HAND_TRUTH_TOPIC",
    "INPUT_STATUS_NAME",
    "INTERNAL_ERROR",
    "JOINT_STATES_TOPIC",
    "LATCHED_TOPICS",
    "LATEST_LABEL_KEY",
    "LATEST_STAMP_KEY",
    "LIVE_STATUS_NAME",
    "MOTION_LEAD",
    "MOTION_OBJECT",
    "MOTION_PREFIX",
    "MOTION_REST",
    "MOTION_TARE",
    "MOTION_VERIFY",
    "MOVING",
    "OBJECT_PREFIX",
    "OBJECT_TOPIC",
    "OK",
    "POSE_TOPIC",
    "ROBOT_DESCRIPTION_TOPIC",
    "RUN_CANCELLED",
    "SIM_PARAMETERS_SERVICE",
    "STATIC_PREFIXES",
    "TARE_PREFIX",
    "TOPIC_TYPES",
    "TRUTH_MOVE_M",
    "TRUTH_TOPIC",
    "VERIFY_PREFIX",
    "WARN",
    "WINDOW_PREFIXES",
    "WRENCH_TOPIC",
    "done_stamp",
    "heard_stamps",
    "level_of",
    "status_of",
]

# --- topics (absolute names; remap with --ros-args -r) ---------------------------------
WRENCH_TOPIC = "/ft_sensor/wrench"
"""geometry_msgs/WrenchStamped: the load's wrench on the sensor, frame ``ft_sensor``."""
COMPENSATED_TOPIC = "/ft_sensor/wrench_compensated"
"""geometry_msgs/WrenchStamped: each wrench of WRENCH_TOPIC (same stamp and frame) less the
sensor's bias and the gravity of the hand and the payload at that sample's orientation:
the contact wrench (docs/design.md, Compensated wrench)."""
JOINT_STATES_TOPIC = "/joint_states"
CLOCK_TOPIC = "/clock"
TRUTH_TOPIC = "/wrench_sim/ground_truth"
"""geometry_msgs/InertiaStamped: the object's mass and COM in ``ft_sensor`` (latched)."""
HAND_TRUTH_TOPIC = "/wrench_sim/hand_ground_truth"
APPLY_WRENCH_TOPIC = "/wrench_sim/apply_wrench"
"""geometry_msgs/WrenchStamped: a push on the held object from ``header.stamp`` (sim time)
for the sim's ``push_duration``; frame ``world`` or the sensor's (``ft_sensor``)."""
APPLIED_WRENCH_TOPIC = "/wrench_sim/applied_wrench"
"""geometry_msgs/WrenchStamped: the push as the sensor reads it (frame ``ft_sensor``, about
its origin) at each wrench stamp while it lasts, then one zero wrench."""
OBJECT_TOPIC = "/wrench_sim/object"
"""std_msgs/String: ``shape=box mass=0.1000 grasp_mode=rigid state=held`` (latched)."""
ARM_COMMAND_TOPIC = "/arm_controller/joint_trajectory"
"""trajectory_msgs/JointTrajectory: the arm's joints (its robot configuration's
``arm_joints``): the arm controller's topic interface, beside its FollowJointTrajectory
action (the configuration's ``arm_action``); remap to the arm's controller
(``--ros-args -r``)."""
ARM_SENT_TOPIC = "/exploration_sequencer/arm_trajectory"
"""trajectory_msgs/JointTrajectory: each trajectory the sequencer sends the arm, as sent
(stamp and points), whether through the action or the topic: the bag keeps what a recorder
of topics does not see of an action."""
HAND_COMMAND_TOPIC = "/gripper_controller/commands"
"""std_msgs/Float64MultiArray: one value, the gripper's command (the robot configuration's
``gripper_open`` .. ``gripper_closed``; m per finger on the Panda, rad on the xArm): the
gripper's topic interface, beside its GripperCommand action (the configuration's
``gripper_action``)."""
GRIPPER_SENT_TOPIC = "/exploration_sequencer/gripper_command"
"""control_msgs/GripperCommand: each gripper command the sequencer sends, as sent (position in
the units of ``gripper_open``, max_effort N), whether through the action or the topic: the
bag keeps what a recorder of topics does not see of an action."""
POSE_TOPIC = "/exploration_sequencer/pose"
"""std_msgs/Header: frame_id the label, stamp the sensor time from which it applies."""
ESTIMATE_TOPIC = "/com_estimator/estimate"
"""geometry_msgs/InertiaStamped: usable estimates only (docs/design.md, Statuses)."""
DIAGNOSTICS_TOPIC = "/diagnostics"
ROBOT_DESCRIPTION_TOPIC = "/robot_description"
"""std_msgs/String: the URDF the robot runs (latched, as robot_state_publisher does)."""

TOPIC_TYPES = {
    CLOCK_TOPIC: "rosgraph_msgs/msg/Clock",
    WRENCH_TOPIC: "geometry_msgs/msg/WrenchStamped",
    COMPENSATED_TOPIC: "geometry_msgs/msg/WrenchStamped",
    APPLIED_WRENCH_TOPIC: "geometry_msgs/msg/WrenchStamped",
    JOINT_STATES_TOPIC: "sensor_msgs/msg/JointState",
    TRUTH_TOPIC: "geometry_msgs/msg/InertiaStamped",
    HAND_TRUTH_TOPIC: "geometry_msgs/msg/InertiaStamped",
    OBJECT_TOPIC: "std_msgs/msg/String",
    ARM_COMMAND_TOPIC: "trajectory_msgs/msg/JointTrajectory",
    ARM_SENT_TOPIC: "trajectory_msgs/msg/JointTrajectory",
    HAND_COMMAND_TOPIC: "std_msgs/msg/Float64MultiArray",
    GRIPPER_SENT_TOPIC: "control_msgs/msg/GripperCommand",
    POSE_TOPIC: "std_msgs/msg/Header",
    ESTIMATE_TOPIC: "geometry_msgs/msg/InertiaStamped",
    DIAGNOSTICS_TOPIC: "diagnostic_msgs/msg/DiagnosticArray",
    ROBOT_DESCRIPTION_TOPIC: "std_msgs/msg/String",
}
"""Every topic of a run and its message type (what a run bag records)."""
LATCHED_TOPICS = frozenset(
    {
        TRUTH_TOPIC,
        HAND_TRUTH_TOPIC,
        OBJECT_TOPIC,
        POSE_TOPIC,
        ESTIMATE_TOPIC,
        ROBOT_DESCRIPTION_TOPIC,
    }
)
"""Published transient local (depth 1): a late joiner gets the latest message."""
BEST_EFFORT_TOPICS = frozenset({CLOCK_TOPIC, WRENCH_TOPIC, COMPENSATED_TOPIC, JOINT_STATES_TOPIC})
"""The high-rate streams, best effort; every other topic is reliable."""

# --- services -----------------------------------------------------------------------
EXPLORE_SERVICE = "/exploration_sequencer/explore"
"""std_srvs/Trigger, and the com_interfaces/action/Explore action of the same name."""
ESTIMATOR_SOLVE_SERVICE = "/com_estimator/solve"
ESTIMATOR_RESET_SERVICE = "/com_estimator/reset"
ESTIMATOR_SAVE_PAYLOAD_SERVICE = "/com_estimator/save_payload"
ESTIMATOR_PARAMETERS_SERVICE = "/com_estimator/get_parameters"
ESTIMATOR_SET_PARAMETERS_SERVICE = "/com_estimator/set_parameters"
SIM_PARAMETERS_SERVICE = "/wrench_sim/get_parameters"

# --- pose labels (frame_id of a POSE_TOPIC message) -----------------------------------
TARE_PREFIX = "tare/"
"""``tare/<pose>``: a static window of the empty hand."""
OBJECT_PREFIX = "object/"
"""``object/<pose>``: a static window with the object in the hand."""
VERIFY_PREFIX = "verify/"
"""``verify/<pose>``: a static window with the object in the hand at a pose no fit uses,
where the compensated wrench is checked (``verification``)."""
MOTION_PREFIX = "motion/"
"""``motion/<what>``: a span of the wrist's excitation, fitted along the motion
(``com_core.estimation.runs.motion_solution``): one of the three below."""
MOTION_TARE = MOTION_PREFIX + "tare"
"""The excitation with the empty hand."""
MOTION_OBJECT = MOTION_PREFIX + "object"
"""The excitation with the object in the hand."""
MOTION_VERIFY = MOTION_PREFIX + "verify"
"""Another motion with the object, that no fit uses: the compensated wrench is checked
along it."""
MOTION_LEAD = 0.5
"""s between sending an excitation and its start, the arm still at its first point (a
stamp the controller got late would jump the arm): the joint states reach before the
span's first wrench."""
MOTION_REST = 0.3
"""s at rest at the end of every ``motion/`` span, after the motion itself: the joint
states reach beyond its last wrench. The fits leave it out: over whole periods of the
excitation, with the joint states on both sides, the empty hand's fit over more of them
than the object's weighs each as the object's does, and the calibration's error on the
hand's wrench cancels between them."""
STATIC_PREFIXES = (TARE_PREFIX, OBJECT_PREFIX, VERIFY_PREFIX)
"""The labels that open a static window."""
WINDOW_PREFIXES = (*STATIC_PREFIXES, MOTION_PREFIX)
"""The labels that open a static window or a motion's span."""
MOVING = "moving"
"""Ends a window; the arm moves (also the handshake label)."""
DONE = "done"
"""Ends the exploration: solve from the windows before it."""
CANCELLED = "cancelled"
"""Ends an exploration that was cancelled: its windows are dropped, nothing is solved."""
INTERNAL_ERROR = "internal error"
"""How a node, the replay or the demo names an exception that reached its top level: a
defect of this project, never a user's input (which is refused by name where it enters,
``com_core.inputs``). Each is logged with its traceback and counted."""


def done_stamp(labels: Sequence[tuple[int, str]]) -> int | None:
    """Stamp (ns) of the first ``done`` that arrived after a window label, or None.

    ``labels``: (stamp ns, label) in arrival order. A ``done`` with no window label
    (``tare/``, ``object/``, ``verify/``, ``motion/``) before it ends an earlier
    exploration (the latched label a late-joining subscriber or a recorder gets first),
    not this one; with a
    restarted clock its stamp could fall anywhere, so the order of arrival decides, not
    the stamp.
    """
    seen_window = False
    for stamp, label in labels:
        if label.startswith(WINDOW_PREFIXES):
            seen_window = True
        elif label == DONE and seen_window:
            return stamp
    return None


# --- the estimator's statuses on DIAGNOSTICS_TOPIC ------------------------------------
DIAGNOSTIC_NAME = "com_estimator: exploration"
"""The status of each solution: level, reason, mass, com_x..z, sigmas, chi2, ..."""
LIVE_STATUS_NAME = "com_estimator: live"
"""The estimate so far, each time an object window closes (mass, com_x..z and their
sigmas, the windows it has): progress, never a result (not on ESTIMATE_TOPIC)."""
INPUT_STATUS_NAME = "com_estimator: input"
"""The 1 Hz status of the wrench input."""
COMPENSATION_STATUS_NAME = "com_estimator: compensation"
"""The 1 Hz status of COMPENSATED_TOPIC: its payload's source, the samples published and
those left out (stale joint states), or why nothing is published."""
LATEST_STAMP_KEY = "latest_stamp_ns"
"""Input status key: the stamp of the latest wrench the estimator heard, ns."""
LATEST_LABEL_KEY = "latest_label_ns"
"""Input status key: the stamp of the latest label it heard, ns (absent before one)."""

OK, WARN, ERROR = "OK", "WARN", "ERROR"
RUN_CANCELLED = "CANCELLED"
"""The status of a cancelled exploration run (the Explore action's result), beside the
estimator's three."""
_LEVELS = {OK: 0, WARN: 1, ERROR: 2}
_STATUSES = {0: OK, 1: WARN, 2: ERROR, 3: "STALE"}


def level_of(status: str) -> bytes:
    """diagnostic_msgs/DiagnosticStatus level of a status (0 OK, 1 WARN, 2 ERROR), as the
    one byte rclpy's message field takes (an int there is not a level)."""
    return bytes([_LEVELS[status]])


def status_of(level: int | bytes) -> str:
    """The status text of a DiagnosticStatus level (an int, or the one byte rclpy gives)."""
    if isinstance(level, bytes):
        level = level[0]
    return _STATUSES.get(int(level), "ERROR")


class _KeyValue(Protocol):
    key: str
    value: str


class _Status(Protocol):
    name: str
    level: int | bytes
    values: Iterable[_KeyValue]


def heard_stamps(status: _Status) -> tuple[int, int | None] | None:
    """(latest wrench stamp, latest label stamp or None), ns, of the estimator's input
    status; None for any other status or an input status that is not OK."""
    if status.name != INPUT_STATUS_NAME or status_of(status.level) != OK:
        return None
    values = {kv.key: kv.value for kv in status.values}
    if LATEST_STAMP_KEY not in values:
        return None
    label = values.get(LATEST_LABEL_KEY)
    return int(values[LATEST_STAMP_KEY]), None if label is None else int(label)


# --- the sim -----------------------------------------------------------------------
TRUTH_MOVE_M = 5e-5
"""m; the simulator republishes the ground truth when the COM moves this much in the hand."""
