"""Writes docs/nodes.md: every node's topics, services and parameters.

The parameter tables are read from the code that declares them, so the page cannot drift
from what ``ros2 param describe`` says:

- ``sim_node``: ``wrench_sim.parameters.PARAMETERS``;
- ``estimator_node``: ``com_core.estimation.runs.settings.SETTINGS`` (the replay's options too)
  and the node's own rows of ``com_estimator.estimator_node.PARAMETERS``;
- ``sequencer_node``: ``exploration_sequencer.parameters.PARAMETERS``;
- the robot configuration's keys (sim and sequencer, read-only):
  ``com_core.robot.config.declared_parameters()``.

Topic and service names and types come from ``com_core.contract``; what each carries is
written here. Run from the workspace with its environment (``source ./env.sh``)::

    python docs/nodes.py > docs/nodes.md
    python docs/nodes.py --check    # exit 1 when docs/nodes.md differs
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "nodes.md"
# The source trees, ahead of any installed copy: the page describes the code as it is.
for _tree in ("exploration_sequencer", "com_estimator", "wrench_sim", "src/com_core"):
    sys.path.insert(0, str(ROOT / _tree))

from com_core import contract as c  # noqa: E402
from com_core.estimation.runs.settings import SETTINGS  # noqa: E402
from com_core.inputs import Input  # noqa: E402
from com_core.robot.config import (  # noqa: E402
    DEFAULT_ARM_ACTION,
    DEFAULT_GRIPPER_ACTION,
    declared_parameters,
)
from com_estimator.estimator_node import PARAMETERS as ESTIMATOR_PARAMETERS  # noqa: E402
from exploration_sequencer.parameters import PARAMETERS as SEQUENCER_PARAMETERS  # noqa: E402
from wrench_sim.parameters import PARAMETERS as SIM_PARAMETERS  # noqa: E402

TRIGGER = "std_srvs/srv/Trigger"
GET_PARAMETERS = "rcl_interfaces/srv/GetParameters"
SET_PARAMETERS = "rcl_interfaces/srv/SetParameters"


def value_text(value: object) -> str:
    """A default as a reader types it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "NaN"
        if value == math.pi / 6:
            return "pi/6"
        return repr(value) if len(repr(value)) <= 8 else f"{value:.6g}"
    if isinstance(value, str):
        return value or "''"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    if type(value).__name__ == "Type":  # rclpy's Parameter.Type: declared without a value
        return "unset"
    return str(value)


def cell(text: str) -> str:
    """Text inside a table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(x) for x in row) + " |" for row in rows]
    return [*lines, ""]


def gripper_action(kind: str, notes: str) -> tuple[str, ...]:
    """A row of the gripper's action: its default name and the configuration's key."""
    return (
        f"`{DEFAULT_GRIPPER_ACTION}` (the configuration's `gripper_action`)",
        "`control_msgs/action/GripperCommand`",
        kind,
        notes,
    )


def arm_action(kind: str, notes: str) -> tuple[str, ...]:
    """A row of the arm's action: its default name and the configuration's key."""
    return (
        f"`{DEFAULT_ARM_ACTION}` (the configuration's `arm_action`)",
        "`control_msgs/action/FollowJointTrajectory`",
        kind,
        notes,
    )


def interface(name: str, kind: str, notes: str, type_: str | None = None) -> tuple[str, ...]:
    """A row of a node's topics or services; topic types from the contract."""
    type_ = type_ or c.TOPIC_TYPES[name]
    return (f"`{name}`", f"`{type_}`", kind, notes)


INTERFACE_HEADER = ("name", "type", "", "what")
PARAMETER_HEADER = ("parameter", "default", "takes", "what")


def parameter_rows(rows: Iterable[Input]) -> list[tuple[str, ...]]:
    """A parameter table's rows: name, default, what it takes (refused otherwise, before
    anything moves), meaning."""
    return [
        (f"`{row.name}`", f"`{value_text(row.default)}`", row.allowed(), row.description)
        for row in rows
    ]


def sim_node() -> list[str]:
    rows = [
        interface(c.CLOCK_TOPIC, "out", "sim time, `clock_rate` Hz of sim time"),
        interface(
            c.WRENCH_TOPIC, "out", "frame `ft_sensor`, sim-time stamps, `rate` Hz (the sensor)"
        ),
        interface(
            c.JOINT_STATES_TOPIC,
            "out",
            "the configuration's `joint_state_rate` (Panda 1 kHz), sim time; its `arm_joints`, "
            "then `gripper_joints` (rigid mode: the virtual gripper's position)",
        ),
        interface(
            c.TRUTH_TOPIC,
            "out",
            "the object's m and COM in `ft_sensor`; latched; on grasp, release and when the "
            f"COM moves more than {c.TRUTH_MOVE_M * 1e3:g} mm in the hand",
        ),
        interface(
            c.HAND_TRUTH_TOPIC,
            "out",
            "every link beyond the sensor (hand or gripper, fingers) from the URDF; latched",
        ),
        interface(
            c.OBJECT_TOPIC,
            "out",
            "`shape=box mass=0.1000 grasp_mode=rigid state=held`, with each held / not held "
            "change; latched",
        ),
        interface(
            c.ROBOT_DESCRIPTION_TOPIC,
            "out",
            "the URDF it loaded (rigid mode: the copy with the gripper's joints fixed open); "
            "latched",
        ),
        interface(
            c.ARM_COMMAND_TOPIC,
            "in",
            "the configuration's `arm_joints`, as the Jazzy joint_trajectory_controller: "
            "replaces the running trajectory on arrival, runs from the measured state to the "
            "first point at `header.stamp` + time_from_start (0: now), linear, cubic or "
            "quintic by what the points carry; position control",
        ),
        interface(
            c.HAND_COMMAND_TOPIC,
            "in",
            "one value, the gripper's command, `gripper_open` .. `gripper_closed` (Panda: m "
            "per finger, 0.04 open, 0 closed; xArm6: rad, 0 open, 0.85 closed); aborts a "
            "running gripper goal",
        ),
        interface(
            c.APPLY_WRENCH_TOPIC,
            "in",
            "a push on the held object: force at its COM and a couple, frame `world` or "
            "`ft_sensor`, from `header.stamp` (0: now) for `push_duration` s; pushes add up",
            c.TOPIC_TYPES[c.APPLIED_WRENCH_TOPIC],
        ),
        interface(
            c.APPLIED_WRENCH_TOPIC,
            "out",
            "the push as the sensor reads it (`ft_sensor`, about its origin), with each wrench "
            "sample's stamp while it acts, then one zero",
        ),
    ]
    services = [
        arm_action(
            "action server",
            "the arm as a Jazzy joint_trajectory_controller serves it: the trajectory of the "
            "topic, checked in the goal callback (rejected with an ERROR log naming what is "
            "wrong); path and goal tolerances per joint (0: the configuration's "
            "`goal_tolerance` and `stopped_velocity_tolerance`), `goal_time_tolerance`; "
            "result codes SUCCESSFUL, PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED, "
            "INVALID_GOAL (replaced by a newer goal or a topic trajectory); cancel holds the "
            "arm where it is; feedback every 50 ms",
        ),
        gripper_action(
            "action server",
            "the gripper as real grippers' drivers serve it: `command.position` in "
            "`gripper_open` .. `gripper_closed` (Panda: m per finger, as franka_gripper's; "
            "xArm6: rad), `command.max_effort` N (caps the fingers' force; 0: `grip_force`); "
            "a goal outside these is rejected. The fingers stop on the object. Ends "
            "succeeded with `reached_goal` within 2 % of the stroke of the goal, or "
            "`stalled` when the fingers stayed still 0.1 s (sim) short of it (on the "
            "object: position beyond `gripper_closed`, effort the grip force); feedback "
            "(position, effort, stalled, reached_goal) every 50 ms while they move. A new "
            "goal or a topic command aborts the running one; cancel stops the fingers. The "
            "status reads ACCEPTED until the fingers stop",
        ),
    ]
    params = parameter_rows(SIM_PARAMETERS.values())
    return [
        "## wrench_sim: `sim_node`",
        "",
        "pybullet (DIRECT; `-p gui:=true` opens a window), the arm of its robot configuration "
        "on a fixed base (the Franka Panda of pybullet_data by default; `--ros-args "
        "--params-file src/com_core/com_core/config/xarm6.yaml` runs the xArm6 with its "
        "gripper), 1 kHz physics, gravity 9.80665 m/s^2, as fast as it can "
        "(`real_time_factor:=0`) or at a set real-time factor. What its sensor reads and how "
        "exact that is: [design.md, The simulated sensor](design.md#the-simulated-sensor).",
        "",
        "### Topics",
        "",
        *table(INTERFACE_HEADER, rows),
        "A malformed or unreachable command (unknown joint, NaN, wrong lengths, times not "
        "increasing, outside the joint or velocity limits) is logged as rejected and ignored; "
        "so is a push in another frame, with a non-finite value or with no object held.",
        "",
        "### Actions",
        "",
        *table(INTERFACE_HEADER, services),
        "### Parameters",
        "",
        "From `wrench_sim.parameters.PARAMETERS`. A sensor part left at NaN (or `[-1.0]` for a "
        "list) takes the `sensor_profile`'s figure ([design.md, A real sensor]"
        "(design.md#a-real-sensor-correlated-noise-ringing-drift-and-calibration)). Besides "
        "these, every key of the robot configuration, read-only ([Robot configuration]"
        "(#robot-configuration)).",
        "",
        *table(PARAMETER_HEADER, params),
        "`object_com_offset` is the COM minus the body's geometric centre, in the object's "
        "frame (z up, y the fingers' axis). Only the inertial frame moves: the body stands "
        "centred on its stand between the open pads (its centre on the grasp centre at "
        "`pick_joints`) whatever the offset, until the fingers close, and it stays upright "
        "only while its COM is above its base (the box's 0.05 m square, the cylinder's "
        "0.025 m and the mug's 0.028 m radius disc); Bullet tips it over a little inside the "
        "edge (a round base at 0.95 of its radius, upright at 0.9). So the sim accepts only "
        "offsets in `wrench_sim.objects.holdable_com_range(object)`, 0.8 of the base, and "
        "|z| up to the half height (0.04 m, mug 0.045 m), in both grasp modes; any other "
        "offset stops the node at start with a log line that states the range. The seeded "
        "draw is uniform in half the half extents, inside that range. At the range's edge "
        "the object is held and, lifted, its ground truth is the requested offset to 0.07 mm "
        "in either mode. In friction mode whether it stays held through the tilts also "
        "depends on `object_mass` and `grip_force`: at 5 N per finger every edge offset "
        "tried held through seven orientations at 0.1 and 0.3 kg; at 0.6 kg the box and the "
        "cylinder with the COM at (0.02, 0, -0.04) m, low and far from the pads, dropped out "
        "with gravity along the finger axis.",
        "",
    ]


def estimator_node() -> list[str]:
    rows = [
        interface(
            c.WRENCH_TOPIC,
            "in",
            "best effort, depth 5000; raw CDR decoded in batches with numpy",
        ),
        interface(
            c.POSE_TOPIC,
            "in",
            "the sequencer's pose labels (latched); `cancelled` drops the run's windows",
        ),
        interface(c.JOINT_STATES_TOPIC, "in", "each window's orientation; the compensation"),
        interface(c.ROBOT_DESCRIPTION_TOPIC, "in", "the URDF, unless `robot_description` is set"),
        interface(
            c.ESTIMATE_TOPIC,
            "out",
            "m and COM in `ft_sensor`, and from a run in motion the inertia about the COM "
            "when the motion told it (every principal moment beyond its sigma); latched, "
            "stamped with the `done` stamp; usable estimates only",
        ),
        interface(
            c.DIAGNOSTICS_TOPIC,
            "out",
            f"`{c.DIAGNOSTIC_NAME}` at each solution; `{c.LIVE_STATUS_NAME}` each time an "
            "object window closes (the estimate so far, never on `~/estimate`); "
            f"`{c.INPUT_STATUS_NAME}` and "
            f"`{c.COMPENSATION_STATUS_NAME}` once a second (keys: [design.md, Wire contract]"
            "(design.md#wire-contract))",
        ),
        interface(
            c.COMPENSATED_TOPIC,
            "out",
            "best effort; each wrench, with its stamp and frame, less the bias and the gravity "
            "wrench of the hand and the payload at that sample's orientation, once there is a "
            "payload ([design.md, Compensated wrench](design.md"
            "#compensated-wrench-verification-and-payload-files))",
        ),
    ]
    services = [
        interface(c.ESTIMATOR_SOLVE_SERVICE, "server", "estimate now from what has arrived; "
                  "`success` only for OK", TRIGGER),
        interface(c.ESTIMATOR_RESET_SERVICE, "server", "forget the current exploration "
                  "(\"cleared N samples\")", TRIGGER),
        interface(c.ESTIMATOR_SAVE_PAYLOAD_SERVICE, "server", "write the payload files to "
                  "`payload_save_dir`; the answer names them, or why not", TRIGGER),
    ]  # fmt: skip
    settings = [
        (*row, "`--tare`" if name == "tare_cache" else f"`--{name.replace('_', '-')}`")
        for name, row in zip(SETTINGS, parameter_rows(SETTINGS.values()), strict=True)
    ]
    own = parameter_rows(row for name, row in ESTIMATOR_PARAMETERS.items() if name not in SETTINGS)
    return [
        "## com_estimator: `estimator_node`",
        "",
        "Groups the wrenches into windows by their stamps and the labels' stamps, subtracts "
        "the tare, and on `done` (or `~/solve`) publishes the estimate and the status; then "
        "the compensated wrench. The computation is `com_core.estimation` and "
        "`com_core.payload`; what each status means: [design.md, Statuses]"
        "(design.md#statuses-and-what-each-consumer-sees).",
        "",
        "### Topics",
        "",
        *table(INTERFACE_HEADER, rows),
        "### Services",
        "",
        *table(INTERFACE_HEADER, services),
        "### Parameters",
        "",
        "The estimator's settings, `com_core.estimation.runs.settings.SETTINGS`: the node's "
        "parameters and the replay's options alike, so the replay uses the node's defaults.",
        "",
        *table((*PARAMETER_HEADER, "replay"), settings),
        "The node's own, from `com_estimator.estimator_node.PARAMETERS`:",
        "",
        *table(PARAMETER_HEADER, own),
        "Bad input never stops it: NaN/inf samples, another frame, duplicate stamps, samples "
        "out of time order, labels longer than 128 characters are dropped and counted (WARN); "
        "a window with motion in it is dropped (WARN, or ERROR if too few poses remain); "
        "`done` with no window before it, without tare, too few poses, gravity directions too "
        "close, no load beyond the hand (the object was not held), a load against gravity (a "
        "tare taken with the object in the hand): ERROR with the reason. A sensor clock that "
        "jumps back by more than 1 s (a restarted simulator, a looped bag) starts a new "
        "timeline (a run whose `done` came but whose samples had not reached it is solved "
        "first, on what it has); a label more than `max_label_gap` s after the previous one "
        "drops the exploration before it (a sequencer that died mid-run), so two runs' "
        "windows of one name never merge.",
        "",
        "### `replay BAG [BAG ...]`",
        "",
        "On PATH after `source ./env.sh`. Reads a bag's wrenches and labels and feeds them to "
        "the same core code with the node's defaults: the same messages give the same numbers "
        "(`--json` prints one object per run: mass, com, sigmas, covariance, chi2, status, "
        "method, samples per window, and under `bag` what was read). A BAG may be a "
        "directory of runs (`replay bags/`): each run is replayed on its own, one that fails "
        "never stops the others, and a table of them ends the output (`--json`: JSON Lines). "
        "The exit code is the worst run's: 0 OK or WARN, 1 ERROR, 2 no bag or an option out "
        "of range, 3 an internal error. A kinematic fit takes the sensor and base frames of "
        "the run's robot configuration, `robot.yaml` beside the bag (the sequencer writes "
        "it; `--robot FILE` for another, `--sensor-frame` / `--base-frame` win over both), "
        "and the tare the run reused, `tare.json` beside the bag (`--tare FILE` for another).",
        "",
        "A recording without labels that has joint states and a robot description (the "
        "bag's `/robot_description`, or `--robot-description FILE`, with `--sensor-frame` "
        "and `--base-frame`), or a log that never was ROS (`replay LOG.csv` or `LOG.npz`: "
        "`time`, `fx fy fz tx ty tz` in the sensor frame, and the sensor's orientation as "
        "`qx qy qz qw` or `r11`..`r33`), is fitted as any recording "
        "(`com_core.estimation.recordings.recording_fit`): its rests and the slow motion "
        "between them, whatever the bias, the noise learnt from it, what it could not tell "
        "named (a load that changed: ERROR; orientations about one axis or barely turned, "
        "a drift beyond its prior: WARN), and a self-check (each half predicting the other: "
        "the rms residual per axis, in N, N m and in sigmas). `--tare-recording` (a bag or a "
        "log of the empty tool) gives the object alone, else the whole load beyond the "
        "sensor; `--report FILE.png` draws the recording, the fit and each window's residual.",
        "",
        "A bag without labels nor kinematics is cut into static windows by the core (blocks "
        "of 50 ms at the "
        "noise level, joined while their means agree within 6 standard errors, kept when "
        "longer than 0.3 s), which it sorts by load level: a window's |f| is the gravity load "
        "whatever the orientation, so the empty hand's windows and the loaded hand's form two "
        "levels (apart by more than 0.5 % and 6 standard errors). Each object window is tared "
        "with the tare window, of the bag or of the cached tare, whose force points the same "
        "way within 2 deg; one without such a tare is left out. The sample run without its "
        "labels: 5 object windows, all tared from its tare.json, mass 99.93 +- 0.14 g against "
        "99.97 +- 0.17 g labelled (fitted together, the two levels gave 1093.5 g). With one "
        "load level the estimate is of the whole load beyond the sensor, untared. The output "
        "says which it did.",
        "",
        "A bag rosbags cannot open (an MCAP file cut short by a copy has no Footer) is read "
        "record by record with the `mcap` package up to the cut, and the output says how much "
        "of what metadata.yaml lists it read (the sample cut at 50 % of its bytes: 48 % of "
        "the wrenches; at 90 %: 88 %, every window). A labelled run without its `done` (a run "
        "that died), or cut before the end of its last window, is WARN with the reason (`the "
        "run has no done label: cut short after object/tilt_x+`, and whether metadata.yaml "
        "says its recorder never closed it); the estimate is kept. A chunk whose checksum fails "
        "(a bad sector, a copy gone wrong) is skipped and the rest of the file read through "
        "its chunk index; the run is WARN with the chunk, its time span and the messages lost "
        "per topic where its message index survived. A run that was cancelled (its "
        "`cancelled` label) has its windows dropped, as the node drops them: ERROR, the "
        "reason says it was cancelled.",
        "",
        "### `synthetic_exploration`",
        "",
        "Plays a synthetic exploration (optionally with a fault: `--fault nan|frame|order|"
        "duplicate|motion|no-tare|one-pose|no-windows|long-label`, or an object that moves: "
        "`--shift-sigma`) into a live estimator and records what it sent (`--bag`); several "
        "faults play one exploration each, in order, each with the same stamps. It starts "
        "each exploration only once the estimator's input status reports hearing its lead-in "
        "(`--estimator-timeout`, 0 for no estimator).",
        "",
    ]


def sequencer_node() -> list[str]:
    rows = [
        interface(c.POSE_TOPIC, "out", "the pose labels: latched, depth 1, each waiting for "
                  "every reader's acknowledgement (up to 10 s) before the next"),
        interface(c.ARM_COMMAND_TOPIC, "out", "the arm's trajectories, with `arm_interface` "
                  "`topic`"),
        interface(c.ARM_SENT_TOPIC, "out", "each arm trajectory as sent, through the action "
                  "or the topic (stamp, points with velocities and accelerations): the bag's "
                  "record of them"),
        interface(c.HAND_COMMAND_TOPIC, "out", "open and close, with `gripper_interface` "
                  "`topic` (then 0.6 s of waiting)"),
        interface(c.GRIPPER_SENT_TOPIC, "out", "each gripper command as sent, through the "
                  "action or the topic (position, max_effort N): the bag's record of them"),
        interface(c.JOINT_STATES_TOPIC, "in", "when the arm rests; each window's joints"),
        interface(c.DIAGNOSTICS_TOPIC, "in", "the estimator's input and exploration statuses"),
        interface(c.ROBOT_DESCRIPTION_TOPIC, "in", "the URDF the poses are solved on"),
    ]  # fmt: skip
    services = [
        interface(c.EXPLORE_SERVICE, "action server", "one exploration with the goal's "
                  "options over the parameters (0, `PARAMETER` or '' keeps a parameter; values "
                  "are checked before the arm moves); feedback every 0.5 s: `phase`, "
                  "`progress` (time done over time done and left, never back), "
                  "`time_remaining` (s, sim: what the current phase has left of its plan and "
                  "every later phase's plan; phases `tare`, `grasp and lift`, `object pass` "
                  "or `object motion`, `verification`, `return`, `estimate and report`) and, "
                  "as object windows close, the `estimate` so far and its `sigma_mass` and "
                  "`sigma_com` (the last: the object pass's); "
                  "the result: `status` (OK, WARN, ERROR, CANCELLED), `message`, `estimate` "
                  "with its 4x4 `covariance`, `verification` and `bag`; one goal at a time "
                  "(another is answered ERROR, still running); cancel puts back what the hand "
                  "holds, goes home, labels the bag `cancelled` and closes it; "
                  "`information` and `reference_mass` (kg: the object is a reference weight, "
                  "the run calibrates the sensor in place) are the estimator's settings for "
                  "the run, restored after it",
                  "com_interfaces/action/Explore"),
        interface(c.EXPLORE_SERVICE, "server", "the same exploration with the parameters, "
                  "for scripts; answers with the one-line summary, `success` only for OK",
                  TRIGGER),
        arm_action("action client", "every move and excitation (`arm_interface` `action`, "
                   "the default), with the configuration's tolerances and 2 s of "
                   "`goal_time_tolerance`; a result other than SUCCESSFUL fails the run "
                   "naming the controller's error"),
        gripper_action("action client", "open and close (`gripper_interface` `action`, the "
                       "default): the goal's result within `gripper_timeout` s or the run "
                       "fails naming the action (the goal cancelled, as on the run's "
                       "cancel); a closing on the object must end stalled, "
                       "not at its goal, with the finger joint states short of closed, and "
                       "then weigh at least `min_load`"),
        interface(c.ESTIMATOR_RESET_SERVICE, "client", "at the start of each run", TRIGGER),
        interface(c.ESTIMATOR_PARAMETERS_SERVICE, "client", "the estimator's `method`, to "
                  "predict for it", GET_PARAMETERS),
        interface(c.ESTIMATOR_SET_PARAMETERS_SERVICE, "client", "`payload_save_dir` = the "
                  "run's bag directory", SET_PARAMETERS),
        interface(c.ESTIMATOR_SAVE_PAYLOAD_SERVICE, "client", "the payload files beside the "
                  "bag, when the run's estimate became the payload", TRIGGER),
    ]  # fmt: skip
    params = parameter_rows(SEQUENCER_PARAMETERS.values())
    return [
        "## exploration_sequencer: `sequencer_node`",
        "",
        "Runs one exploration per `~/explore` goal or call: tare, grasp, tilt, label, record, "
        "report "
        "([design.md, Run lifecycle](design.md#run-lifecycle-and-recovery); its plan: "
        "[Planner rules](design.md#planner-rules); its poses: [Robots](design.md#robots); its "
        "tare: [The tare cache](design.md#the-tare-cache)). A label goes out only once the "
        "arm rests: joint positions within 5 mrad of the target and speeds below 5 mrad/s, "
        "then `settle` s counted from the stamp of the first joint state that shows it "
        "resting. Its high-rate subscriptions "
        "(joint states, statuses, the recorder) live on a second node, "
        "`exploration_sequencer_io`, in the same process.",
        "",
        "### Topics",
        "",
        *table(INTERFACE_HEADER, rows),
        "The recorder subscribes to every topic of a run, raw, and writes "
        "`<bag_dir>/<run-id>/` (rosbag2, MCAP, metadata.yaml), never re-encoding: "
        + ", ".join(f"`{t}`" for t in sorted(c.TOPIC_TYPES))
        + ". A run that dies leaves a bag that opens up to ~0.1 s before the end "
        "([bag_writer.md](bag_writer.md)). Beside it: `tare.json` (the tare entry a run "
        "reused), `robot.yaml` (its robot configuration), `report.png` (the wrench traces "
        "with the windows and motions, and the estimate against the ground truth with 1- "
        "and 3-sigma bars; for a run in motion also the inertia, and the wrench fitted along "
        "the motions) and, for an estimate that became the payload, the payload files.",
        "",
        "### Services",
        "",
        *table(INTERFACE_HEADER, services),
        "Its service calls wait `sim_timeout` for the server and retry three times, 3 s each "
        "(a request sent before the service matched is lost).",
        "",
        "### Parameters",
        "",
        "From `exploration_sequencer.parameters.PARAMETERS`; besides these, every key of "
        "the robot configuration, read-only ([Robot configuration](#robot-configuration)).",
        "",
        *table(PARAMETER_HEADER, params),
        "### `demo`",
        "",
        "`python -m exploration_sequencer.demo` (`make demo ARGS=...`) starts the three "
        "nodes as processes, calls `~/explore`, prints the progress and a summary (estimate, "
        "sigma, truth, error, time, bag and report paths) and stops the nodes, the sequencer "
        "first: Ctrl-C, SIGTERM and SIGHUP cancel the run cleanly; a node whose demo died "
        "(SIGKILL) stops on its own, as on Ctrl-C, the sequencer before the others "
        "(`com_core.runtime.lifeline`); `--help` lists its options.",
        "",
    ]


def robot_configuration() -> list[str]:
    rows = [(f"`{key}`", f"`{value_text(value)}`") for key, value in declared_parameters().items()]
    return [
        "## Robot configuration",
        "",
        "`sim_node` and `sequencer_node` declare every key of the robot configuration, "
        "read-only (a file's `0` is taken for `0.0`); the estimator takes `sensor_frame` and "
        "`hand_id` from it. The defaults are the Panda's file "
        "(`src/com_core/com_core/config/panda.yaml`), but for `max_joint_acceleration`, "
        "empty (none stated) unless the arm's own file states it; what each key means: "
        "[README, Your own arm](../README.md#your-own-arm).",
        "",
        *table(("key", "default (Panda)"), rows),
    ]


def page() -> str:
    lines = [
        "# Nodes",
        "",
        "<!-- Generated by docs/nodes.py from the parameter tables in code; do not edit. "
        "Regenerate: python docs/nodes.py > docs/nodes.md -->",
        "",
        "Every node's topics, services and parameters; `ros2 param describe` gives the same "
        "descriptions (and, as its constraints, what each takes). QoS, publishers and "
        "subscribers of every topic: [design.md, Wire contract](design.md#wire-contract).",
        "",
        "A parameter's column *takes* says what it takes; any other value is refused, "
        "naming the parameter, the value and the range: at start the node ends with "
        "`cannot start: <name>=<value> refused: ...` (exit code 1), at a set the set fails "
        "with that reason, and the demo's flags and the replay's options the same way "
        "(exit code 2) ([design.md, Inputs](design.md#inputs-refused-where-they-enter)).",
        "",
        *sim_node(),
        *estimator_node(),
        *sequencer_node(),
        *robot_configuration(),
    ]
    while lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    text = page()
    if "--check" in argv:
        if PAGE.read_text() != text:
            print(f"{PAGE} differs from docs/nodes.py: python docs/nodes.py > docs/nodes.md")
            return 1
        return 0
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
