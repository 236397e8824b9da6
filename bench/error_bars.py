"""Honest error bars over many calibrations: each run recorded once, read through many.

    source ./env.sh && python bench/error_bars.py [--objects 10] [--draws 20]
        [--robot panda] [--masses 0.1,0.5,2.0] [--profile realistic] [--seed 0]
        [--calibration-accuracy 0.03] [--without hysteresis] [--calibrate KG]

A sensor's calibration error is the same in every sample it reads, so the rms of error /
sigma over the few sensors a bench simulates (``bench/motion.py``: 30, serials 0-29, the
same in every case) carries their draw as much as the estimator's error bars: where the
calibration's share rules (a 3 % sensor at 2 kg), 30 fixed matrices are 30 samples of it,
not one per run and case. The sensor reads C times what its gauges give (its low-pass,
bias, noise, hysteresis and the rest come first; ``wrench_sim.sensor``), so a run
recorded through the sensor with C = I reads through any other C as readings C^T
afterwards (its quantisation then before C, not after: a change of C's percent of a
count).

Per object (box, cylinder, mug in turn; seed and serial from ``--seed`` on), the arm
explores it once at rest (the sequencer's default pass, ``motion.record_static``) and
once in motion (the empty hand, the grasp, the object; the arm's 3 s excitation), through
``--profile``'s sensor with its calibration matrix I; each run is then solved as
``bench/motion.py`` solves it (the estimator told the profile's datasheet) under
``--draws`` calibrations: the serial's own (draw 0, the sensor ``bench/motion.py`` reads
through) and draws - 1 more of the profile's accuracy (``calibration_matrix``). Printed
per case: the rms error / sigma of the mass, the COM (and the inertia in motion) over the
serials' own calibrations (n = objects) and over every draw (n = objects x draws), with
the mean error / sigma of the mass (a bias every sensor shares) and the 95th percentiles
of the mass and COM errors over every draw.

``--without PART``: the profile without its hysteresis or non-linearity, in the sensor
and in what the estimator is told. ``--calibrate KG``: each sensor first calibrated in
place under each of its draws, as ``bench/motion.py --calibrate`` does it (a KG kg box as
the reference weight, explored at rest once through the same serial with its own noise,
solved under each C); the object's runs under that C are then corrected by that
calibration and weigh what it left.
"""

from __future__ import annotations

import argparse

import numpy as np
from motion import (
    SHAPES,
    record_static,
    reference_weight,
    static_exploration,
    static_outcome,
    wrist_bounds,
)

from com_core.estimation.fits.motion import fit_motion, load_vector
from com_core.estimation.runs.sensor_calibration import SensorCalibration
from com_core.estimation.runs.settings import use_sensor_calibration
from com_core.planning.excitation import DEFAULT_ACCELERATION, design_excitation
from com_core.robot.config import read_robot_config
from com_core.robot.dynamics import inertial_parameters
from com_core.robot.model import RobotModel
from com_core.sensing.calibration import reading_correction
from com_core.sensing.sensor_profiles import PROFILES
from com_core.sensing.wrench_model import calibration_matrix
from wrench_sim.config import SimConfig
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import profile_calibration, profile_sensor
from wrench_sim.studies import grasp, run_excitation, without_rest

DRAWS_SEED = 7_000  # the extra calibrations' stream: (DRAWS_SEED, serial)
EVERY = 10  # joint states at 100 Hz, as bench/motion.py's default


def calibrations(profile, serial: int, draws: int) -> list[np.ndarray]:
    """(6, 6) matrices C: the ``serial``'s own, then ``draws`` - 1 more of ``profile``'s
    accuracy."""
    rng = np.random.default_rng((DRAWS_SEED, serial))
    more = [calibration_matrix(profile.calibration_accuracy, profile.limit_f,
                               profile.limit_tau, rng) for _ in range(draws - 1)]  # fmt: skip
    return [profile_calibration(profile, serial), *more]


def through(recorded: tuple, c: np.ndarray, correction=None) -> tuple:
    """``recorded`` (joint stamps, positions, wrench stamps, readings) read through C,
    then by ``correction`` (6, 6; ``sensing.calibration.reading_correction``; None: as
    read)."""
    *joints, readings = recorded
    return (*joints, readings @ (c.T if correction is None else c.T @ correction.T))


def perfectly_calibrated(config, shape, kg, serial, profile, noise_seed) -> tuple:
    """(world holding the object, its sensor ``serial`` of ``profile`` but for a
    calibration matrix I, its noise drawn from ``noise_seed``)."""
    world = ArmWorld(SimConfig(robot=config, object_shape=shape, object_mass=kg, seed=serial))
    perfect = profile.with_overrides(calibration_accuracy=0.0)
    return world, profile_sensor(perfect, seed=noise_seed, serial=serial, world=world)


def in_place(config, kg, serial, profile, matrices) -> list[SensorCalibration | None]:
    """The sensor's calibration in place under each of ``matrices`` (None where refused):
    a box stated as ``kg`` kg explored at rest as the reference weight (``bench/motion.py``'s
    ``--calibrate``: its true mass off that within its class's tolerance, its noise drawn
    apart from the object's), recorded once."""
    true_mass, noise_seed = reference_weight(kg, serial)
    world, sensor = perfectly_calibrated(config, "box", true_mass, serial, profile, noise_seed)
    try:
        windows, _ = record_static(world, sensor, EVERY)
        out = []
        for c in matrices:
            exploration = static_exploration(world, windows, profile, kg, through=c)
            result = exploration.solve().calibration
            out.append(None if result is None else SensorCalibration(f"sim-{serial}", 0.0, result))
        return out
    finally:
        world.close()


def at_rest(config, shape, mass, serial, profile, matrices, calibrated) -> list[np.ndarray]:
    """(mass error, COM error m, z (4,)) of the static exploration under each of
    ``matrices``, with the sensor's calibration in place under it (``calibrated``, None:
    the stated accuracy); [] when the sim's gripper did not hold the object."""
    world, sensor = perfectly_calibrated(config, shape, mass, serial, profile, serial)
    try:
        try:
            windows, _ = record_static(world, sensor, EVERY)
        except RuntimeError:  # not grasped (bench/motion.py's at_rest)
            return []
        out = []
        for c, entry in zip(matrices, calibrated, strict=True):
            exploration = static_exploration(world, windows, profile, through=c)
            use_sensor_calibration(exploration, entry)
            r = static_outcome(world, exploration, exploration.solve())
            out.append(np.concatenate([[r["mass"], r["com"]], r["z"]]))
        return out
    finally:
        world.close()


def in_motion(config, model, excitation, shape, mass, serial, profile, matrices, calibrated):
    """(mass error, COM error m, z (10,)) of the motion fits under each of ``matrices``,
    the readings corrected by the calibration in place under it (``calibrated``)."""
    world, sensor = perfectly_calibrated(config, shape, mass, serial, profile, serial)
    try:
        empty = without_rest(run_excitation(world, excitation, sensor, EVERY))
        grasp(world, sensor=sensor)
        loaded = without_rest(run_excitation(world, excitation, sensor, EVERY))
        true_mass, true_com = world.object_ground_truth()
        inertia = world.inertia_ground_truth()[1]
        truth = load_vector(inertial_parameters(true_mass, true_com, inertia))
        noise = profile.noise_model()
        out = []
        for c, entry in zip(matrices, calibrated, strict=True):
            stated = entry.calibration if entry else profile.calibration()
            hysteresis = profile.stated_hysteresis()
            correction = reading_correction(stated, hysteresis)
            read = [through(run, c, correction) for run in (empty, loaded)]
            hand = fit_motion(model, *read[0], noise, calibration=stated, hysteresis=hysteresis)
            fit = fit_motion(model, *read[1], noise, hand, stated, hysteresis=hysteresis)
            got = fit.load_vector()
            z = (got - truth) / np.sqrt(np.diag(fit.load_cov()))
            errors = [abs(got[0] - true_mass) / true_mass, np.linalg.norm(got[1:4] - true_com)]
            out.append(np.concatenate([errors, z]))
        return out
    finally:
        world.close()


def row(label: str, runs: list[list[np.ndarray]]) -> str:
    """One case's line: rms z over the serials' own calibrations and over every draw, the
    mean z of the mass over every draw (a bias the sensors share), the errors' p95."""
    own = np.array([r[0] for r in runs if r])
    every = np.array([x for r in runs for x in r])

    def rms(a: np.ndarray) -> str:
        z = [a[:, 2], a[:, 3:6]] + ([a[:, 6:]] if a.shape[1] > 6 else [])
        return " ".join(f"{np.sqrt(np.nanmean(x**2)):4.2f}" for x in z)

    return (
        f"{label:>12}  own ({len(own):3d}) {rms(own):14}  every draw ({len(every):4d}) "
        f"{rms(every):14}  {np.nanmean(every[:, 2]):+5.2f}  "
        f"{100 * np.nanpercentile(every[:, 0], 95):6.3f}% "
        f"{1e3 * np.nanpercentile(every[:, 1], 95):7.3f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--objects", type=int, default=10)
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--masses", default="0.1,0.5,2.0")
    parser.add_argument("--profile", default="realistic", choices=sorted(PROFILES))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--calibration-accuracy", type=float,
                        help="the profile's accuracy changed (of full scale)")  # fmt: skip
    parser.add_argument("--without", action="append", default=[], metavar="PART",
                        choices=("hysteresis", "nonlinearity"),
                        help="the profile without this part, in sensor and estimator")  # fmt: skip
    parser.add_argument("--calibrate", type=float, metavar="KG", default=0.0,
                        help="calibrate each sensor in place with a KG reference")  # fmt: skip
    args = parser.parse_args()
    profile = PROFILES[args.profile].with_overrides(**{part: () for part in args.without})
    if args.calibration_accuracy is not None:
        profile = profile.with_overrides(calibration_accuracy=args.calibration_accuracy)
    if profile.calibration_accuracy <= 0:
        raise SystemExit(f"the {args.profile} profile states no calibration accuracy")
    config = read_robot_config(args.robot)
    world = ArmWorld(SimConfig(robot=config))
    model = RobotModel(world.urdf_text, config.sensor_frame)
    world.close()
    excitation = design_excitation(model, config.home_joints, config.arm_joints[-3:], 3.0,
                                   wrist_bounds(config, str(DEFAULT_ACCELERATION)),
                                   seed=args.seed)  # fmt: skip
    print(
        f"{args.robot}, the {args.profile} sensor, {args.objects} objects, {args.draws} "
        "calibrations each: rms z of mass, COM (, inertia); of every draw, the mass's mean z "
        "and the mass and COM errors' p95"
    )
    serials = range(args.seed, args.seed + args.objects)
    matrices = {k: calibrations(profile, k, args.draws) for k in serials}
    calibrated = {k: in_place(config, args.calibrate, k, profile, matrices[k])
                  if args.calibrate else [None] * args.draws for k in serials}  # fmt: skip
    kept = sum(e is not None for k in serials for e in calibrated[k])
    if args.calibrate:
        print(
            f"calibrated in place with {args.calibrate:g} kg: {kept} of "
            f"{args.objects * args.draws} kept, the rest at the stated accuracy"
        )
    for mass in (float(m) for m in args.masses.split(",")):
        shapes = {k: SHAPES[k % 3] for k in serials}
        rest = [at_rest(config, shapes[k], mass, k, profile, matrices[k], calibrated[k])
                for k in serials]  # fmt: skip
        print(row(f"{mass:.2f} static", rest), flush=True)
        moving = [in_motion(config, model, excitation, shapes[k], mass, k, profile,
                            matrices[k], calibrated[k]) for k in serials]  # fmt: skip
        print(row(f"{mass:.2f} motion", moving), flush=True)


if __name__ == "__main__":
    main()
