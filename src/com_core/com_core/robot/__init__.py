"""The arm: its configuration files, its kinematic model from the URDF, inverse
kinematics, the choreography of an exploration's poses, the wrench a load exerts on the
sensor in motion, and its joint states merged per joint from several publishers.
"""

from com_core.robot.choreography import (
    AXES,
    MAX_PIVOT_SHIFT,
    QUINTIC_PEAK,
    VERIFY_AXIS,
    VERIFY_POSE,
    VERIFY_TILT,
    Choreography,
    PoseUnreachable,
    TiltPlan,
)
from com_core.robot.config import (
    BAG_ROBOT_FILE,
    CONFIG_DIR,
    ROBOTS,
    RobotConfig,
    RobotConfigError,
    default_robot_config,
    grasp_point,
    read_robot_config,
    robot_config_path,
    robot_problems,
    urdf_file,
    write_robot_config,
)
from com_core.robot.dynamics import (
    inertial_parameters,
    load_of,
    sensor_regressor,
)
from com_core.robot.inverse_kinematics import (
    IkResult,
    largest_reachable_tilt,
    solve_pose,
)
from com_core.robot.joint_states import JointStates
from com_core.robot.model import (
    DEFAULT_GRAVITY,
    KinematicsError,
    RobotModel,
)

__all__ = [
    "AXES",
    "BAG_ROBOT_FILE",
    "CONFIG_DIR",
    "DEFAULT_GRAVITY",
    "MAX_PIVOT_SHIFT",
    "QUINTIC_PEAK",
    "ROBOTS",
    "VERIFY_AXIS",
    "VERIFY_POSE",
    "VERIFY_TILT",
    "Choreography",
    "IkResult",
    "JointStates",
    "KinematicsError",
    "PoseUnreachable",
    "RobotConfig",
    "RobotConfigError",
    "RobotModel",
    "TiltPlan",
    "default_robot_config",
    "grasp_point",
    "inertial_parameters",
    "largest_reachable_tilt",
    "load_of",
    "read_robot_config",
    "robot_config_path",
    "robot_problems",
    "sensor_regressor",
    "solve_pose",
    "urdf_file",
    "write_robot_config",
]
