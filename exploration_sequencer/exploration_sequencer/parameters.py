"""The sequencer's parameters: name, default, meaning and range (``com_core.inputs``).

An Explore goal's options and the demo's flags that set them are checked against the
same rows. Besides these, the node reads every key of a robot configuration
(``com_core.robot.config``), read-only.
"""

from __future__ import annotations

import math

from com_core.estimation.runs.motion_solution import EXCITATIONS, STATIC
from com_core.inputs import Input, table_of
from com_core.planning.excitation import DEFAULT_ACCELERATION
from com_core.planning.motion_accuracy import DENSITY_GUESS, HAND_CYCLES, MAX_CYCLES, PERIODS

__all__ = ["PARAMETERS"]

# a tilt well beyond the arm's rest tolerance (5 mrad), else a pose is taken for the last
_TILT = dict(unit="rad", low=0.01, high=math.pi / 2, high_open=True)
_DWELL = dict(unit="s", low=0.1, high=300.0)  # 100 samples at 1 kHz and more
_WAIT = dict(unit="s", low=0.5, high=600.0)
_PLAN_NOISE = "for the prediction until a tare pass of the hand in the tare cache has learnt it"


def _distinct(axes: list[str]) -> str:
    return "" if len(set(axes)) == len(axes) else "names an axis twice"


PARAMETERS = table_of([
    Input("excitation", STATIC, "how the load is excited: 'static' (windows at rest at "
          "tilted poses: mass and COM) or 'motion' (a designed wrist motion: mass, COM and "
          "inertia; needs the estimator's kinematic information)", kind="str",
          choices=EXCITATIONS),
    Input("motion_period", 3.0, "with excitation 'motion': the excitation's period, the time "
          "of each motion (the empty hand's, the object's and the verification's)", unit="s",
          low=1.0, high=30.0),
    Input("motion_cycles", 1, "with excitation 'motion': how many periods the object's "
          "motion runs (and the empty hand's, at least; the noise's share of the inertia's "
          "variance goes as 1 / cycles, the calibration's stays; python -m "
          "com_core.planning.motion_accuracy says how many a target needs)", kind="int",
          low=1, high=MAX_CYCLES),
    Input("hand_motion_cycles", HAND_CYCLES, "with excitation 'motion': how many periods "
          "the empty hand's motion runs when it moves (as many as motion_cycles if fewer): "
          "its fit is taken off the object's, in this run and in each later one that reuses "
          "it, so over a motion as long as the object's half the noise's share of the "
          "object's variance is the hand's, and over n times as long 1 / n of the object's "
          "share", kind="int", low=1, high=MAX_CYCLES),
    Input("motion_acceleration", DEFAULT_ACCELERATION, "with excitation 'motion': the "
          "bound on each wrist joint's acceleration, within the arm's own limits where its "
          "configuration states them (max_joint_acceleration): a faster motion tells the "
          "inertia more in less time, with a shorter motion_period (python -m "
          "com_core.planning.motion_accuracy weighs a longer motion against a faster one); "
          "the load's acceleration grows with it, and the grasp must hold it",
          unit="rad/s^2", low=1.0, high=100.0),
    Input("target_inertia", 0.0, "with excitation 'motion': the largest 1-sigma of each "
          "principal moment, as a fraction of it, for a guessed object (a solid box of "
          f"mass_guess at {DENSITY_GUESS:g} kg/m^3, edges 2:3:4, its COM at com_guess): the "
          f"run takes the fastest motion that meets it (periods "
          f"{', '.join(f'{p:g}' for p in PERIODS)} s and motion_period, within "
          "motion_acceleration or the arm's own limits, up to "
          f"{MAX_CYCLES} cycles; planning.motion_accuracy), or is refused before anything "
          "moves when none does (0: the motion as set)", low=0.0, high=10.0),
    Input("tilt", math.pi / 6, "wrist tilt from home about each axis", **_TILT,
          fix="a tilt the wrist makes from home, e.g. 0.52 (30 deg)"),
    Input("tilt_axes", ["y", "x"], "sensor axes to tilt about (the pass visits y first)",
          kind="strings", choices=("y", "x"), lengths=(1, 2), check=_distinct),
    Input("both_directions", True, "tilt +tilt and -tilt about each axis (false: the "
          "paper's one)", kind="bool"),
    Input("dwell", 0.9, "samples per object window", **_DWELL),
    Input("tare_dwell", 5.0, "samples per tare window (empty hand; cached per hand)", **_DWELL),
    Input("settle", 0.3, "wait after a motion before a window starts", unit="s", low=0.0,
          high=10.0),
    Input("speed", 1.35, "mean joint speed, capped per joint by the URDF's velocity limits",
          unit="rad/s", low=0.01, high=10.0),
    Input("preview", False, "plan the run, log every move's joint targets and the largest "
          "joint excursion, and end [PREVIEW] without moving the arm (a first run on a real "
          "arm: config/real_robot.yaml)", kind="bool"),
    Input("max_tilt", math.pi / 6, "the largest tilt the object allows (a full mug: small)",
          **_TILT),
    Input("raise_tilt", False, "with target_com_sigma: the tilt may be raised up to max_tilt",
          kind="bool"),
    Input("target_com_sigma", 0.0, "extend dwell until the predicted COM sigma meets it "
          "(0: off)", unit="m", low=0.0, high=0.1),
    Input("fewer_poses", False, "with target_com_sigma: the planner may drop poses for a "
          "shorter pass", kind="bool"),
    Input("max_object_time", 20.0, "(sim) the object pass may take when meeting "
          "target_com_sigma", unit="s", low=1.0, high=3600.0),
    Input("sigma_f", 0.1, f"the sensor's force noise per sample, {_PLAN_NOISE}", unit="N",
          low=1e-6, high=100.0),
    Input("sigma_tau", 0.005, "the sensor's torque noise per sample (as sigma_f)",
          unit="N m", low=1e-7, high=10.0),
    Input("correlation_time", 0.005, "the sensor's noise correlation time (its first-order "
          "low-pass), for the prediction (as sigma_f)", unit="s", low=0.0, high=1.0),
    Input("rate", 1000.0, "the sensor's rate (for the prediction)", unit="Hz", low=1.0,
          high=100_000.0),
    Input("mass_guess", 0.1, "a guess of the object's mass (for the prediction)", unit="kg",
          low=1e-3, high=100.0),
    Input("com_guess", [0.0], "a guess of the COM in ft_sensor ([0.0]: the grasp centre)",
          kind="floats", unit="m", low=-1.0, high=1.0, lengths=(3,), keep=([0.0],)),
    Input("sim_timeout", 5.0, "(wall) without /joint_states before a run fails", **_WAIT),
    Input("estimate_timeout", 10.0, "(wall) to wait for the estimator: to hear us, to answer",
          **_WAIT),
    Input("bag_dir", "bags", "directory that receives one rosbag2 directory per run",
          kind="str", check=lambda v: "" if v.strip() else "must name a directory"),
    Input("tare_cache", "", "file of the cached tare pass ('': <bag_dir>/tare_cache.json)",
          kind="str"),
    Input("tare_max_age", 3600.0, "a cached tare older than this is taken again", unit="s",
          low=0.0, high=1e9),
    Input("bias_dwell", 3.0, "the empty-hand windows at home before the grasp (with a cached "
          "tare) and, with kinematic information, after the release: they give the run's "
          "sensor bias and its drift (with the wrenches alone, the first checks the cache's "
          "drift)", **_DWELL),
    Input("verify_dwell", 2.0, "the window at the verification pose (20 deg about the "
          "sensor's diagonal, no fit uses it) after the object pass, with kinematic "
          "information; 0: none", unit="s", low=0.0, high=300.0),
    Input("release", True, "put the object back on its stand after the run (false: the run "
          "ends holding it at home, for the compensated wrench; no empty-hand window after "
          "it)", kind="bool"),
    Input("min_load", 0.005, "the grasp must hold at least this before the object pass, "
          "less what the estimator's stated hysteresis can move the reading by since the "
          "tare (then a warning)", unit="kg", low=0.0, high=100.0),
    Input("grasp_check_dwell", 0.2, "samples at home after lifting that check the grasp",
          unit="s", low=0.05, high=300.0),
    Input("arm_interface", "action", "how the arm is commanded: 'action' (the "
          "control_msgs/action/FollowJointTrajectory of its trajectory controller, the robot "
          "configuration's arm_action; each result is checked) or 'topic' (its "
          "JointTrajectory topic /arm_controller/joint_trajectory; no result)", kind="str",
          choices=("action", "topic")),
    Input("gripper_interface", "action", "how the gripper is commanded: 'action' (its "
          "control_msgs/action/GripperCommand, the robot configuration's gripper_action; the "
          "result confirms the grasp) or 'topic' (one Float64MultiArray value on "
          "/gripper_controller/commands, then 0.6 s (sim) of waiting)", kind="str",
          choices=("action", "topic")),
    Input("gripper_max_effort", 20.0, "the gripper action's max_effort: the force the fingers "
          "may grip with (0: the gripper's own limit)", unit="N", low=0.0, high=1000.0),
    Input("gripper_timeout", 10.0, "(wall) for the gripper action's server and its result",
          **_WAIT),
])  # fmt: skip
"""The parameters by name."""
