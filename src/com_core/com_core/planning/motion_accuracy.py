"""What a wrist motion tells of an object before anything moves: the predicted sigmas of
an exploration in motion (mass, COM, principal moments), and how long a motion the
inertia needs.

    python -m com_core.planning.motion_accuracy [--robot panda] [--profile realistic]
        [--masses 0.1,0.5,2.0] [--density 1000] [--com 0,0,0.1] [--period 3]
        [--acceleration 8] [--target 0.2] [--reference 1.0] [--hand-cycles 4]

The prediction (``predict_motion``) is the estimator's own fit (``fits.motion.fit_motion``:
the empty hand's, then the object's with the hand taken off) of the wrench the loads would
give along the excitation, read without noise at 1 kHz with joint states at 100 Hz: its
covariance is the bound of the sensor's noise model plus the calibration's share (the
stated accuracy, or what a calibration in place left) and what a stated hysteresis leaves
(``sensing.hysteresis``), which depend on the design and on the loads' wrench, not on the
noise drawn. The object is a guess (``guessed_load``): a
solid box of its mass and a density, its COM where the grasp holds it. Two equal
principal moments have no axes of their own, and each one's sigma then depends on the
axes chosen: the guess should have three distinct ones (the box's edges are 2:3:4).

Motions of ``cycles`` periods of the same excitation (the D-optimal design is periodic;
the sequencer's ``motion_cycles``) divide the noise's share of the variance by
``cycles``; the calibration's share stays: it is the same error at every pass. The
object's fit takes the empty hand's off, so over motions of equal length half the
noise's share is the hand's. The hand moves once per sensor and hand (its fit is kept
and taken off every later object's motion along the same excitation), so it may run
longer: ``hand_cycles`` periods (the sequencer's ``hand_motion_cycles``, ``HAND_CYCLES``
by default) leave of its share 1 / ``hand_cycles`` of the object's (the Panda, a 0.5 kg
box over one 3 s period: the mass's and the COM's sigmas 0.79 of the equal motions' with
4, 0.71 with the hand known exactly). ``cycles_for`` finds the fewest cycles over which
every principal moment stands ``1 / target`` of its sigma, or says that the
calibration's share alone forbids it (then a calibration in place or a faster motion,
not a longer one, is what helps).

A longer period is no substitute: the design is scaled to the URDF's position and velocity
limits and an acceleration bound, so a slower motion has smaller accelerations, and the
inertia is told by the accelerations. A faster one is: a shorter period (``PERIODS``)
with the bound raised up to the arm's own limits (the configuration's
``max_joint_acceleration``) makes the inertial wrench larger against the calibration's
error as well as the noise. ``candidate_motions`` lists such designs and ``fastest``
picks the one that meets the target in the least time; the sequencer runs it with
``motion_period``, ``motion_acceleration`` and ``motion_cycles``, or picks it itself for
``target_inertia``. The load's acceleration grows with it: the grasp must hold it.
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.motion import MotionFit, fit_motion, principal_moments
from com_core.planning.excitation import Excitation, acceleration_bounds
from com_core.robot.dynamics import inertial_parameters, sensor_regressors
from com_core.robot.model import RobotModel
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis
from com_core.sensing.noise import NoiseModel

__all__ = ["DENSITY_GUESS", "HAND_CYCLES", "MAX_CYCLES", "PERIODS", "MotionAccuracy",
           "box_inertia", "candidate_motions", "cycles_for", "fastest", "guessed_load",
           "predict_fit", "predict_motion"]  # fmt: skip

SENSOR_RATE = 1000.0
"""Hz: the wrenches the prediction reads."""
JOINT_RATE = 100.0
"""Hz: the joint states it reads (the shipped configurations' rate)."""
_REST = 0.5  # s of joint states at rest before and after the motion
MAX_CYCLES = 20
"""The most cycles ``cycles_for`` proposes (the sequencer's ``motion_cycles`` range)."""
HAND_CYCLES = 4
"""Periods the empty hand's motion runs by default, once per sensor and hand (module)."""
PERIODS = (1.5, 2.0, 3.0)
"""s: the periods weighed besides the one asked for (``candidate_motions``)."""
DENSITY_GUESS = 1000.0
"""kg/m^3: a guessed object's density (water's) when only its mass is known."""


@dataclass(frozen=True)
class MotionAccuracy:
    """The predicted 1-sigma of the object's fit over a motion of one period:
    ``sigma_mass`` (kg), ``sigma_com`` (3,; m), and the principal ``moments`` (3,; kg m^2,
    ascending, of the guess) with ``sigma_moments``. Of each moment's variance,
    ``fixed`` (3,; kg^2 m^4) does not shrink with more cycles (the calibration's share),
    the rest is the noise's, the object's and the empty hand's over its ``hand_cycles``
    periods."""

    sigma_mass: float
    sigma_com: NDArray[np.float64]
    moments: NDArray[np.float64]
    sigma_moments: NDArray[np.float64]
    fixed: NDArray[np.float64]
    hand_cycles: int = 1

    def sigma_moments_over(self, cycles: int) -> NDArray[np.float64]:
        """kg m^2: the moments' sigmas over ``cycles`` periods of the object's motion and
        ``max(cycles, hand_cycles)`` of the empty hand's (each motion's noise share as
        large as the other's over as many periods)."""
        noise = self.sigma_moments**2 - self.fixed
        hand = self.hand_cycles
        shrink = (1 / cycles + 1 / max(cycles, hand)) / (1 + 1 / hand)
        return np.sqrt(self.fixed + noise * shrink)


def box_inertia(mass: float, size: ArrayLike) -> NDArray[np.float64]:
    """(3, 3) kg m^2: a solid box of ``mass`` kg and edges ``size`` (3,; m) about its COM,
    edges along the axes."""
    a, b, c = np.asarray(size, dtype=np.float64) ** 2
    return mass / 12.0 * np.diag([b + c, a + c, a + b])


def guessed_load(
    mass: float, com: ArrayLike, density: float = DENSITY_GUESS
) -> NDArray[np.float64]:
    """(10,) the inertial parameters of a guessed object: a solid box of ``mass`` kg and
    ``density`` kg/m^3 with edges 2:3:4 (three distinct moments, see module), its COM at
    ``com`` (3,; m, sensor frame)."""
    unit = (mass / density / 24.0) ** (1 / 3)  # m: the box's edges are 2, 3 and 4 of it
    return inertial_parameters(mass, com, box_inertia(mass, unit * np.array([2, 3, 4])))


def candidate_motions(
    period: float,
    acceleration: float,
    joints: Sequence[str],
    arm_joints: Sequence[str],
    published: Sequence[float],
) -> list[tuple[float, tuple[float, ...]]]:
    """(period s, acceleration bound rad/s^2 per joint of ``joints``) of each motion
    weighed: the one asked for first, then each of ``PERIODS`` at the bound asked for and
    at the arm's own limits (``published``, one per joint of ``arm_joints``; none: the
    bound asked for only; ``planning.excitation.acceleration_bounds``)."""
    asked = acceleration_bounds(acceleration, joints, arm_joints, published)
    limits = acceleration_bounds(np.inf, joints, arm_joints, published)
    bounds = [asked] + ([limits] if np.all(np.isfinite(limits)) and limits != asked else [])
    others = [(other, bound) for other in PERIODS for bound in bounds]
    return [(period, asked)] + [motion for motion in others if motion != (period, asked)]


def predict_fit(
    robot: RobotModel,
    excitation: Excitation,
    hand: NDArray[np.float64],
    load: NDArray[np.float64],
    noise: NoiseModel,
    calibration: Calibration | None,
    hysteresis: Hysteresis | None = None,
    hand_cycles: int = 1,
) -> MotionFit:
    """The object's fit (see module) along ``excitation`` (its ``cycles``; the empty
    hand's along ``hand_cycles`` periods, or as many if more) with the ``hand``'s and the
    object's (``load``) inertial parameters (10,; sensor frame, ``robot.dynamics``), the
    sensor's ``noise`` model, ``calibration`` and stated ``hysteresis`` (what its gain
    leaves, as the estimator weighs it: ``fits.motion.motion_calibration``): its
    ``load_cov()`` is the prediction."""

    def fit(ex: Excitation, pi: NDArray[np.float64], under: MotionFit | None) -> MotionFit:
        joint_times = np.arange(-_REST, ex.duration + _REST, 1.0 / JOINT_RATE)
        positions = ex.at(np.clip(joint_times, 0.0, ex.duration))[0]
        times = np.arange(0.0, ex.duration, 1.0 / SENSOR_RATE)
        wrenches = sensor_regressors(robot, *ex.at(times)) @ pi
        return fit_motion(robot, joint_times, positions, times, wrenches, noise, under,
                          calibration, hysteresis=hysteresis)  # fmt: skip

    hand_motion = replace(excitation, cycles=max(excitation.cycles, hand_cycles))
    return fit(excitation, hand + load, fit(hand_motion, hand, None))


def predict_motion(
    robot: RobotModel,
    excitation: Excitation,
    hand: NDArray[np.float64],
    load: NDArray[np.float64],
    noise: NoiseModel,
    calibration: Calibration | None,
    hysteresis: Hysteresis | None = None,
    hand_cycles: int = 1,
) -> MotionAccuracy:
    """The object's predicted sigmas over ``excitation`` (``predict_fit``, the empty hand
    along ``hand_cycles`` periods), and the part of the moments' variance more cycles
    leave: the calibration's and the hysteresis's, what the same fit without them lacks
    (``MotionAccuracy.sigma_moments_over``)."""
    one = predict_fit(robot, excitation, hand, load, noise, calibration, hysteresis, hand_cycles)
    bare = predict_fit(robot, excitation, hand, load, noise, None, None, hand_cycles)
    _, _, inertia = one.load()
    moments, sigma = principal_moments(inertia, one.load_cov()[4:, 4:])
    _, sigma_bare = principal_moments(inertia, bare.load_cov()[4:, 4:])
    fixed = np.clip(sigma**2 - sigma_bare**2, 0.0, sigma**2)
    sigmas = np.sqrt(np.diag(one.load_cov())[:4])
    return MotionAccuracy(float(sigmas[0]), sigmas[1:4], moments, sigma, fixed, hand_cycles)


def cycles_for(accuracy: MotionAccuracy, target: float) -> int | None:
    """The fewest cycles (at most ``MAX_CYCLES``) over which every principal moment's
    sigma is within ``target`` of the moment; None when what more cycles leave (the
    calibration's share) exceeds it already, or ``MAX_CYCLES`` do not reach it."""
    for cycles in range(1, MAX_CYCLES + 1):
        if np.all(accuracy.sigma_moments_over(cycles) <= target * accuracy.moments):
            return cycles
    return None


def fastest(
    designs: Sequence[tuple[Excitation, MotionAccuracy]], target: float
) -> tuple[int, int] | None:
    """Of ``designs`` (each excitation with its prediction over one period), which one
    meets ``target`` (``cycles_for``) in the least time, and over how many cycles:
    (its index, cycles); None when none does."""
    best = None
    for index, (excitation, accuracy) in enumerate(designs):
        cycles = cycles_for(accuracy, target)
        if cycles and (best is None or cycles * excitation.period < best[2]):
            best = (index, cycles, cycles * excitation.period)
    return None if best is None else best[:2]


def main(argv: list[str] | None = None) -> int:
    from com_core.planning.excitation import DEFAULT_ACCELERATION, cached_excitation
    from com_core.planning.sensor_accuracy import default_pass, predicted_calibration
    from com_core.robot.choreography import Choreography
    from com_core.robot.config import read_robot_config, urdf_file
    from com_core.sensing.sensor_profiles import PROFILES

    parser = argparse.ArgumentParser(prog="motion_accuracy", description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--profile", default="realistic", choices=sorted(PROFILES))
    parser.add_argument("--masses", default="0.1,0.5,2.0")
    parser.add_argument("--density", type=float, default=DENSITY_GUESS, help="kg/m^3 of the box")
    parser.add_argument("--com", default="0,0,0.1", help="m, sensor frame")
    parser.add_argument("--period", type=float, default=3.0)
    parser.add_argument(
        "--acceleration",
        type=float,
        default=DEFAULT_ACCELERATION,
        help="rad/s^2, the bound on each wrist joint's acceleration",
    )
    parser.add_argument("--target", type=float, default=0.2)
    parser.add_argument("--reference", type=float, default=1.0, metavar="KG")
    parser.add_argument("--hand-cycles", type=int, default=HAND_CYCLES,
                        help="periods of the empty hand's motion")  # fmt: skip
    parser.add_argument("--cache", default="", help="the excitations' cache file (JSON)")
    args = parser.parse_args(argv)
    config = read_robot_config(args.robot)
    urdf = urdf_file(config).read_text()
    motion = Choreography.of(config, urdf)
    robot = motion.robot
    home = [motion.home_positions()[name] for name in robot.joint_names]
    cache = args.cache or str(Path(tempfile.gettempdir()) / "com_excitations.json")
    wrist = config.arm_joints[-3:]
    candidates = candidate_motions(args.period, args.acceleration, wrist, config.arm_joints,
                                   config.max_joint_acceleration)  # fmt: skip
    designs = [cached_excitation(cache, robot, home, wrist, period, bound)
               for period, bound in candidates]  # fmt: skip
    profile = PROFILES[args.profile]
    com = np.array([float(v) for v in args.com.split(",")])
    calibrations = {
        "stated": profile.calibration(),
        "calibrated": predicted_calibration(default_pass(profile, args.reference),
                                            args.reference),
    }  # fmt: skip
    limits = acceleration_bounds(np.inf, wrist, config.arm_joints, config.max_joint_acceleration)
    own = (f"its own limits {', '.join(f'{v:g}' for v in limits)} rad/s^2"
           if config.max_joint_acceleration else "no limits of its own stated")  # fmt: skip
    print(f"{args.robot} ({own}), the {args.profile} sensor, its {args.period:g} s "
          f"excitation within {args.acceleration:g} rad/s^2; the object a box of "
          f"{args.density:g} kg/m^3 (edges 2:3:4), its COM at "
          f"({', '.join(f'{1e3 * v:g}' for v in com)}) mm; "
          f"target: every principal moment within {args.target:.0%} (1 sigma); calibrated "
          f"in place with a {args.reference:g} kg reference; the empty hand along "
          f"{args.hand_cycles} cycle(s)")  # fmt: skip
    print(f"{'kg':>5} {'':>10}  {'mass %':>6} {'COM mm':>6}  {'moments %, 1 cycle':>18}  "
          f"{'never below %':>13}  {'cycles to the target':<24}  the fastest motion that "
          "meets it")  # fmt: skip
    for mass in (float(m) for m in args.masses.split(",")):
        load = guessed_load(mass, com, args.density)
        for name, calibration in calibrations.items():
            predicted = [predict_motion(robot, excitation, motion.hand, load,
                                        profile.noise_model(), calibration,
                                        profile.stated_hysteresis(), args.hand_cycles)
                         for excitation in designs]  # fmt: skip
            a = predicted[0]  # the motion asked for
            cycles = cycles_for(a, args.target)
            floor = np.max(np.sqrt(a.fixed) / a.moments)
            best = fastest(list(zip(designs, predicted, strict=True)), args.target)
            longer = (f"{cycles} ({cycles * args.period:g} s)" if cycles else "none"
                      if floor > args.target else f"more than {MAX_CYCLES}")  # fmt: skip
            if best:
                (period, bound), n, b = candidates[best[0]], best[1], predicted[best[0]]
                faster = (f"{n} x {period:g} s within {', '.join(f'{v:g}' for v in bound)} "
                          f"rad/s^2 (mass {100 * b.sigma_mass / mass:.3f} %, COM "
                          f"{1e3 * b.sigma_com.max():.3f} mm)")  # fmt: skip
            print(
                f"{mass:5.2f} {name:>10}  {100 * a.sigma_mass / mass:6.3f} "
                f"{1e3 * a.sigma_com.max():6.3f}  "
                f"{', '.join(f'{100 * v:.0f}' for v in a.sigma_moments / a.moments):>18}  "
                f"{100 * floor:13.0f}  {longer:<24}  {faster if best else 'none'}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
