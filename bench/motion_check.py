"""False alarms of an exploration's own tests, over many sensors, arms and loads.

    source ./env.sh && python bench/motion_check.py [--sensors 10] [--first 0]
        [--robots panda,xarm6,ur5e] [--masses 0.1,0.5,2.0] [--static]
        [--profile realistic] [--calibration-accuracy 0.01] [--period 3]
        [--acceleration 8|limits] [--hand-cycles 4]

In process, no ROS: per arm, mass and sensor serial (the ``--profile``'s sensor, the
estimator told its datasheet, a calibration drawn per serial at its accuracy or
``--calibration-accuracy``; a box, cylinder or mug in turn, its COM drawn from the serial) the
exploration the sequencer runs with ``excitation: motion`` (``wrench_sim.studies
.explore_in_motion``), solved as the estimator and the replay solve it
(``Exploration.solve``), its excitation of ``--period`` s within ``--acceleration`` rad/s^2
(``limits``: the arm's own), the empty hand along ``--hand-cycles`` periods of it (the
sequencer's ``hand_motion_cycles``); with ``--static`` also the default exploration at
rest of the same object through the same sensor (``bench/motion.py``'s
``static_object``). Nothing is wrong with any of these runs, so every WARN is a false
alarm: in motion, of the one-rigid-load test (chi^2/dof below ``MAX_CHI2_PER_DOF``
times what the noise, the encoders and the calibration explain, or more where the
calibration's misfit rules: ``allowed_chi2_per_dof``) or of the check along the motion no
fit used (its ratio to the prediction above the allowance, forces and torques); at rest,
of the consistency test or the verification pose. Printed: per run, its chi^2/dof against what
is explained, the check's ratios against their allowances, the 10 parameters' largest
|error / sigma| (mass, COM, the inertia's 6 elements), whether the object's fit was
projected onto a physical body and whether its inertia is published; per case, the false
alarms against the ``alpha`` the checks are set to (the reference: the rate it allows).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from motion import SHAPES, at_rest, wrist_bounds

from com_core.estimation.fits.estimators import DEFAULT_ALPHA
from com_core.estimation.fits.motion import load_vector
from com_core.estimation.runs.motion_solution import allowed_chi2_per_dof
from com_core.planning.excitation import DEFAULT_ACCELERATION
from com_core.planning.motion_accuracy import HAND_CYCLES
from com_core.robot.config import read_robot_config
from com_core.robot.dynamics import inertial_parameters
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.studies import explore_in_motion


def one_sensor(
    profile: str,
    accuracy: float,
    serial: int,
    robot: str,
    mass: float,
    period: float,
    acceleration: str,
    hand_cycles: int = HAND_CYCLES,
) -> dict:
    """The run in motion of sensor ``serial``: status, chi^2/dof and what is explained,
    the check's ratios and allowances, the largest |error / sigma|, whether the object's
    fit was constrained and its inertia published."""
    started = time.perf_counter()
    bounds = wrist_bounds(read_robot_config(robot), acceleration)
    run = explore_in_motion(accuracy, serial, robot=robot, mass=mass, shape=SHAPES[serial % 3],
                            object_seed=serial, period=period, acceleration=bounds,
                            profile=profile, hand_cycles=hand_cycles)  # fmt: skip
    try:
        solution, result = run.solution, run.solution.motion
        (mass_, com), inertia = run.world.object_ground_truth(), run.world.inertia_ground_truth()
        truth = load_vector(inertial_parameters(mass_, com, inertia[1]))
        z = (result.object.load_vector() - truth) / np.sqrt(np.diag(result.load_cov))
        (check,) = solution.verifications
        return {
            "status": solution.status,
            "reason": solution.reason,
            "chi2_dof": solution.consistency.chi2 / solution.consistency.dof,
            "expected": result.object.expected,
            "rigid_allowed": allowed_chi2_per_dof(result.object, DEFAULT_ALPHA),
            "ratio": check.ratio,
            "allowed": check.allowed,
            "z": float(np.max(np.abs(z))),
            "constrained": result.object.constrained,
            "published": result.inertia_identified,
            "seconds": time.perf_counter() - started,
        }
    finally:
        run.world.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sensors", type=int, default=10)
    parser.add_argument("--first", type=int, default=0, help="the first sensor serial")
    parser.add_argument("--robots", default="panda,xarm6,ur5e")
    parser.add_argument("--masses", default="0.1,0.5,2.0")
    parser.add_argument("--static", action="store_true", help="the same objects at rest too")
    parser.add_argument("--profile", default="realistic", choices=sorted(PROFILES))
    parser.add_argument("--calibration-accuracy", type=float,
                        help="default: the profile's")  # fmt: skip
    parser.add_argument("--period", type=float, default=3.0)
    parser.add_argument("--hand-cycles", type=int, default=HAND_CYCLES,
                        help="periods of the empty hand's motion")  # fmt: skip
    parser.add_argument("--acceleration", default=str(DEFAULT_ACCELERATION),
                        help="rad/s^2, or 'limits': the arm's own")  # fmt: skip
    args = parser.parse_args()
    stated = PROFILES[args.profile]
    if args.calibration_accuracy is None:
        args.calibration_accuracy = stated.calibration_accuracy
    profile = stated.with_overrides(calibration_accuracy=args.calibration_accuracy)
    serials = range(args.first, args.first + args.sensors)
    cases = []
    for robot in args.robots.split(","):
        for mass in (float(m) for m in args.masses.split(",")):
            runs = []
            for serial in serials:
                r = one_sensor(args.profile, args.calibration_accuracy, serial, robot, mass,
                               args.period, args.acceleration, args.hand_cycles)  # fmt: skip
                runs.append(r)
                print(f"{robot} {mass:g} kg sensor {serial:3d} {r['status']:4s} chi2/dof "
                      f"{r['chi2_dof']:.3f} ({r['chi2_dof'] / r['expected']:.2f} of explained, "
                      f"allowed {r['rigid_allowed'] / r['expected']:.2f})"
                      f"  check {r['ratio'][0]:.2f} {r['ratio'][1]:.2f} (allowed "
                      f"{r['allowed'][0]:.2f} {r['allowed'][1]:.2f})  max |z| {r['z']:.2f}"
                      f"{'  constrained' if r['constrained'] else ''}"
                      f"{'' if r['published'] else '  inertia not published'}"
                      f"  {r['seconds']:.1f} s"
                      + ("" if r["status"] == "OK" else f"\n    {r['reason'][:300]}"),
                      flush=True)  # fmt: skip
            static = []
            if args.static:
                config = read_robot_config(robot)
                static = [at_rest(config, SHAPES[k % 3], mass, k, 10, profile) for k in serials]
                for k, s in zip(serials, static, strict=True):
                    if s["status"] != "OK":
                        print(f"    at rest, sensor {k}: {s['status']} {s['reason'][:300]}")
            cases.append((robot, mass, runs, static))
    n = len(serials)
    print(f"\n{n} {args.profile} sensors per case, calibration accuracy "
          f"{args.calibration_accuracy:g}; "
          f"alpha {DEFAULT_ALPHA:g} allows {n * DEFAULT_ALPHA:.3f} false alarms per test per "
          "case")  # fmt: skip
    print(f"{'arm':>6} {'kg':>4}  {'motion WARN':>11} {'chi2/dof / explained':>20} "
          f"{'check / allowed':>15} {'max |z|':>7} {'projected':>9} {'inertia':>9}"
          f"{'  at rest WARN' if args.static else ''}")  # fmt: skip
    for robot, mass, runs, static in cases:
        ratio = max(r["chi2_dof"] / r["expected"] for r in runs)
        allowed = min(r["rigid_allowed"] / r["expected"] for r in runs)
        check = max(max(np.divide(r["ratio"], r["allowed"])) for r in runs)
        warn = sum(r["status"] != "OK" for r in runs)
        warned = sum(s["status"] == "WARN" for s in static)
        ungrasped = sum(s["status"] == "no grasp" for s in static)
        print(f"{robot:>6} {mass:4.1f}  {warn:>4} of {n:<3} {ratio:11.2f} (<= "
              f"{allowed:.2f})  {check:9.2f} (<= 1) {max(r['z'] for r in runs):7.2f} "
              f"{sum(r['constrained'] for r in runs):>5} of {n:<2} "
              f"{sum(r['published'] for r in runs):>3} of {n:<2}"
              + (f"  {warned:>5} of {n - ungrasped}" if static else ""))  # fmt: skip


if __name__ == "__main__":
    main()
