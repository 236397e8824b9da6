"""One exploration over the sequencer's ports (no ROS): the choreography and its decisions.

A run starts from a known state (an arm that may hold an object puts it back on the stand
first, an arm away from home goes home), takes or checks the empty hand's tare, grasps,
confirms the grasp by the gripper's outcome, the fingers and the weight, then holds the
object still at each pose of its plan (or moves it along an excitation, docs/design.md,
Identification in motion), checks a verification pose, returns, and asks the estimator
for its answer. Each window is labelled once the arm has settled; every wait is the
ports' (``sequencing.ports``), so a test drives the whole run with fakes. What the run
decides (its plan, the noise it plans for, the tare's reuse, the grasp's load) is
``com_core.planning.decisions``; its progress is ``progress``.

How a run ends (``ExplorationRun.execute``): OK, WARN or ERROR with the estimator's answer;
ERROR naming why when a step cannot go on (``RunError``), after a full disk the arm back
home and the bag so far closed; CANCELLED after a cancel, the run's windows dropped (a
``cancelled`` label), the object put back and the arm home. Every run is recorded to
``<bag_dir>/<run-id>/`` with the robot configuration and the estimator's settings the
replay takes, and a PNG report.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from com_core.bags.cdr import decode_wrench_batch
from com_core.contract import (
    CANCELLED,
    DIAGNOSTICS_TOPIC,
    DONE,
    ERROR,
    INTERNAL_ERROR,
    JOINT_STATES_TOPIC,
    MOTION_LEAD,
    MOTION_OBJECT,
    MOTION_REST,
    MOTION_TARE,
    MOTION_VERIFY,
    MOVING,
    OBJECT_PREFIX,
    OK,
    POSE_TOPIC,
    RUN_CANCELLED,
    STATIC_PREFIXES,
    TARE_PREFIX,
    VERIFY_PREFIX,
    WRENCH_TOPIC,
)
from com_core.estimation.fits.windows import Window
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.fit_setup import WRENCHES
from com_core.estimation.runs.hand_motion import (
    HAND_MOTION_FILE,
    HandMotion,
    hand_motion_path,
    load_hand_motion,
    save_hand_motion,
)
from com_core.estimation.runs.motion_solution import MOTION
from com_core.estimation.runs.sensor_calibration import (
    CALIBRATION_FILE,
    SensorCalibration,
    calibrated_owner,
    kept_calibration,
    save_calibration,
)
from com_core.estimation.runs.settings import (
    BAG_SETTINGS_FILE,
    SETTINGS,
    hysteresis_of,
    write_bag_settings,
)
from com_core.estimation.runs.solution import noise_line, vector_value, verification_lines
from com_core.estimation.runs.tare_cache import (
    BAG_TARE_FILE,
    cache_owner,
    save_tares,
    tare_signature,
    use_tares,
)
from com_core.inputs import unwritable
from com_core.planning.decisions import (
    BIAS_AFTER_SUFFIX,
    BIAS_WINDOW_SUFFIX,
    GRIPPER_TIME,
    PlanInfeasible,
    Poses,
    RunSettings,
    bag_room_refusal,
    cached_tare,
    closing_problem,
    com_guess,
    complete_tare_pass,
    estimator_calibration,
    free_room,
    grasp_holds,
    held_mass,
    hysteresis_hides,
    may_hold_object,
    newest_hand_model,
    plan_within_reach,
    planning_noise,
    predicted_run,
    tare_cache_path,
    tare_decision,
    tare_reuse,
)
from com_core.planning.excitation import Excitation, cached_excitation
from com_core.planning.motion_accuracy import (
    DENSITY_GUESS,
    MAX_CYCLES,
    candidate_motions,
    fastest,
    guessed_load,
    predict_motion,
)
from com_core.planning.planner import HOME, Plan
from com_core.planning.prediction import Prediction
from com_core.planning.run_time import (
    ESTIMATE,
    GRASP,
    OBJECT_MOTION,
    OBJECT_PASS,
    RETURN,
    TARE,
    VERIFICATION,
    PhaseTime,
    motion_run_phases,
    static_run_phases,
)
from com_core.report import RunData, read_run, write_report
from com_core.robot.choreography import VERIFY_POSE, Choreography
from com_core.robot.config import BAG_ROBOT_FILE, RobotConfig, write_robot_config
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis, Way
from com_core.sensing.noise import NoiseModel
from com_core.sequencing.errors import (
    CancelledRunError,
    RecordingError,
    RunError,
    TimeoutRunError,
)
from com_core.sequencing.motion import ArmMotion
from com_core.sequencing.ports import (
    ArmPort,
    EstimatorAnswer,
    EstimatorPort,
    GripperPort,
    JointFeed,
    LabelSink,
    RunClock,
    RunLog,
    RunRecorder,
)
from com_core.sequencing.progress import RunProgress

__all__ = [
    "CANCELLING",
    "ExplorationRun",
    "RunOutcome",
    "RunPorts",
    "summary_line",
]

CANCELLING = "cancelling"  # the phase of the way back after a cancel: no cancel from then on
EXCITATION_CACHE = "excitation_cache.json"  # beside the tare cache
VERIFY_ITERATIONS = 40  # the verification's motion needs no optimum, only another motion
ANSWER_RECORD_WAIT = 5.0  # s (wall) the bag's close waits for the recorder to hear the answer
CLOCKS_APART = 3600 * 10**9  # ns between the sensor's stamps and this clock: two clocks


@dataclass(frozen=True)
class RunPorts:
    """What a run drives (``sequencing.ports``): ``clock`` and ``feed`` (the joint
    states), the ``arm`` and ``gripper`` picked for the run, the pose ``labels``, the
    ``recorder``, the ``estimator``, ``robot`` (the arm's choreography on the robot's URDF;
    RunError naming what does not serve) and ``log``."""

    clock: RunClock
    feed: JointFeed
    arm: ArmPort
    gripper: GripperPort
    labels: LabelSink
    recorder: RunRecorder
    estimator: EstimatorPort
    robot: Callable[[], Choreography]
    log: RunLog


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended: ``status`` (OK, WARN, ERROR or CANCELLED), its one-line
    ``message``, the ``bag`` (None before one) and the estimator's ``answer``."""

    status: str
    message: str
    bag: Path | None = None
    answer: EstimatorAnswer | None = None


@dataclass
class _Record:
    """What a run has recorded so far: its labels (stamp ns, label) and each window's
    middle (s) and mean joint positions (rad, m) by label (a tare window's are cached
    with it)."""

    bag: Path | None = None
    start_ns: int = 0  # no window of the run starts before it
    labels: list[tuple[int, str]] = field(default_factory=list)
    windows: dict[str, tuple[float, dict[str, float]]] = field(default_factory=dict)
    failed: bool = False  # the recorder's failure was raised once


class ExplorationRun:
    """The exploration ``run_id`` of the arm ``config`` over ``ports``, with the
    sequencer's parameters ``p(name)`` (a goal's options over them); ``estimator``: the
    estimator's settings for this run (``information``; ``reference_mass``: the object is
    a reference weight, the run calibrates the sensor in place), set before it starts
    and restored after; ``wall_seen``: the wall time of
    own work per phase, from run to run (``RunProgress``); ``defects`` numbers the
    exceptions that reach the run's top level. See module."""

    def __init__(
        self,
        run_id: str,
        config: RobotConfig,
        ports: RunPorts,
        p: Callable[[str], Any],
        wall_seen: dict[str, float],
        defects: Iterator[int],
        estimator: Mapping[str, object] | None = None,
    ) -> None:
        self.run_id, self.config, self.ports, self.p = run_id, config, ports, p
        self.log, self.clock, self.feed = ports.log, ports.clock, ports.feed
        self.estimator, self.recorder = ports.estimator, ports.recorder
        self._defects, self._estimator_options = defects, dict(estimator or {})
        self.arm = ArmMotion(ports.clock, ports.feed, config, ports.log.warning)
        self.arm.arm, self.arm.gripper_port = ports.arm, ports.gripper
        self.progress = RunProgress(ports.clock, wall_seen)
        self._record = _Record()
        self._estimator_cache = ""  # the estimator's tare_cache, read at the run's start
        self._answer: EstimatorAnswer | None = None
        self._cancel_lock = threading.Lock()  # a cancel, and the way back from one

    # --- the run's ends ------------------------------------------------------------------

    def execute(self) -> RunOutcome:
        """Run it; the outcome (see module). An exception that is no RunError is a
        defect: ERROR, ``internal error #n``, its traceback logged."""
        run_id, log = self.run_id, self.log
        self.clock.cancel.clear()
        try:
            success, message = self.explore()
            answer = self._answer
            status = OK if success else answer.status if answer else ERROR
        except CancelledRunError as exc:
            status, message = RUN_CANCELLED, self._cancelled(str(exc))
        except RecordingError as exc:  # the bag so far closed, the arm back
            status, message = ERROR, f"run {run_id} failed: {exc}"
            log.error(message)
            self._label(self.clock.now_ns(), MOVING)
            self._go_back("after the recording stopped")
            self._stop_recording()
        except RunError as exc:
            status, message = ERROR, f"run {run_id} failed: {exc}"
            log.error(message)
            self._stop_recording()
        except Exception as exc:  # a defect: the run fails, the node lives
            status = ERROR
            message = f"run {run_id} failed: {INTERNAL_ERROR} #{next(self._defects)} {exc!r}"
            log.error(f"{message}\n{traceback.format_exc()}")
            self._stop_recording()
        finally:
            self.estimator.restore()
            self.progress.phase = ""
            self.clock.cancel.clear()
        return RunOutcome(status, message, self._record.bag, self._answer)

    def cancel(self) -> None:
        """Ask the run to stop (the way back, once under way, is not cancelled)."""
        with self._cancel_lock:
            if self.progress.phase != CANCELLING:
                self.clock.cancel.set()

    def _cancelled(self, why: str) -> str:
        """After a cancel: the run's windows dropped (a ``cancelled`` label), the object
        put back and the arm home, the bag closed; the summary."""
        self.log.warning(f"run {self.run_id}: {why}")
        with self._cancel_lock:  # the way back must move: no cancel from here on
            self.progress.phase = CANCELLING
            self.clock.cancel.clear()
        self._label(self.clock.now_ns(), CANCELLED)
        self._label(self.clock.now_ns(), MOVING)
        self._go_back("after the cancel")
        self._stop_recording()
        bag = f"; bag {self._record.bag}" if self._record.bag else ""
        return f"[CANCELLED] run {self.run_id} cancelled: {why}{bag}"

    def _go_back(self, when: str) -> None:
        """The object put back and the arm home (nothing when nothing moved yet); a way
        back that fails is logged."""
        try:
            if self.arm.motion is not None:
                self.arm.come_to_rest()
                home, pick = list(self.config.home_joints), list(self.config.pick_joints)
                self._to_known_state(home, pick, when)
        except RunError as exc:
            self.log.error(f"run {self.run_id}: not back home {when}: {exc}")

    # --- the run ---------------------------------------------------------------------------

    def _enter(self, phase: str, line: str) -> None:
        """Log the phase's line; the progress counts from its start."""
        self.progress.enter(phase)
        self.log.info(line)

    def _cache_path(self) -> Path:
        return tare_cache_path(self.p("tare_cache"), self.p("bag_dir"))

    def _calibration(self) -> SensorCalibration | None:
        """The sensor's calibration in place the estimator applies (kept beside its tare
        cache, read at the run's start); None without."""
        return kept_calibration(self._estimator_cache, self.p("sensor_id"))

    def _owner(self) -> str:
        """The hand on the sensor as calibrated, which every cached thing of this run
        belongs to."""
        owner = cache_owner(self.p("hand_id"), self.p("sensor_id"))
        return calibrated_owner(owner, self._calibration())

    def _ready(self) -> Choreography:
        """The paths the run writes are writable, the arm's joint states come, the
        estimator hears the sensor and the labels, and is reset for the run; returns the
        arm's choreography. RunError before anything moves."""
        for name, path, directory in (
            ("bag_dir", self.p("bag_dir"), True),
            ("tare_cache", self._cache_path(), False),
        ):
            if why := unwritable(name, path, directory):
                raise RunError(why)
        clock, feed, config = self.clock, self.feed, self.config
        clock.sim_timeout = self.p("sim_timeout")
        self.arm.speed, self.arm.settle = self.p("speed"), self.p("settle")
        self.arm.max_effort = self.p("gripper_max_effort")
        clock.wait(lambda: feed.joints, "waiting for the joint states", wall_timeout=None)
        self.progress.start()  # the run's time (and the sim's rate) from here
        motion = self.arm.motion = self.ports.robot()
        # the arm's and the gripper's publishers are heard apart: before the run decides
        # whether the hand holds an object, the fingers must have been heard too
        joints = (*config.arm_joints, *config.gripper_joints)
        with contextlib.suppress(TimeoutRunError):  # missing: named below
            clock.wait(
                lambda: all(name in feed.joints for name in joints),
                "waiting for the arm's and the gripper's joint states",
                wall_timeout=clock.sim_timeout,
            )
        missing = [name for name in config.arm_joints if name not in feed.joints]
        if missing:
            raise RunError(
                f"{JOINT_STATES_TOPIC} has no {', '.join(missing)} of the robot configuration's "
                f"arm_joints (it names {', '.join(feed.joints)})"
            )
        if fingers := [name for name in config.gripper_joints if name not in feed.joints]:
            self.log.warning(
                f"{JOINT_STATES_TOPIC} has no {', '.join(fingers)} of the robot "
                "configuration's gripper_joints: those fingers count as open"
            )
        feed.arm_joints = frozenset(config.arm_joints)  # their messages: the arm answers
        self._handshake()
        for name, value in self._estimator_options.items():  # before the reset: read there
            self.estimator.set(name, value)
        self.estimator.reset()
        self.estimator.clear_answers()  # only this run's answers from here on
        return motion

    def explore(self) -> tuple[bool, str]:
        """One exploration; returns (success, summary). Raises RunError."""
        log, config, run_id = self.log, self.config, self.run_id
        motion = self._ready()
        home, pick = list(config.home_joints), list(config.pick_joints)
        # the estimator's settings, once: the run's plan, and the bag's copy for the replay
        values = self.estimator.settings([n for n in SETTINGS if n != "robot_description"])
        method, information = values["method"], values["information"]
        self._estimator_cache = str(values["tare_cache"])
        if values["reference_mass"] and (
            self.p("excitation") == MOTION or information == WRENCHES
        ):
            raise RunError(
                "a calibration in place (reference_mass) is a static exploration with the "
                "kinematics: excitation 'static', information 'kinematics' or "
                "'kinematics+mount'"
            )
        if self.p("excitation") == MOTION:
            return self._explore_in_motion(motion, values)
        drift_rate = tuple(values["bias_drift_rate"])
        calibration = self._planning_calibration(values)
        settings = RunSettings.from_parameters(self.p)
        noise, source = self._planning_noise(settings)
        plan, poses, prediction = self._planned(
            settings, noise, method, information, drift_rate, motion, calibration,
            hysteresis_of(values),
        )  # fmt: skip
        log.info(f"planned for the sensor's {noise.summary()} ({source})")
        log.info(
            f"run {run_id}: {config.robot}, poses {[n for n, _ in poses]}, "
            f"tilt {plan.tilt:.3f} rad, dwell {plan.dwell:g} s; predicted {prediction}"
        )
        bracket = information != WRENCHES  # an empty-hand window after the pass brackets
        if self.p("preview"):
            verify = motion.verify_joints()[0] if bracket else None
            moves = [("home", home), ("pick", pick), *poses]
            moves += [(VERIFY_POSE, verify)] if verify else []
            return True, self._preview(moves)
        phases = self._static_phases(plan, motion, bracket, False)
        bag = self._start_bag(self.progress.plan(phases), values)
        self._to_known_state(home, pick)
        self.arm.gripper(close=False)
        tare_home = self._tare(
            plan, motion, bag, values["tare_cache"], bracket, hysteresis_of(values)
        )
        self._enter(GRASP, "phase 2/4: grasp and lift")
        self.arm.move(home, "home")
        self.arm.move(pick, "the object")
        self._close_on_object(home)
        self._check_grasp(home, tare_home, pick, values)
        self._enter(OBJECT_PASS, "phase 3/4: object pass")
        start = self.clock.now_ns()
        self._pass(OBJECT_PREFIX, poses, plan.dwell)
        end = self._record.labels[-1][0]  # the last window's end: the same if "moving" is lost
        object_time = (end - start) * 1e-9
        if bracket and self.p("verify_dwell") > 0:  # the fit predicts the wrench there
            verify, reason = motion.verify_joints()
            if verify is None:
                log.warning(f"no verification: its pose is out of reach ({reason})")
            else:
                self._enter(VERIFICATION, "verification pose: a tilt no fit uses")
                self._pass(VERIFY_PREFIX, [(VERIFY_POSE, verify)], self.p("verify_dwell"))
                end = self._record.labels[-1][0]
        release = self.p("release")
        self._enter(RETURN, f"phase 4/4: return{' and release' if release else ', holding'}")
        if bracket and release:  # the bias's drift (kinematic information): done after it
            self.arm.put_back(home, pick)
            after = f"{poses[0][0]}{BIAS_AFTER_SUFFIX}"
            self._pass(TARE_PREFIX, [(after, home)], self.p("bias_dwell"))
            end = self._record.labels[-1][0]
        self._label(end, DONE)
        self._label(max(end, self.clock.now_ns()), MOVING)  # the latched label is no "done"
        if not release:
            self.arm.move(home, "home")
        elif not bracket:
            self.arm.put_back(home, pick)
        plan_line = f"predicted {prediction}; object pass {object_time:.1f} s (sim)"
        return self._estimate(end, plan_line, bag)

    def _planned(
        self,
        settings: RunSettings,
        noise: NoiseModel,
        method: str,
        information: str,
        bias_drift_rate: tuple[float, ...],
        motion: Choreography,
        calibration: Calibration | None = None,
        hysteresis: Hysteresis | None = None,
    ) -> tuple[Plan, Poses, Prediction]:
        """The plan of ``settings``, the joints of its poses and its prediction
        (``plan_within_reach``, ``predicted_run``), each pose refused and each change
        logged. RunError when no plan is feasible (the reason says what would be)."""
        try:
            planned = plan_within_reach(settings, motion, noise, calibration, bias_drift_rate,
                                        hysteresis)  # fmt: skip
            for refusal in planned.refusals:
                self.log.warning(f"refused before moving: {refusal}")
            planned, prediction = predicted_run(planned, settings, motion, method, information)
        except PlanInfeasible as exc:
            raise RunError(str(exc)) from exc
        for change in planned.changes:
            self.log.warning(f"plan changed: {change}")
        return planned.plan, planned.poses, prediction

    def _static_phases(
        self, plan: Plan, motion: Choreography, bracket: bool, tare_check: bool
    ) -> tuple[PhaseTime, ...]:
        """The phases of a static run of ``plan`` on ``motion`` (``static_run_phases``)
        with this run's parameters and the wall time of own work as last measured;
        ``bracket``: kinematic information; ``tare_check``: a cached tare is checked."""
        config, verify_dwell = self.config, self.p("verify_dwell")
        verify = motion.verify_joints()[0] if bracket and verify_dwell > 0 else None
        return static_run_phases(
            plan,
            motion.pose_joints(plan.tare_plan()),
            motion.pose_joints(plan),
            motion=motion,
            speed=self.arm.speed,
            home=config.home_joints,
            pick=config.pick_joints,
            verify=verify,
            tare_check=tare_check,
            bias_dwell=self.p("bias_dwell"),
            grasp_check_dwell=self.p("grasp_check_dwell"),
            verify_dwell=verify_dwell,
            bracket=bracket,
            release=self.p("release"),
            wall=self.progress.wall_seen,
        )

    def _preview(self, moves: list[tuple[str, list[float]]]) -> str:
        """Log every move's joint targets (deg, the configuration's arm_joints) and return
        the summary: where the arm would go, without moving it (``preview``)."""
        log, names = self.log, self.config.arm_joints
        here = [self.feed.joints[name][0] for name in names]
        log.info(f"preview of run {self.run_id}: joint targets in deg of {', '.join(names)}")
        for name, joints in moves:
            log.info(f"  {name}: " + ", ".join(f"{math.degrees(v):7.1f}" for v in joints))
        excursion = max(
            abs(v - h) for _, joints in moves for v, h in zip(joints, here, strict=True)
        )
        return (
            f"[PREVIEW] run {self.run_id}: {len(moves)} targets logged, the largest joint "
            f"excursion from where the arm is {math.degrees(excursion):.1f} deg at speed "
            f"{self.p('speed'):g} rad/s; nothing moved (set preview false to run)"
        )

    def _start_bag(self, planned_s: float, settings: dict[str, object]) -> Path:
        """Start recording the run to <bag_dir>/<run_id> (with the robot configuration the
        replay takes its frames from and the estimator's ``settings``, its defaults) and
        its progress, ``planned_s`` s (sim) long."""
        bag = Path(self.p("bag_dir")).resolve() / self.run_id
        if why := bag_room_refusal(bag.parent, planned_s):
            raise RunError(why)  # before anything moves
        self.recorder.start(bag)
        self._record = _Record(bag=bag, start_ns=self.clock.now_ns())
        self.progress.recording(planned_s)
        write_robot_config(self.config, bag / BAG_ROBOT_FILE)  # the replay's frames
        write_bag_settings(settings, bag / BAG_SETTINGS_FILE)  # the replay's defaults
        if (calibration := self._calibration()) is not None:
            save_calibration(bag / CALIBRATION_FILE, calibration)  # the replay's
        return bag

    def _estimate(self, end: int, plan_line: str, bag: Path) -> tuple[bool, str]:
        """The run's last phase, after the ``done`` label at ``end`` (ns): the estimator's
        answer, the payload files when it holds a payload now, the bag closed, the summary
        and the report; returns (success, summary). Its time is kept for the next run's
        plan."""
        self._enter(ESTIMATE, "the estimate: the estimator's answer, the payload, the report")
        answer = self._answer = self._estimator_answer(end)
        if answer is not None:
            self._answer_recorded()
        if answer is not None and answer.values.get("payload") == "True":
            self.estimator.save_payload(bag)  # this run's estimate is its payload now
        counts = self._stop_recording()
        run = self._read_run(bag)
        summary = summary_line(answer, plan_line, bag, run.incomplete if run else [])
        self.log.info(f"run {self.run_id}: {summary} ({sum(counts.values())} messages recorded)")
        if run is not None and run.incomplete:
            self.log.warning(f"the bag is incomplete: {'; '.join(run.incomplete)}")
        try:
            self.log.info(f"report: {write_report(bag, run=run)}")
        except Exception as exc:  # a report must never fail a run
            self.log.error(f"report not written: {exc!r}")
        self.progress.ended(self.clock.now_ns())
        return answer is not None and answer.status == OK, summary

    def _read_run(self, bag: Path) -> RunData | None:
        """The closed bag read back (the report's ``read_run``: what it lacks of the run
        among the rest), or None when it cannot be read (logged)."""
        try:
            return read_run(bag)
        except Exception as exc:  # a bag that cannot be read back must never fail a run
            self.log.error(f"bag {bag} not read back: {exc!r}")
            return None

    def _planning_calibration(self, values: dict[str, object]) -> Calibration | None:
        """The calibration term the estimator will weigh (``values``: its settings): what
        is left of a calibration in place kept for this sensor, else its stated accuracy."""
        calibration = estimator_calibration(values["accuracy"], values["full_scale"])
        if (kept := self._calibration()) is not None and not values["reference_mass"]:
            calibration = kept.calibration  # what the estimator weighs: what is left of it
        return calibration

    def _planning_noise(self, settings: RunSettings) -> tuple[NoiseModel, str]:
        """The sensor's noise to plan for, and where it comes from (``planning_noise``)."""
        return planning_noise(newest_hand_model(self._cache_path(), self._owner()), settings)

    # --- an exploration in motion -------------------------------------------------------

    def _explore_in_motion(
        self, motion: Choreography, settings: dict[str, object]
    ) -> tuple[bool, str]:
        """An exploration in motion (docs/design.md, Identification in motion): the empty
        hand at rest at home (the sensor's noise and bias) and along the excitation (not
        when the hand's motion fit of an earlier run serves, ``_cached_hand``), the grasp,
        the object along the excitation, then along another motion no fit uses, and the
        return. RunError before anything moves when the estimator's information has no
        kinematics. ``settings``: the estimator's."""
        if settings["information"] == WRENCHES:
            raise RunError(
                "excitation 'motion' needs the estimator's information 'kinematics' or "
                "'kinematics+mount' (it has 'wrenches'): the fit takes the wrist's motion "
                "from the URDF and the joint states"
            )
        config = self.config
        home, pick = list(config.home_joints), list(config.pick_joints)
        period, bounds, cycles = self._motion(motion, settings)
        excitation, verification = self._excitations(motion, period, bounds)
        excitation = replace(excitation, cycles=cycles)  # the object's
        hand_cycles = max(cycles, self.p("hand_motion_cycles"))
        if self.p("preview"):
            names = config.arm_joints
            moves = [("home", home), ("pick", pick)]
            for name, ex in ((MOTION_OBJECT, excitation), (MOTION_VERIFY, verification)):
                q = ex.waypoints(names)[1]  # the path's extremes, joint by joint
                moves += [(f"{name} lowest", list(q.min(axis=0))),
                          (f"{name} highest", list(q.max(axis=0)))]  # fmt: skip
            return True, self._preview(moves)
        hand = self._cached_hand(motion, excitation, str(settings["tare_cache"]))
        phases = motion_run_phases(
            motion=motion,
            speed=self.arm.speed,
            settle=self.arm.settle,
            home=home,
            pick=pick,
            period=period,
            cycles=cycles,
            hand_cycles=hand_cycles,
            lead=MOTION_LEAD,
            rest=MOTION_REST,
            hand_moves=hand is None,
            bias_dwell=self.p("bias_dwell"),
            grasp_check_dwell=self.p("grasp_check_dwell"),
            release=self.p("release"),
            wall=self.progress.wall_seen,
        )
        bag = self._start_bag(self.progress.plan(phases), settings)
        if hand is not None:
            save_hand_motion(bag / HAND_MOTION_FILE, hand)  # the replay's
        self._to_known_state(home, pick)
        self.arm.gripper(close=False)
        line = "at rest" + (f", then along the excitation ({hand_cycles} x {period:g} s)"
                            if hand is None else "")  # fmt: skip
        self._enter(TARE, f"phase 1/4: the empty hand {line}")
        tare_home = self._captured_tares([(HOME, home)], self.p("bias_dwell"))[0].get(HOME)
        if tare_home is None:
            raise RunError(f"the empty hand's window at {HOME} was not recorded")
        if hand is None:
            self._excite(MOTION_TARE, replace(excitation, cycles=hand_cycles))
        self._enter(GRASP, "phase 2/4: grasp and lift")
        self.arm.move(pick, "the object")
        self._close_on_object(home)
        self._check_grasp(home, tare_home, pick, settings)
        self._enter(OBJECT_MOTION, "phase 3/4: the object along the excitation")
        end = self._excite(MOTION_OBJECT, excitation)
        self._enter(VERIFICATION, "verification: the object along a motion no fit uses")
        end = self._excite(MOTION_VERIFY, verification)
        release = self.p("release")
        self._enter(RETURN, f"phase 4/4: return{' and release' if release else ', holding'}")
        self._label(end, DONE)
        self._label(max(end, self.clock.now_ns()), MOVING)  # the latched label is no "done"
        if release:
            self.arm.put_back(home, pick)
        joints = ", ".join(excitation.joints)
        plan_line = (f"excitation of {joints}, {period:g} s x {cycles}; object motion "
                     f"{excitation.duration:.1f} s (sim)")  # fmt: skip
        return self._estimate(end, plan_line, bag)

    def _cached_hand(
        self, motion: Choreography, excitation: Excitation, estimator_cache: str
    ) -> HandMotion | None:
        """The empty hand's motion fit that the estimator saved beside the tare cache after
        an earlier run, when it serves this one (``HandMotion.serves``: this hand and
        robot model, the path of this run's excitation, younger than ``tare_max_age``)
        and the estimator reads that cache too; else None (the empty hand moves again)."""
        path = hand_motion_path(self._cache_path())
        entry = load_hand_motion(path)
        if entry is None:
            return None
        log = self.log
        if not estimator_cache or Path(estimator_cache).resolve() != self._cache_path().resolve():
            log.warning(
                f"the estimator reads the tare cache {estimator_cache or '(none)'!r}, not "
                f"{str(self._cache_path())!r}: the empty hand moves again (give both nodes "
                "one tare_cache)"
            )
            return None

        def commanded(t: np.ndarray) -> np.ndarray:  # at rest at home after its cycles
            return excitation.at(np.clip(t, 0.0, excitation.duration))[0]

        why = entry.serves(self._owner(), motion.robot.urdf_sha256, commanded,
                           excitation.duration, self.p("tare_max_age"))  # fmt: skip
        if why:
            log.info(f"the empty hand's motion fit in {path} not reused: {why}")
            return None
        log.info(f"the empty hand's motion fit reused ({entry.age():.0f} s old, {path})")
        return entry

    def _motion(
        self, motion: Choreography, settings: dict[str, object]
    ) -> tuple[float, tuple[float, ...], int]:
        """(period s, acceleration bound per wrist joint rad/s^2, cycles) of this run's
        motion: as set (``motion_period``, ``motion_acceleration`` within the arm's own
        limits, ``motion_cycles``), or with ``target_inertia`` the fastest of
        ``candidate_motions`` that meets it for the guessed object
        (``planning.motion_accuracy``); RunError when none does. ``settings``: the
        estimator's (its calibration term)."""
        config, joints = self.config, self.config.arm_joints[-3:]
        period, acceleration = self.p("motion_period"), self.p("motion_acceleration")
        candidates = candidate_motions(period, acceleration, joints, config.arm_joints,
                                       config.max_joint_acceleration)  # fmt: skip
        target = self.p("target_inertia")
        if target <= 0:
            return *candidates[0], self.p("motion_cycles")
        self.log.info(
            f"target_inertia {target:g}: weighing {len(candidates)} motions (each "
            "designed once, then read from the excitation cache)"
        )
        run_settings = RunSettings.from_parameters(self.p)
        mass = run_settings.mass_guess
        load = guessed_load(mass, com_guess(run_settings, motion))
        noise, source = self._planning_noise(run_settings)
        calibration = self._planning_calibration(settings)
        designs = [self._excitation(motion, p, b) for p, b in candidates]
        hysteresis = hysteresis_of(settings)
        hand_cycles = self.p("hand_motion_cycles")
        predicted = [predict_motion(motion.robot, ex, motion.hand, load, noise, calibration,
                                    hysteresis, hand_cycles) for ex in designs]  # fmt: skip
        best = fastest(list(zip(designs, predicted, strict=True)), target)
        if best is None:
            reach = min(max(a.sigma_moments_over(MAX_CYCLES) / a.moments) for a in predicted)
            raise RunError(
                f"no motion meets target_inertia {target:g} for the guessed object (a box "
                f"of {mass:g} kg at {DENSITY_GUESS:g} kg/m^3): {MAX_CYCLES} cycles of the "
                f"best leave a principal moment's sigma at {reach:.0%} of it; calibrate the "
                "sensor in place, or set a larger target_inertia (python -m "
                "com_core.planning.motion_accuracy weighs it)"
            )
        (period, bounds), cycles = candidates[best[0]], best[1]
        a = predicted[best[0]]
        self.log.info(
            f"target_inertia {target:g}: {cycles} x {period:g} s within "
            f"{', '.join(f'{b:g}' for b in bounds)} rad/s^2 for a box of {mass:g} kg; "
            f"predicted moments' sigmas "
            f"{', '.join(f'{v:.0%}' for v in a.sigma_moments_over(cycles) / a.moments)} of "
            f"them, mass {a.sigma_mass / mass:.2%}, COM {1e3 * a.sigma_com.max():.2f} mm "
            f"(the sensor's noise {source})"
        )
        return period, bounds, cycles

    def _excitation(
        self, motion: Choreography, period: float, bounds: tuple[float, ...], **design: int
    ) -> Excitation:
        """The excitation of the wrist's last three joints over ``period`` s within
        ``bounds`` rad/s^2, designed once per arm, home, period, bounds and ``design``
        (iterations, seed) and cached beside the tare cache
        (``planning.excitation.cached_excitation``)."""
        path = self._cache_path().with_name(EXCITATION_CACHE)
        robot = motion.robot
        home = [motion.home_positions()[name] for name in robot.joint_names]
        return cached_excitation(path, robot, home, self.config.arm_joints[-3:], period, bounds,
                                 **design)  # fmt: skip

    def _excitations(
        self, motion: Choreography, period: float, bounds: tuple[float, ...]
    ) -> tuple[Excitation, Excitation]:
        """(the excitation of the wrist's last three joints over ``period`` s within
        ``bounds`` rad/s^2, another one for the verification; ``_excitation``)."""
        started = time.monotonic()
        excitation = self._excitation(motion, period, bounds)
        verification = self._excitation(motion, period, bounds, iterations=VERIFY_ITERATIONS,
                                        seed=1)  # fmt: skip
        self.log.info(
            f"excitation: {', '.join(excitation.joints)} over {period:g} s, accelerations "
            f"within {', '.join(f'{b:g}' for b in bounds)} rad/s^2, log det "
            f"{excitation.log_det:.1f} ({time.monotonic() - started:.1f} s, cache "
            f"{self._cache_path().with_name(EXCITATION_CACHE)})"
        )
        return excitation, verification

    def _excite(self, label: str, excitation: Excitation) -> int:
        """Run ``excitation`` from home, labelled ``label`` from its start to
        ``MOTION_REST`` s after its end (the joint states must reach beyond the last
        wrench the fit takes); returns that end, sim time, ns."""
        self.arm.move(list(self.config.home_joints), "home")
        start = self.clock.now_ns() + round(MOTION_LEAD * 1e9)
        end = self.arm.follow(excitation, start, label) + round(MOTION_REST * 1e9)
        self._label(start, label)
        self.log.info(f"span {label} from t={start * 1e-9:.3f} s")
        self.clock.sleep_until(end, f"recording {label}")
        self.arm.finished(wall_timeout=10.0)
        self._label(end, MOVING)
        return end

    # --- steps ------------------------------------------------------------------------

    def _tare(
        self,
        plan: Plan,
        motion: Choreography,
        bag: Path,
        estimator_cache: str,
        hand_model: bool,
        hysteresis: Hysteresis | None,
    ) -> Window:
        """Phase 1: reuse the cached tare pass of this hand if still valid, else take a new
        one, cached with its windows' ways through the sensor's stated ``hysteresis``;
        returns an empty-hand window at home (of this run when it has one). The policy:
        docs/design.md, "The tare cache"."""
        log = self.log
        path = self._cache_path()
        tare_poses = motion.pose_joints(plan.tare_plan())
        home_name, home = tare_poses[0]
        signature = tare_signature(self._owner(), tare_poses)
        cache, unreadable = cached_tare(path, self._owner(), signature, hand_model)
        if unreadable:
            log.warning(f"tare cache {path} unreadable ({unreadable}): taking a new tare")
        decision = tare_decision(
            cache,
            path,
            estimator_cache,
            self.p("tare_max_age"),
            [name for name, _ in plan.poses()],
            hand_model,
        )
        if decision.unshared:
            log.warning(
                f"the estimator reads the tare cache {estimator_cache or '(none)'!r}, not "
                f"{str(path)!r}: taking a fresh tare pass (give both nodes one tare_cache)"
            )
        if decision.check and cache is not None:
            what = "this run's bias" if hand_model else "drift check of the cached tare"
            self.progress.plan(self._static_phases(plan, motion, hand_model, True))
            self._enter(TARE, f"phase 1/4: {what} ({cache.age():.0f} s old), empty hand at home")
            self.arm.move(home, "home")
            check = f"{home_name}{BIAS_WINDOW_SUFFIX}"  # matches no object window
            fresh = self._captured_tares([(check, home)], self.p("bias_dwell"))[0].get(check)
            reuse = tare_reuse(cache, home_name, fresh, hand_model)
            if reuse.reuse:
                use_tares(path, cache)
                use_tares(bag / BAG_TARE_FILE, cache)
                log.info(f"tare: reusing the cache ({reuse.verdict})")
                return reuse.home
            log.warning(f"tare not reusable ({reuse.verdict}): new tare pass")
            self.progress.plan(self._static_phases(plan, motion, hand_model, False))
        self._enter(TARE, "phase 1/4: tare pass with the empty hand")
        windows, noise, ways = self._captured_tares(
            tare_poses, plan.tare_dwell or plan.dwell, hysteresis
        )
        if home_name not in windows:
            raise RunError(f"the tare window at {home_name} was not recorded")
        if complete_tare_pass(windows, [name for name, _ in tare_poses]):
            seen = {pose: self._record.windows[TARE_PREFIX + pose] for pose in windows}
            times = {pose: time for pose, (time, _) in seen.items()}
            joints = {p: j for p, (_, j) in seen.items()}
            save_tares(path, signature, windows, joints, times, noise, ways)
            log.info(f"tare: saved to {path}")
        return windows[home_name]

    def _to_known_state(
        self, home: list[float], pick: list[float], when: str = "before the run"
    ) -> None:
        """Start from the empty hand at home: fingers that are not open may hold an object
        (a run that stopped mid-way), so it is put back on the stand first; an arm away
        from home goes home."""
        closed = self.arm.gripper_closed()
        if may_hold_object(closed):
            self.log.warning(
                f"the gripper is {closed:.0%} closed: the hand may hold an object; putting "
                f"it back on the stand {when}"
            )
            self.arm.put_back(home, pick)
        elif not self.arm.at(home):
            self.log.warning(f"the arm is away from home: moving it home {when}")
            self.arm.move(home, "home")

    def _close_on_object(self, home: list[float]) -> None:
        """Close the gripper on the object: the gripper's outcome (stalled on it, not at
        the closed goal) and the finger joint states (short of closed) must show the
        fingers stopped on something (``closing_problem``), else the gripper opens, the
        arm goes home and RunError."""
        result = self.arm.gripper(close=True, wait=GRIPPER_TIME)
        what = "the gripper"
        stalled = reached = None
        if result is not None:  # the driver's outcome (an action's result)
            what = f"the gripper action {self.config.gripper_action}"
            stalled, reached = result.stalled, result.reached_goal
        problem = closing_problem(stalled, reached, self.arm.gripper_closed(), what)
        if problem:
            self.arm.gripper(close=False, wait=GRIPPER_TIME)
            self.arm.move(home, "home")
            raise RunError(
                f"grasp failed: {problem}: the object was not picked up; check pick_joints "
                "and where the object stands"
            )

    def _check_grasp(
        self, home: list[float], tare_home: Window, pick: list[float], settings: dict[str, object]
    ) -> None:
        """Lift and weigh: the wrench at home beyond the tare must hold ``min_load`` kg
        along gravity, less what the sensor's hysteresis can move it by (``settings``:
        the estimator's), else the object was not picked up (RunError, hand emptied); a
        weight the hysteresis hides is a warning, the gripper's word taken."""
        dwell = round(self.p("grasp_check_dwell") * 1e9)

        def lift_and_weigh() -> int:
            end = self.arm.move(home, "lifting") + dwell
            self.clock.sleep_until(end, "weighing the grasp")
            return end

        raws, end = self._wrenches_during(lift_and_weigh, "the grasp check")
        stamps, wrenches, _ = decode_wrench_batch(raws)
        mass = held_mass(stamps, wrenches, end - dwell, end, tare_home.force)
        if mass is None:
            raise RunError(
                "the grasp cannot be weighed: no wrenches arrived, or the empty hand's tare "
                "weighs nothing (a force resolution coarser than the hand's weight?)"
            )
        min_load = self.p("min_load")
        hidden = hysteresis_hides(hysteresis_of(settings), tare_home.force)
        held = f"after lifting the hand holds {mass * 1e3:.1f} g beyond the tare"
        if not grasp_holds(mass, min_load, hidden):
            self.arm.put_back(home, pick)
            within = f" - {hidden * 1e3:.0f} g the sensor's hysteresis can hide" if hidden else ""
            raise RunError(
                f"grasp failed: {held} (< min_load {min_load * 1e3:g} g{within}): the object "
                "was not picked up; check pick_joints and where the object stands"
            )
        if mass < min_load:
            self.log.warning(
                f"the grasp check cannot weigh the object: {held}, within the "
                f"{hidden * 1e3:.0f} g the sensor's hysteresis can move it by since the "
                "tare; going on as the gripper closed on it"
            )
        else:
            self.log.info(f"grasp holds {mass * 1e3:.1f} g")

    def _captured_tares(
        self,
        poses: list[tuple[str, list[float]]],
        dwell: float,
        hysteresis: Hysteresis | None = None,
    ) -> tuple[dict[str, Window], NoiseModel | None, dict[str, Way]]:
        """Run a tare pass and reduce its windows from the wrenches the recorder saw, with
        the noise they learn (``com_core.sensing.noise``) and, given the sensor's stated
        ``hysteresis``, each window's way from the one before it (``Hysteresis.ways``);
        (windows by pose, that noise, those ways; all as read)."""

        def tare_pass() -> int:
            self._pass(TARE_PREFIX, poses, dwell)
            return self._record.labels[-1][0]  # the last window's end

        raws, end = self._wrenches_during(tare_pass, "the tare")
        exploration = Exploration(expected_frame="")  # the driver's frame, whatever it is
        if raws:
            exploration.add_samples(*decode_wrench_batch(raws))
        for stamp, label in self._record.labels:
            exploration.add_label(stamp, label)
        noise = exploration.noise_model(end)
        tares, _, _, refused = exploration.reduced_windows(end, noise)
        for note in refused:
            self.log.warning(f"not usable: {note}")
        learnt = f"; {noise.summary()}" if noise is not None else ""
        self.log.info(f"{TARE_PREFIX}: {len(tares)} windows from {len(raws)} wrenches{learnt}")
        if hysteresis is None or not tares:
            return tares, noise, {}
        stamps, wrenches = exploration.samples()
        times = {p: exploration.window_time(TARE_PREFIX + p, stamps, end) for p in tares}
        order, ahead = sorted(tares, key=times.__getitem__), np.argsort(stamps, kind="stable")
        found = hysteresis.ways([times[p] for p in order], [], stamps[ahead] * 1e-9,
                                wrenches[ahead])  # fmt: skip
        return tares, noise, dict(zip(order, found, strict=True))

    def _wrenches_during(self, act: Callable[[], int], what: str) -> tuple[list[bytes], int]:
        """(the raw wrenches the recorder saw while ``act`` ran, and up to the sim time
        it returns; that time, ns): the stream is awaited until it reaches it."""
        recorder = self.recorder
        recorder.capture(WRENCH_TOPIC)
        try:
            end = act()
            self.clock.wait(
                lambda: recorder.latest_ns >= end,
                f"waiting for the wrenches of {what}",
                wall_timeout=10.0,
            )
        finally:
            raws = recorder.release(WRENCH_TOPIC)
        return raws, end

    def _pass(self, prefix: str, poses: list[tuple[str, list[float]]], dwell: float) -> None:
        """A window at each pose. Each window starts ``settle`` s after the joint states
        first show the arm resting at its pose; the move to the next pose is sent once the
        window has ended (a trajectory controller starts a trajectory when it arrives)."""
        dwell_ns = round(dwell * 1e9)
        # an arm at rest all along rests from before the recording: the bag starts there
        start = max(self.arm.move(poses[0][1], poses[0][0]), self._record.start_ns)
        for k, (name, _) in enumerate(poses):
            end = start + dwell_ns
            self._label(start, prefix + name)
            self.clock.sleep_until(end, f"recording {prefix}{name}")
            joints = self.feed.joints_over(start, end)
            self._record.windows[prefix + name] = ((start + end) * 0.5e-9, joints)
            self._label(end, MOVING)
            if k + 1 < len(poses):
                start = self.arm.move(poses[k + 1][1], poses[k + 1][0])

    def _label(self, stamp_ns: int, label: str) -> None:
        """Publish ``label`` from ``stamp_ns``; RecordingError once the recorder says its
        writer stopped (a full disk)."""
        self.ports.labels.publish(stamp_ns, label)
        self._record.labels.append((stamp_ns, label))
        self._check_recording()
        if label.startswith(STATIC_PREFIXES):
            self.log.info(f"window {label} from t={stamp_ns * 1e-9:.3f} s")

    def _handshake(self) -> None:
        """Wait until the estimator hears the sensor on this run's clock (a wrench stamped
        after now, not ahead of it: not a sensor that was restarted, nor another one) and
        the run's labels: a "moving" now, which begins no window, must come back in its
        input status (a subscriber can match a publisher seconds after the publisher
        matched it, and then the first window labels would be lost). Its status comes at
        1 Hz wall: a sim faster than real time is seconds ahead of it by then. RunError at
        once when the sensor's stamps and this clock are far apart: the two run on
        different clocks (sim time without ``use_sim_time``)."""
        handshake = self.clock.now_ns()
        self._label(handshake, MOVING)

        def heard() -> bool:
            (latest, label), now = self.estimator.heard(), self.clock.now_ns()
            if abs(latest - now) > CLOCKS_APART and latest > 0:
                raise RunError(
                    f"the estimator hears {WRENCH_TOPIC} stamped {latest * 1e-9:.3f} s while "
                    f"this node's clock reads {now * 1e-9:.3f} s: they run on different "
                    "clocks; with a simulator's sensor (sim time on /clock) start this node "
                    "with use_sim_time:=true"
                )
            return handshake <= latest < now + 1_000_000_000 and label == handshake

        self.clock.wait(
            heard,
            f"waiting for the estimator to hear {WRENCH_TOPIC} and {POSE_TOPIC}",
            wall_timeout=self.p("estimate_timeout"),
        )

    def _estimator_answer(self, done_ns: int) -> EstimatorAnswer | None:
        """The estimator's answer for this run's 'done', or None (logged)."""
        try:
            self.clock.wait(
                lambda: self.estimator.answer(done_ns),
                "waiting for the estimator",
                wall_timeout=self.p("estimate_timeout"),
            )
        except RunError as exc:
            self.log.error(f"no estimate: {exc}")
            return None
        return self.estimator.answer(done_ns)

    def _answer_recorded(self) -> None:
        """Wait until the recorder has heard a status the estimator published after its
        answer: the estimator's statuses come in order from one publisher (one a second at
        least), and the recorder hears them apart from this node, so the answer is then in
        the bag. At most ``ANSWER_RECORD_WAIT`` s (wall), else logged."""
        recorder = self.recorder
        recorder.capture(DIAGNOSTICS_TOPIC)  # latest_ns: 0 until a status is heard
        try:
            self.clock.wait(lambda: recorder.latest_ns > 0, "the recorder hearing the "
                            "estimator's answer", wall_timeout=ANSWER_RECORD_WAIT)  # fmt: skip
        except TimeoutRunError:
            self.log.warning(
                f"the recorder heard no estimator status within {ANSWER_RECORD_WAIT:g} s of "
                "its answer: the bag may lack it"
            )
        finally:
            recorder.release(DIAGNOSTICS_TOPIC)

    def _stop_recording(self) -> dict[str, int]:
        """Close the bag; messages written per topic ({} when none or the recording
        failed: the bag holds what was written before, logged)."""
        if not self.recorder.recording:
            return {}
        try:
            return self.recorder.stop()
        except RuntimeError as exc:
            self.log.error(f"{exc}; {free_room(self._record.bag)}")
            return {}

    def _check_recording(self) -> None:
        """RecordingError once the recorder says its writer stopped (a full disk)."""
        if self._record.failed or not self.recorder.recording:
            return
        if why := self.recorder.failure():
            self._record.failed = True
            raise RecordingError(f"{why}; {free_room(self._record.bag)}")


def summary_line(
    answer: EstimatorAnswer | None, plan_line: str, bag: Path, incomplete: list[str]
) -> str:
    """One line: the estimator's status and message, for a kinematic fit the COM sigma
    the wrenches alone give on the same windows and the verification, the ``plan_line``
    (the prediction and the pass), the bag and what it lacks (``RunData.incomplete``)."""
    if answer is None:
        head = "[ERROR] the estimator did not answer"
    else:
        head, values = f"[{answer.status}] {answer.message}", answer.values
        if alone := vector_value(values, "wrenches_sigma_com", 1e3):
            head += f" (wrenches alone: COM +- ({', '.join(f'{v:.2f}' for v in alone)}) mm)"
        head += "".join(f"; {line}" for line in verification_lines(values))
        head += f"; {noise}" if (noise := noise_line(values)) else ""
    lacks = "".join(f"; incomplete: {line}" for line in incomplete)
    return f"{head}; {plan_line}{lacks}; bag {bag}"
