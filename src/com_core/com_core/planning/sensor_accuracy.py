"""What a named sensor can do before anything moves: the accuracy the sequencer's default
static pass reaches with it, its calibration as stated, calibrated in place, or perfect
(the floor no calibration goes below), and the lightest object it weighs to 5 %.

    python -m com_core.planning.sensor_accuracy [--profiles realistic,ur_e_series,...]
        [--masses 0.1,0.5,2.0] [--reference 1.0] [--fixture]

For each profile (``sensing.sensor_profiles``: its noise, through its low-pass, and its
stated calibration accuracy) and object mass, the planner's prediction of the kinematic
fit (``prediction.predict``, information ``kinematics+mount``: the bound of the windows'
noise plus the calibration's share, which no dwell lowers) of the default pass
(``default_pass``: a cached 5 s tare pass, 0.9 s at home and four 30 deg tilts, the COM
100 mm out along the hand's axis, where a parallel gripper holds it). Calibrated in
place: the calibration a reference of ``--reference`` kg through the same poses leaves
(``predicted_calibration``), found from the poses alone (what is left of the error
depends on the design, not on the readings). ``--fixture``: the reference's COM known to
``FIXTURE_COM_SIGMA`` (a weight on a fixture of known geometry: the estimator's
``reference_com`` and ``reference_com_sigma``), which identifies the part of the torque
error a COM offset explains and a gripped reference leaves. The floor: the same pass with
no calibration error at all, its noise's and its hysteresis's share alone; where the
stated prediction is not twice the floor, no calibration halves the sigma, and only a
longer pass narrows it (``planner``).

The prediction holds what a profile's stated hysteresis leaves once its gain is taken
off (``sensing.hysteresis``), as the fits weigh it. It is linear: a profile's
non-linearity is not in it, nor
the arm model's error of a wrench estimated from the joint torques (the table says which
profiles have them), nor is a motion's (``bench/motion.py`` measures those).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, replace

import numpy as np

from com_core.estimation.fits.in_place import calibrate_in_place
from com_core.estimation.fits.known_gravity import Reference
from com_core.estimation.runs.settings import REFERENCE_MASS_SHARE
from com_core.planning.planner import Plan
from com_core.planning.prediction import carried_hysteresis, plan_observations, predict
from com_core.sensing.calibration import Calibration
from com_core.sensing.sensor_profiles import PROFILES, SensorProfile
from com_core.sensing.wrench_model import SensorModel

__all__ = ["FIXTURE_COM_SIGMA", "SensorAccuracy", "default_pass", "lightest_mass",
           "predicted_calibration", "sensor_accuracy"]  # fmt: skip

INFORMATION = "kinematics+mount"
"""The estimator's default information model, the one predicted."""
TARGET = 0.05
"""The share of the mass ``lightest_mass`` weighs to, at 95 % (2 sigma)."""
FIXTURE_COM_SIGMA = 5e-5
"""m: the 1-sigma per axis of a reference's COM on a fixture, from its drawing."""


def default_pass(profile: SensorProfile, mass: float) -> Plan:
    """The sequencer's default static pass (module) of an object of ``mass`` kg read
    through ``profile``, with its stated calibration and its bias's drift rate."""
    sensor = SensorModel.from_scalars(max(profile.sigma_f, 1e-6), max(profile.sigma_tau, 1e-7))
    plan = Plan(axes=("y", "x"), dwell=0.9, tare_dwell=5.0, sensor=sensor, mass_guess=mass,
                com_guess=(0.0, 0.0, 0.1), noise=profile.noise_model(),
                calibration=profile.calibration(),
                hysteresis=profile.stated_hysteresis())  # fmt: skip
    drift = profile.bias_drift_rate
    return plan if drift is None else replace(plan, bias_drift_rate=drift)


def predicted_calibration(
    plan: Plan, reference_mass: float, com_sigma: float = 0.0
) -> Calibration | None:
    """What a calibration in place with a reference of ``reference_mass`` kg held through
    ``plan``'s poses leaves of the stated calibration's error (no estimate: the covariance
    only), its COM at the plan's guess known to ``com_sigma`` m (0: unknown); None when
    the plan states no calibration."""
    stated = plan.calibration
    if stated is None:
        return None
    session, nuisance_cov = carried_hysteresis(
        plan, plan_observations(replace(plan, mass_guess=reference_mass))
    )
    reference = Reference(reference_mass, REFERENCE_MASS_SHARE * reference_mass)
    if com_sigma > 0:
        reference = replace(reference, com=plan.com_guess, com_sigma=com_sigma)
    result, _ = calibrate_in_place(session, reference, stated, nuisance_cov=nuisance_cov)
    return replace(stated, residual_cov=result.calibration.residual_cov)


@dataclass(frozen=True)
class SensorAccuracy:
    """The predicted 1-sigma of a static pass: ``sigma_mass`` (kg) and ``sigma_com`` (3,;
    m), as stated, calibrated in place (``calibrated_*``) and with a perfect calibration
    (``floor_*``: the noise's and the hysteresis's share alone)."""

    mass: float
    sigma_mass: float
    sigma_com: np.ndarray
    calibrated_sigma_mass: float
    calibrated_sigma_com: np.ndarray
    floor_sigma_mass: float
    floor_sigma_com: np.ndarray


def sensor_accuracy(
    profile: SensorProfile, mass: float, reference_mass: float = 1.0, com_sigma: float = 0.0
) -> SensorAccuracy:
    """The default pass's predicted accuracy for an object of ``mass`` kg with
    ``profile``, stated, calibrated in place with a ``reference_mass`` kg reference, its
    COM known to ``com_sigma`` m (0: unknown), and calibrated perfectly."""
    plan = default_pass(profile, mass)
    stated = predict(plan, "ml", INFORMATION)
    calibration = predicted_calibration(plan, reference_mass, com_sigma)
    calibrated = predict(replace(plan, calibration=calibration), "ml", INFORMATION)
    floor = predict(replace(plan, calibration=None), "ml", INFORMATION)
    return SensorAccuracy(mass, stated.sigma_mass, stated.sigma_com, calibrated.sigma_mass,
                          calibrated.sigma_com, floor.sigma_mass, floor.sigma_com)  # fmt: skip


def lightest_mass(
    profile: SensorProfile, calibration: Calibration | None, target: float = TARGET
) -> float:
    """kg: the lightest object the default pass weighs to ``target`` of its mass at 95 %
    (2 sigma) with ``calibration`` in place of the profile's stated one (bisection on a log
    scale over 1 g to 100 kg; inf when even 100 kg is not weighed so); ``calibration``
    None is a perfect one."""

    def share(mass: float) -> float:
        plan = replace(default_pass(profile, mass), calibration=calibration)
        return 2.0 * predict(plan, "ml", INFORMATION).sigma_mass / mass

    low, high = math.log(1e-3), math.log(100.0)
    if share(math.exp(high)) > target:
        return math.inf
    if share(math.exp(low)) <= target:
        return math.exp(low)
    for _ in range(30):
        middle = (low + high) / 2
        low, high = (middle, high) if share(math.exp(middle)) > target else (low, middle)
    return math.exp(high)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="sensor_accuracy", description=__doc__.split("\n\n")[0])
    parser.add_argument("--profiles", default=",".join(p for p in PROFILES if p != "ideal"))
    parser.add_argument("--masses", default="0.1,0.5,2.0")
    parser.add_argument("--reference", type=float, default=1.0, metavar="KG")
    parser.add_argument(
        "--fixture",
        action="store_true",
        help="the reference's COM known to 0.05 mm (on a fixture)",
    )
    args = parser.parse_args(argv)
    masses = [float(m) for m in args.masses.split(",")]
    com_sigma = FIXTURE_COM_SIGMA if args.fixture else 0.0
    fixture = f", its COM known to {1e3 * com_sigma:g} mm" if args.fixture else ""
    print(
        f"the default static pass, predicted (1 sigma); calibrated in place with a "
        f"{args.reference:g} kg reference{fixture}; the floor: a perfect calibration"
    )
    print(
        f"{'profile':>13} {'kg':>5}  {'mass %':>7} {'COM mm (worst axis)':>20}  "
        f"{'calibrated: mass %':>18} {'COM mm':>7}  {'floor: mass %':>13} {'COM mm':>7}"
    )
    for name in args.profiles.split(","):
        profile = PROFILES[name]
        for mass in masses:
            a = sensor_accuracy(profile, mass, args.reference, com_sigma)
            print(f"{name:>13} {mass:5.2f}  {100 * a.sigma_mass / mass:7.3f} "
                  f"{1e3 * a.sigma_com.max():20.3f}  "
                  f"{100 * a.calibrated_sigma_mass / mass:18.3f} "
                  f"{1e3 * a.calibrated_sigma_com.max():7.3f}  "
                  f"{100 * a.floor_sigma_mass / mass:13.3f} "
                  f"{1e3 * a.floor_sigma_com.max():7.3f}")  # fmt: skip
        plan = default_pass(profile, args.reference)
        lightest = lightest_mass(profile, profile.calibration())
        calibrated = lightest_mass(profile, predicted_calibration(plan, args.reference, com_sigma))
        floor = lightest_mass(profile, None)
        left_out = " (its non-linearity is not in these)" if profile.nonlinearity else ""
        if profile.joint_torque_estimate:
            left_out = (" (its arm model's error is not in these: the default fit refuses it "
                        "at rest, bench/README.md, Named sensors)")  # fmt: skip
        print(f"{name:>13}: the lightest object weighed to {TARGET:.0%} (2 sigma): "
              f"{1e3 * lightest:.0f} g, calibrated {1e3 * calibrated:.0f} g, "
              f"the floor {1e3 * floor:.0f} g"
              f"{left_out}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
