"""Identification in motion over many objects, against the motion's Cramer-Rao bound.

    source ./env.sh && python bench/motion.py [--objects 50] [--robots panda,xarm6]
        [--masses 0.05,0.2,0.5,2.0] [--period 3.0] [--acceleration 8|limits]
        [--joint-rate 100] [--seed 0] [--profile realistic] [--calibration-accuracy 0.01]
        [--static] [--information kinematics+mount] [--calibrate 1.0] [--hand-cycles 4]

In process, no ROS: for each arm, mass and object (box, cylinder, mug in turn, COM
offset drawn from the object's seed) a simulator holds the empty hand, runs the arm's
D-optimal wrist excitation (``planning.excitation``, designed once per arm, its
accelerations within ``--acceleration`` rad/s^2, or ``limits``: the arm's own;
``--hand-cycles`` periods of it, as the sequencer's ``hand_motion_cycles``), grasps
the object and runs it once; both read through the realistic sensor
(``profile_sensor``: coloured noise, quantisation, drifting bias, a 1 % calibration
drawn per object; ``--profile`` another named one, the estimator told its datasheet; a
strain gauge's hysteresis following the load at every step, the moves and the grasp too,
as the sim node's sensor does), the joint states taken at ``--joint-rate``.
``estimation.fits.motion.fit_motion`` fits the hand, then the object with the hand taken
off, the delay estimated and the noise model the profile's. Per case: the 95th
percentile of the mass, COM and principal moments' errors, the rms of error / sigma
(mass, COM, inertia), the median sigmas the noise alone allows (the bound), the median
fit time, and how many of the objects' inertias the estimator would publish (every
principal moment beyond its sigma, ``MotionResult.inertia_identified``) with the rms of
their error / sigma (what a user is shown; the rms z over all is of every fit, the
unpublished ones pressed against the consistency constraint besides). Goal, for 0.5 kg
and more and at most 3 s of motion: COM <= 1 mm and mass <= 0.5 % at the 95th
percentile, principal moments within 10 %, rms(error / sigma) near 1 (the figures and
what they say: bench/README.md).

``--static``: the same objects through the same sensor (the same seeds) explored at rest
as the sequencer's defaults do it, side by side: a tare pass of the empty hand (5 s at
each of home and the four 30 deg tilts), the grasp, the object pass (0.9 s at each pose,
0.3 s settling after 1 s moves), solved by the estimator's ``Exploration`` with its
defaults (information kinematics+mount, or ``--information``; the noise learnt, the
calibration's accuracy told): the 95th percentile of its mass and COM errors, its
rms(error / sigma), how many runs did not end OK, and the object pass's time against the
motion's; and, on the same windows, the fits users know (``BASELINES``): the paper's
two-pose method and an ft_calib-style least squares (none with 'wrenches': it needs the
kinematics), with the ratios of the 95th percentiles (ours / theirs).

``--calibrate KG``: each object's sensor (its serial) is first calibrated in place as the
sequencer runs it (``estimation.fits.in_place``): the same static exploration with a
box stated as KG kg as a reference weight (its true mass off that within OIML class
M1's tolerance, ``wrench_sim.objects.reference_weight_mass``), the estimator told the
stated mass (``reference_mass``), through a sensor of the same serial (its own noise);
the object's readings are then corrected by that calibration and its fits weigh what is
left of the error (``sensing.calibration``), in motion and at rest. Printed besides: the
share of each block of the calibration error the reference's poses left, median.
``--fixture``: the reference's COM told to the estimator within 0.05 mm
(``reference_com``: a weight on a fixture).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from com_core.contract import DONE, OBJECT_PREFIX, TARE_PREFIX
from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.estimators import two_pose
from com_core.estimation.fits.in_place import BLOCKS
from com_core.estimation.fits.motion import fit_motion, load_vector
from com_core.estimation.fits.windows import subtract_tare
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.fit_setup import INFORMATION, KINEMATICS_MOUNT
from com_core.estimation.runs.motion_solution import MotionResult
from com_core.estimation.runs.sensor_calibration import SensorCalibration
from com_core.estimation.runs.settings import exploration_from, use_sensor_calibration
from com_core.planning.excitation import (
    DEFAULT_ACCELERATION,
    acceleration_bounds,
    design_excitation,
)
from com_core.planning.motion_accuracy import HAND_CYCLES
from com_core.planning.planner import Plan
from com_core.planning.sensor_accuracy import FIXTURE_COM_SIGMA
from com_core.robot.choreography import Choreography
from com_core.robot.config import RobotConfig, read_robot_config
from com_core.robot.dynamics import INERTIA_ELEMENTS, inertial_parameters
from com_core.robot.model import RobotModel
from com_core.sensing.calibration import reading_correction
from com_core.sensing.sensor_profiles import PROFILES
from com_core.sensing.wrench_model import STANDARD_GRAVITY, skew
from wrench_sim.config import SimConfig
from wrench_sim.objects import reference_weight_mass
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import profile_sensor
from wrench_sim.studies import (
    feed,
    grasp,
    hold_still,
    joined,
    move_arm,
    run_excitation,
    without_rest,
)

SHAPES = ("box", "cylinder", "mug")
DIAGONAL = [4 + INERTIA_ELEMENTS.index(name) for name in ("ixx", "iyy", "izz")]  # in load_vector


def one_object(config, model, excitation, shape, mass, seed, every, profile, calibrated=None,
               hand_cycles=HAND_CYCLES) -> dict:  # fmt: skip
    """Hand (along ``hand_cycles`` periods), grasp, object: the object's errors, its error
    / sigma and its bound; with ``calibrated`` (the sensor's calibration in place) the
    readings corrected by it."""
    world = ArmWorld(SimConfig(robot=config, object_shape=shape, object_mass=mass, seed=seed))
    try:
        sensor = profile_sensor(profile, seed=seed, serial=seed, world=world)
        noise = profile.noise_model()
        stated = calibrated.calibration if calibrated else profile.calibration()
        hysteresis = profile.stated_hysteresis()
        correction = reading_correction(stated, hysteresis)

        def excite(cycles: int = 1) -> tuple:
            motion = replace(excitation, cycles=cycles)
            times, q, stamps, readings = without_rest(run_excitation(world, motion, sensor, every))
            if correction is not None:
                readings = readings @ correction.T
            return times, q, stamps, readings

        empty = excite(hand_cycles)
        hand = fit_motion(model, *empty, noise, calibration=stated, hysteresis=hysteresis)
        grasp(world, sensor=sensor)
        recorded = excite()
        start = time.perf_counter()
        fit = fit_motion(model, *recorded, noise, hand, stated, hysteresis=hysteresis)
        seconds = time.perf_counter() - start
        true_mass, true_com = world.object_ground_truth()
        true_inertia = world.inertia_ground_truth()[1]
        truth = load_vector(inertial_parameters(true_mass, true_com, true_inertia))
        mass_, com, inertia = fit.load()
        moments, axes = np.linalg.eigh(inertia)
        true_moments, true_axes = np.linalg.eigh(true_inertia)
        return {
            "mass": abs(mass_ - true_mass) / true_mass,
            "com": float(np.linalg.norm(com - true_com)),
            "moments": float(np.max(np.abs(moments - true_moments) / true_moments)),
            "axes": axes_error(moments, axes, true_moments, true_axes),
            "z": (fit.load_vector() - truth) / np.sqrt(np.diag(fit.load_cov())),
            "bound": np.sqrt(np.diag(fit.load_cov(fit.bound))) / np.abs(truth).clip(1e-12),
            "bound_com": np.sqrt(np.diag(fit.load_cov(fit.bound))[1:4]),
            "delay": fit.delay,
            "seconds": seconds,
            "published": MotionResult(hand, fit, fit.load_cov()).inertia_identified,
        }
    finally:
        world.close()


STATIC_PLAN = Plan(axes=("y", "x"), dwell=0.9)  # the sequencer's default poses and dwell
REFERENCE_SEEDS = 100_000  # a reference session's noise seed: the object's seed plus this
TARE_DWELL, MOVE, SETTLE = 5.0, 1.0, 0.3  # s


def reference_weight(kg: float, serial: int) -> tuple[float, int]:
    """(the true mass, kg, of a reference weight stated as ``kg`` kg, the noise seed of its
    session) for the sensor ``serial``: the seed apart from the object's
    (``REFERENCE_SEEDS``), the mass drawn from it
    (``wrench_sim.objects.reference_weight_mass``)."""
    noise_seed = serial + REFERENCE_SEEDS
    return reference_weight_mass(kg, noise_seed), noise_seed


def static_object(
    config,
    shape,
    mass,
    seed,
    every,
    profile,
    calibrated=None,
    reference=False,
    fixture=False,
    information=KINEMATICS_MOUNT,
) -> dict:
    """The same object explored at rest (see module): its errors, error / sigma and the
    object pass's time (s, sim); with ``calibrated`` (the sensor's calibration in place)
    read through it. ``reference``: the object is a reference weight, the exploration
    calibrates the sensor (its noise drawn apart from the object's): its solution's
    calibration (None when not kept) under "calibrated"; ``fixture``: the estimator told
    the reference's COM to 0.05 mm (a weight on a fixture of known geometry)."""
    true_mass, noise_seed = reference_weight(mass, seed) if reference else (mass, seed)
    world = ArmWorld(SimConfig(robot=config, object_shape=shape, object_mass=true_mass, seed=seed))
    try:
        sensor = profile_sensor(profile, seed=noise_seed, serial=seed, world=world)
        windows, object_time = record_static(world, sensor, every)
        reference_mass = mass if reference else 0.0
        exploration = static_exploration(world, windows, profile, reference_mass, information)
        use_sensor_calibration(exploration, calibrated)
        if fixture:  # the reference's COM in the hand, as a fixture's drawing gives it
            com = tuple(world.object_ground_truth()[1])
            exploration.reference = replace(
                exploration.reference, com=com, com_sigma=FIXTURE_COM_SIGMA
            )
        solution = exploration.solve()
        if reference:
            return {"calibrated": solution.calibration, "reason": solution.reason}
        return static_outcome(world, exploration, solution) | {"time": object_time}
    finally:
        world.close()


def record_static(world, sensor, every) -> tuple[list, float]:
    """([(label, what ``hold_still`` recorded, the way there)] of the sequencer's default
    static pass (see module) with ``world``'s object, read through ``sensor``; the object
    pass's time, s). The way (``studies.Way``): the move's readings where the sensor's
    gauges remember it, the grasp's before the first object window, and the settle's, as
    the node's estimator gets them."""
    config = world.config.robot
    poses = Choreography.of(config, world.urdf_text).pose_joints(STATIC_PLAN)
    windows, ways = [], []

    def window(label: str, joints, dwell: float) -> None:
        ways.append(move_arm(world, joints, MOVE, sensor))
        ways.append(hold_still(world, sensor, SETTLE, every)[2:])  # studies.SENSOR_CATCH_UP
        windows.append((label, hold_still(world, sensor, dwell, every), joined(ways)))
        ways.clear()

    for name, joints in poses:
        window(TARE_PREFIX + name, joints, TARE_DWELL)
    ways.append(grasp(world, sensor=sensor, catch_up=0.0))  # read in the first settle
    start = world.time
    for name, joints in poses:
        window(OBJECT_PREFIX + name, joints, STATIC_PLAN.dwell)
    return windows, world.time - start


def static_exploration(
    world, windows, profile, reference_mass=0.0, information=KINEMATICS_MOUNT, through=None
) -> Exploration:
    """The estimator's ``Exploration`` told ``profile``'s datasheet (as a user tells
    theirs) and, for a reference weight, its stated ``reference_mass`` (kg), fed
    ``record_static``'s ``windows``, each reading multiplied by ``through`` (6, 6) when
    given (another calibration matrix), and done."""
    config = world.config.robot
    settings = profile.datasheet() | {
        "accuracy": profile.calibration_accuracy,
        "sensor_frame": config.sensor_frame,
        "reference_mass": reference_mass,
        "information": information,
    }
    exploration = exploration_from(settings, world.urdf_text)
    for label, (joint_times, q, stamps, readings), (way_stamps, way) in windows:
        if through is not None:
            readings, way = readings @ through.T, way @ through.T
        feed(exploration, world, label, (joint_times, q, stamps, readings), (way_stamps, way))
    exploration.add_label(round(windows[-1][1][2][-1] * 1e9), DONE)  # the last sample's
    return exploration


def static_outcome(world, exploration, solution) -> dict:
    """A solved static exploration's mass and COM errors (relative; m), error / sigma
    (mass, COM), status and reason, and the ``BASELINES``' errors on its windows."""
    true_mass, true_com = world.object_ground_truth()

    def errors(mass_: float, com) -> dict:
        return {"mass": abs(mass_ - true_mass) / true_mass,
                "com": float(np.linalg.norm(np.asarray(com) - true_com))}  # fmt: skip

    others = {name: baseline_errors(fit, exploration, errors) for name, fit in BASELINES.items()}
    e = solution.estimate
    outcome = {"status": solution.status, "reason": solution.reason, "baselines": others}
    if e is None:
        return {"mass": np.nan, "com": np.nan, "z": np.full(4, np.nan), **outcome}
    truth = np.concatenate([[true_mass], true_com])
    z = (np.concatenate([[e.mass], e.com]) - truth) / np.sqrt(np.diag(e.cov))
    return {**errors(e.mass, e.com), "z": z, **outcome}


def at_rest(
    config, shape, mass, seed, every, profile, calibrated=None, information=KINEMATICS_MOUNT
) -> dict:
    """``static_object``, or status "no grasp" when the sim's gripper did not hold the
    object (the light mug of seed 5 is knocked off its stand by the direct move from the
    last tare pose): no estimator's doing, left out of the figures."""
    try:
        return static_object(
            config, shape, mass, seed, every, profile, calibrated, information=information
        )
    except RuntimeError as error:
        return {"status": "no grasp", "reason": str(error)}


def baseline_errors(fit, exploration, errors) -> dict:
    """``errors`` of a baseline ``fit`` of ``exploration``; NaN where it refuses the
    windows (the two-pose method's tilt check, on a noisy sensor)."""
    try:
        return errors(*fit(exploration))
    except EstimationError:
        return {"mass": np.nan, "com": np.nan}


def paper_two_pose(exploration: Exploration) -> tuple[float, np.ndarray]:
    """kg, m: the paper's method (eqs. 3, 7, 8, 11; ``estimators.two_pose``) on the run's
    first two tare-subtracted object windows (home and the first tilt)."""
    tares, objects, _, _ = exploration.reduced_windows()
    e = two_pose(subtract_tare(objects, tares.values()))
    return e.mass, e.com


def ft_calib_least_squares(exploration: Exploration) -> tuple[float, np.ndarray]:
    """kg, m: an ft_calib-style fit (as ROS's force_torque_tools' ft_calib solves it):
    per pass, unweighted linear least squares of the load's mass, first moment m c and
    the sensor's bias (6) from the windows' means and the gravity the kinematics give in
    the sensor frame, f = m g_s + b_f, tau = m c x g_s + b_tau; the hand's fit (the tare
    pass) taken from the whole load's (the object pass)."""
    if exploration.robot is None:  # the estimator told 'wrenches': no kinematics
        raise EstimationError("ft_calib needs each window's gravity from the kinematics")
    tares, objects, _, _ = exploration.reduced_windows()

    def fit(prefix: str, windows) -> np.ndarray:
        rows, values = [], []
        for w in windows:
            g_s = exploration.window_rotation(prefix + w.pose).T @ [0.0, 0.0, -STANDARD_GRAVITY]
            design = np.zeros((6, 10))
            design[:3, 0], design[:3, 4:7] = g_s, np.eye(3)
            design[3:, 1:4], design[3:, 7:] = -skew(g_s), np.eye(3)  # m c x g = -g x (m c)
            rows.append(design)
            values.append(w.mean)
        return np.linalg.lstsq(np.vstack(rows), np.concatenate(values), rcond=None)[0]

    whole, hand = fit(OBJECT_PREFIX, objects), fit(TARE_PREFIX, tares.values())
    mass = whole[0] - hand[0]
    return mass, (whole[1:4] - hand[1:4]) / mass


BASELINES = {"paper two-pose": paper_two_pose, "ft_calib LS": ft_calib_least_squares}
"""The fits users know, on the same static windows as the estimator's."""


def axes_error(moments, axes, true_moments, true_axes) -> float:
    """deg: the largest angle between an estimated principal axis and the true one, over
    the axes whose true moment stands 10 % apart from the others' (nan: none does)."""
    angles = []
    for k in range(3):
        others = np.delete(true_moments, k)
        if np.all(np.abs(others - true_moments[k]) > 0.1 * true_moments[k]):
            cosine = abs(float(axes[:, k] @ true_axes[:, k]))
            angles.append(np.degrees(np.arccos(min(cosine, 1.0))))
    return max(angles) if angles else float("nan")


def wrist_bounds(config: RobotConfig, acceleration: str) -> tuple[float, ...]:
    """rad/s^2, the wrist joints' bounds of ``--acceleration``: a number within the arm's
    own limits, or ``limits``, the arm's own (SystemExit when it states none)."""
    bound = np.inf if acceleration == "limits" else float(acceleration)
    bounds = acceleration_bounds(bound, config.arm_joints[-3:], config.arm_joints,
                                 config.max_joint_acceleration)  # fmt: skip
    if not np.all(np.isfinite(bounds)):
        raise SystemExit(f"{config.robot}: its configuration states no acceleration limits")
    return bounds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=50)
    parser.add_argument("--robots", default="panda,xarm6")
    parser.add_argument("--masses", default="0.05,0.2,0.5,2.0")
    parser.add_argument("--period", type=float, default=3.0)
    parser.add_argument("--acceleration", default=str(DEFAULT_ACCELERATION),
                        help="rad/s^2, or 'limits': the arm's own")  # fmt: skip
    parser.add_argument("--joint-rate", type=float, default=100.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hand-cycles", type=int, default=HAND_CYCLES,
                        help="periods of the empty hand's motion")  # fmt: skip
    parser.add_argument("--profile", default="realistic", choices=sorted(PROFILES))
    parser.add_argument("--calibration-accuracy", type=float,
                        help="in place of the profile's stated accuracy")  # fmt: skip
    parser.add_argument(
        "--information",
        default=KINEMATICS_MOUNT,
        choices=INFORMATION,
        help="the estimator's information at rest (a wrench estimated from "
        "the joint torques wants 'wrenches')",
    )
    parser.add_argument("--static", action="store_true",
                        help="the same objects explored at rest, side by side")  # fmt: skip
    parser.add_argument("--calibrate", type=float, metavar="KG", default=0.0,
                        help="calibrate each sensor first with a KG reference")  # fmt: skip
    parser.add_argument("--fixture", action="store_true",
                        help="with --calibrate: the reference's COM known to 0.05 mm")  # fmt: skip
    args = parser.parse_args()
    profile = PROFILES[args.profile]
    if args.calibration_accuracy is not None:
        profile = profile.with_overrides(calibration_accuracy=args.calibration_accuracy)
    every = round(1000.0 / args.joint_rate)
    print(f"{args.objects} objects per case, {args.period:g} s of motion within "
          f"{args.acceleration} rad/s^2 (the empty hand's {args.hand_cycles} times as "
          f"long), joint states at "
          f"{1000.0 / every:g} Hz, the {args.profile} sensor, calibration accuracy "
          f"{profile.calibration_accuracy:g}")  # fmt: skip
    if args.calibrate:
        print(f"each sensor calibrated in place first with a {args.calibrate:g} kg reference")
    header = (f"{'arm':>6} {'kg':>5}  {'mass p95':>8} {'COM p95 mm':>10} {'moments p95':>11} "
              f"{'axes p95':>8}  {'rms z m, COM, I':>17}  {'bound m, COM mm, I':>20} "
              f"{'delay ms':>8} {'fit s':>5} {'inertia published, rms z':>25}")  # fmt: skip
    rows = []
    for robot in args.robots.split(","):
        config = read_robot_config(robot)
        world = ArmWorld(SimConfig(robot=config))
        model = RobotModel(world.urdf_text, config.sensor_frame)
        world.close()
        excitation = design_excitation(model, config.home_joints, config.arm_joints[-3:],
                                       args.period, wrist_bounds(config, args.acceleration),
                                       seed=args.seed)  # fmt: skip
        seeds = range(args.seed, args.seed + args.objects)
        calibrated = {k: None for k in seeds}
        if args.calibrate:
            sessions = {k: static_object(config, "box", args.calibrate, k, every, profile,
                                         reference=True, fixture=args.fixture)
                        for k in seeds}  # fmt: skip
            calibrated = {k: SensorCalibration(f"sim-{k}", 0.0, r["calibrated"])
                          if r["calibrated"] else None for k, r in sessions.items()}  # fmt: skip
            kept = [c.result for c in calibrated.values() if c is not None]
            refused = [r["reason"] for r in sessions.values() if r["calibrated"] is None]
            left = np.median([list(c.left.values()) for c in kept], axis=0) if kept else []
            print(f"{robot}: {len(kept)} of {len(seeds)} sensors calibrated in place with "
                  f"{args.calibrate:g} kg; left of each block (median): "
                  f"{', '.join(f'{n} {v:.2f}' for n, v in zip(BLOCKS, left, strict=False))}"
                  + (f"; not kept: {refused[0]}" if refused else ""), flush=True)  # fmt: skip
        for mass in (float(m) for m in args.masses.split(",")):
            shapes = {k: SHAPES[k % 3] for k in seeds}
            results = [one_object(config, model, excitation, shapes[k], mass, k, every, profile,
                                  calibrated[k], args.hand_cycles) for k in seeds]  # fmt: skip
            z = np.array([r["z"] for r in results])
            shown = z[[r["published"] for r in results], 4:]
            bound = np.median([r["bound"] for r in results], axis=0)
            bound_com = np.median([r["bound_com"] for r in results], axis=0)
            axes = [r["axes"] for r in results if np.isfinite(r["axes"])]
            rows.append(
                f"{robot:>6} {mass:5.2f}  "
                f"{100 * np.percentile([r['mass'] for r in results], 95):7.3f}% "
                f"{1e3 * np.percentile([r['com'] for r in results], 95):10.3f} "
                f"{100 * np.percentile([r['moments'] for r in results], 95):10.1f}% "
                f"{np.percentile(axes, 95) if axes else float('nan'):7.1f}d  "
                f"{np.sqrt(np.mean(z[:, 0] ** 2)):5.2f} {np.sqrt(np.mean(z[:, 1:4] ** 2)):5.2f} "
                f"{np.sqrt(np.mean(z[:, 4:] ** 2)):5.2f}  "
                f"{100 * bound[0]:5.3f}% {1e3 * bound_com.max():6.3f} "
                f"{100 * np.median(bound[DIAGONAL]):5.1f}% "
                f"{1e3 * np.median([r['delay'] for r in results]):8.2f} "
                f"{np.median([r['seconds'] for r in results]):5.2f} "
                f"{len(shown):>10} of {len(results)}, "
                + (f"{np.sqrt(np.mean(shown**2)):4.2f}" if len(shown) else "   -")
            )
            print(rows[-1], flush=True)
            if args.static:
                runs = [at_rest(config, shapes[k], mass, k, every, profile, calibrated[k],
                                args.information) for k in seeds]  # fmt: skip
                static = [r for r in runs if r["status"] != "no grasp"]
                zs = np.array([r["z"] for r in static])
                rows.append(
                    f"{'static':>12}  "
                    f"{100 * np.nanpercentile([r['mass'] for r in static], 95):7.3f}% "
                    f"{1e3 * np.nanpercentile([r['com'] for r in static], 95):10.3f} "
                    f"{'-':>11} {'-':>8}  "
                    f"{np.sqrt(np.nanmean(zs[:, 0] ** 2)):5.2f} "
                    f"{np.sqrt(np.nanmean(zs[:, 1:] ** 2)):5.2f} {'-':>5}  "
                    f"object pass {np.median([r['time'] for r in static]):.1f} s against the "
                    f"motion's {args.period:g} s"
                    + (f"; {len(runs) - len(static)} not grasped" if len(static) < len(runs)
                       else "")
                    + (f"; {len(static) - ok} not OK" if (ok := sum(
                        r["status"] == "OK" for r in static)) < len(static) else "")
                )  # fmt: skip
                print(rows[-1], flush=True)
                ours = [np.nanpercentile([r[k] for r in static], 95) for k in ("mass", "com")]
                for name in BASELINES:
                    if all(np.isnan(r["baselines"][name]["mass"]) for r in static):
                        rows.append(f"{name:>18}  no estimate from any run's windows")
                        print(rows[-1], flush=True)
                        continue
                    theirs = [np.nanpercentile([r["baselines"][name][k] for r in static], 95)
                              for k in ("mass", "com")]  # fmt: skip
                    rows.append(
                        f"{name:>18}  {100 * theirs[0]:7.3f}% {1e3 * theirs[1]:10.3f}  on the "
                        f"same windows; ours / theirs: mass {ours[0] / theirs[0]:.2f}, "
                        f"COM {ours[1] / theirs[1]:.2f}"
                    )
                    print(rows[-1], flush=True)
    print(header)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
