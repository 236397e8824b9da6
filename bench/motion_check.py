"""False alarms of an exploration in motion's own tests, over many sensors.

    source ./env.sh && python bench/motion_check.py [--sensors 73] [--first 0]
        [--calibration-accuracy 0.01]

In process, no ROS: per sensor serial (the realistic profile, a calibration drawn per
serial) the exploration the sequencer runs with ``excitation: motion`` on the Panda with
a 0.5 kg box (``wrench_sim.studies.explore_in_motion``), solved as the estimator and the
replay solve it (``Exploration.solve``). Nothing is wrong with any of these runs, so
every WARN is a false alarm: of the one-rigid-load test (chi^2/dof below
``MAX_CHI2_PER_DOF``) or of the check along the motion no fit used (its ratio to the
prediction above the allowance, forces and torques). Printed: per run, its chi^2/dof, the
check's ratios against their allowances, the 10 parameters' largest |error / sigma|
(mass, COM, the inertia's 6 elements), and whether the object's fit was projected onto a
physical body; then the false alarms against the ``alpha`` the check is set to (the
reference: the rate it allows), and the ranges.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from com_core.estimation.fits.estimators import DEFAULT_ALPHA
from com_core.estimation.fits.motion import load_vector
from com_core.estimation.runs.motion_solution import MAX_CHI2_PER_DOF
from com_core.robot.dynamics import inertial_parameters
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.studies import explore_in_motion


def one_sensor(accuracy: float, serial: int) -> dict:
    """The run of sensor ``serial``: status, chi^2/dof, the check's ratios and allowances,
    the largest |error / sigma| and whether the object's fit was constrained."""
    started = time.perf_counter()
    run = explore_in_motion(accuracy, serial)
    try:
        solution, result = run.solution, run.solution.motion
        (mass, com), inertia = run.world.object_ground_truth(), run.world.inertia_ground_truth()[1]
        truth = load_vector(inertial_parameters(mass, com, inertia))
        z = (result.object.load_vector() - truth) / np.sqrt(np.diag(result.load_cov))
        (check,) = solution.verifications
        return {
            "status": solution.status,
            "chi2_dof": solution.consistency.chi2 / solution.consistency.dof,
            "ratio": check.ratio,
            "allowed": check.allowed,
            "z": float(np.max(np.abs(z))),
            "constrained": result.object.constrained,
            "seconds": time.perf_counter() - started,
        }
    finally:
        run.world.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sensors", type=int, default=73)
    parser.add_argument("--first", type=int, default=0, help="the first sensor serial")
    parser.add_argument("--calibration-accuracy", type=float,
                        default=PROFILES["realistic"].calibration_accuracy)  # fmt: skip
    args = parser.parse_args()
    runs = []
    for serial in range(args.first, args.first + args.sensors):
        r = one_sensor(args.calibration_accuracy, serial)
        runs.append(r)
        print(f"sensor {serial:3d} {r['status']:4s} chi2/dof {r['chi2_dof']:.3f}  check "
              f"{r['ratio'][0]:.2f} {r['ratio'][1]:.2f} (allowed {r['allowed'][0]:.2f} "
              f"{r['allowed'][1]:.2f})  max |z| {r['z']:.2f}"
              f"{'  constrained' if r['constrained'] else ''}  {r['seconds']:.1f} s",
              flush=True)  # fmt: skip
    n = len(runs)
    chi = [r["chi2_dof"] for r in runs]
    ratios = np.array([r["ratio"] for r in runs])
    allowed = np.array([r["allowed"] for r in runs])
    failed = int(np.sum(np.any(ratios > allowed, axis=1)))
    inconsistent = sum(c > MAX_CHI2_PER_DOF for c in chi)
    projected = sum(r["constrained"] for r in runs)
    print(f"\n{n} sensors, calibration accuracy {args.calibration_accuracy:g}, "
          f"{projected} fits projected onto a physical body")  # fmt: skip
    print(f"false alarms: check {failed} of {n} (alpha {DEFAULT_ALPHA:g} allows "
          f"{n * DEFAULT_ALPHA:.2f}), chi2/dof above {MAX_CHI2_PER_DOF:g}: {inconsistent}; "
          f"WARN in all {sum(r['status'] != 'OK' for r in runs)}")  # fmt: skip
    print(f"chi2/dof {min(chi):.3f}-{max(chi):.3f}; check ratio {ratios.min():.2f}-"
          f"{ratios.max():.2f} against allowances {allowed.min():.2f}-{allowed.max():.2f}, "
          f"largest ratio / allowance {np.max(ratios / allowed):.2f}; largest |z| per run "
          f"median {np.median([r['z'] for r in runs]):.2f}, max "
          f"{max(r['z'] for r in runs):.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
