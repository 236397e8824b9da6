"""Named sets of a simulated wrist F/T sensor's parts, one home for their figures.

- ``ideal``: none of it, the physics floor (the simulator's static error).
- ``white``: independent Gaussian noise of 0.1 N and 0.005 N m per sample, nothing else.
- ``realistic`` (the default of the simulator and of ``make demo``): a strain-gauge wrist
  sensor of the ATI Mini45 class (SI-290-10 calibration: range 290 N, 10 N m) read through
  an interface that samples at 7 kHz, low-pass filters and publishes at 1 kHz:
  - noise 0.1 N and 0.005 N m per published sample through a first-order digital low-pass
    of 5 ms correlation time (~32 Hz; exactly AR(1) at the publish rate,
    ``wrench_model.SensorModel``);
  - quantisation 1/16 N and 1/2000 N m (counts below the noise);
  - calibration accuracy 1 % of full scale (95 %), a gain and cross-talk matrix drawn
    from the seed (``wrench_model.calibration_matrix``; the order ATI states for its
    calibrations);
  - a bias that warms up: each axis toward a final offset drawn N(0, 0.3 N / 0.015 N m),
    time constant 600 s from power-on (sim time 0), plus a random walk of 2e-4 N/sqrt(s)
    and 1e-5 N m/sqrt(s): 0.03 N/min and 1.5 mN m/min at power-on, what its datasheet
    tells the estimator (``bias_drift_rate``);
  - the arm's structure: two lightly damped modes, 12 Hz (damping ratio 0.03) and 27 Hz
    (0.02), of the order of collaborative arms' first structural modes, excited at the end
    of every move by 1 m/s^2 of the load's acceleration per m/s of the move's peak speed,
    decaying at zeta w (``wrench_sim.vibration``).
- ``ur_e_series`` (the UR5e configuration's ``sensor_profile``): the force/torque sensor
  built into a Universal Robots e-Series arm's wrist, read through the driver at 500 Hz.
  Universal Robots' UR5e technical specifications state for it: force range 50 N,
  precision 3.5 N, accuracy 4.0 N; torque range 10 N m, precision 0.2 N m, accuracy
  0.3 N m. From these:
  - noise 1.75 N and 0.1 N m per published sample: the precision taken as the 95 % band
    (2 sigma) of single readings; an upper bound of the noise, as a precision holds more
    than the noise (what repeats from pose to pose);
  - calibration accuracy 3 % of full scale (95 %): the accuracy that the precision does
    not explain, root-sum-square, sqrt(4.0^2 - 3.5^2) = 1.9 N of 50 N (3.9 %) and
    sqrt(0.3^2 - 0.2^2) = 0.22 N m of 10 N m (2.2 %), one figure between the two;
  - range 50 N and 10 N m;
  - the rest UR does not state: the 5 ms low-pass, the warming bias, its random walk and
    the arm's modes are the realistic profile's; no quantisation.

- ``xarm_ft``: UFACTORY's 6-axis F/T sensor for the xArm, from the specifications of its
  user manual (6-Axis Force Torque Sensor, Specifications): load capacity 150 N (Fx, Fy),
  200 N (Fz), 4 N m; resolution 100 mN (Fx, Fy), 150 mN (Fz), 5 mN m; hysteresis 2.5 % FS
  (Fx, Fy), 1 % FS (Fz, torques); cross-talk 3 % FS. From these:
  - range 150 N and 4 N m (one force range: the lateral axes'), quantisation 0.1 N and
    5 mN m;
  - hysteresis 3.75, 3.75 and 2 N, 40 mN m (the stated fractions of each axis's range,
    ``wrench_sim.gauges``);
  - calibration accuracy 3 % of full scale (95 %): the cross-talk, taken as the
    calibration's error;
  - the rest UFACTORY does not state (noise, low-pass, drift, non-linearity, the arm's
    modes) is the realistic profile's: noise 0.1 N and 5 mN m, at the resolution.

- ``bota_sensone``: a Bota Systems SensONE-class sensor (a six-axis strain-gauge sensor
  with its electronics inside, read over USB/RS422 or EtherCAT), from what Bota
  publishes of the SensONE T5 (its news release "Bota Systems' new force torque sensor
  triples sensitivity of small payload cobots", quoted in public robotics notes):
  sensitivity 0.05 N and 0.002 N m, accuracy "exceeding 2.0 %", up to 2000 Hz, for
  cobots of up to 5 kg payload; no range is stated there. The range is that of Bota's
  Rokubi serial sensor as its datasheet is quoted (BFT-ROKS-SER-M8: 500 N Fx, Fy,
  1200 N Fz, 15 N m Mx, My, 12 N m Mz; accuracy < 2.0 %; 800 Hz), the same maker's
  sensor of the same accuracy. From these:
  - noise 0.05 N and 0.002 N m per published sample: the sensitivity taken as one sigma
    (the smallest change it tells from its noise; not the kinder 95 % band);
  - calibration accuracy 2 % of full scale (95 %), range 500 N and 15 N m (one force
    range: the lateral axes');
  - the rest Bota does not state (the 5 ms low-pass, the warming bias, its random walk,
    hysteresis, non-linearity and the arm's modes) is the realistic profile's: no
    hysteresis, no quantisation; published at the sim's 1 kHz.

- ``fr3_estimated``: no wrist sensor: the external wrench a Franka Research 3 (or Panda)
  estimates from its seven link-side joint torque sensors and its dynamic model
  (libfranka's ``K_F_ext_hat_K`` at 1 kHz; ``wrench_sim.joint_torques``). Franka's
  documentation says the estimate can be inaccurate depending on the configuration,
  most during high accelerations (frankaemika/docs, libfranka.rst, "Robot state"), and
  states no accuracy for the FR3; a user of franka_ros (issue 404) reports, with nothing
  held and nothing touching, a constant offset in each pose that changes with the
  configuration, (1.40, -0.37, 1.72) N and (0.00, 0.45, -0.15) N m in one, and its
  maintainers say the model is averaged over many robots, not identified per robot.
  From these:
  - the arm model's error: each inertial parameter of every arm link off by 7 % of its
    magnitude (1 sigma) and each joint torque sensor's offset 0.2 N m, drawn per arm
    (the serial): at the default static pass's poses of the FR3 the error's median is
    1.9 N and 0.44 N m (50 arms; 95th percentile 4.3 N and 0.83 N m), as reported;
  - noise 0.075 N and 0.025 N m per sample: the Panda's datasheet's force and torque
    repeatability (0.15 N, 0.05 N m, as quoted from it; the FR3's states none) taken as
    the 95 % band, as for the UR sensor's precision;
  - no calibration matrix, range nor quantisation of a strain-gauge sensor; the 5 ms
    low-pass, the warming bias, its random walk and the arm's modes are the realistic
    profile's.

Except where a datasheet is named, these are assumptions of a sensor's class: each part is
a parameter of the simulator that a user sets to their sensor's figures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np
import yaml

from com_core.inputs import refusal
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis
from com_core.sensing.noise import NoiseModel, ar1_noise

__all__ = ["DEFAULT_PROFILE", "PROFILES", "SensorProfile", "file_profile"]


@dataclass(frozen=True)
class SensorProfile:
    """Every part of a simulated sensor (units: N, N m, s, Hz).

    The strain gauges' own errors (``wrench_sim.gauges``), before the calibration:
    ``hysteresis`` (6,; N, N m) the band between loading and unloading over a full-scale
    excursion, per axis (fx fy fz tx ty tz; a datasheet's "hysteresis, % FS" times the
    axis's range); ``nonlinearity`` (6,; N, N m) the largest deviation from the straight
    line through zero and full scale; ``sensitivity_drift`` (1/K) how far each axis's gain
    moves per kelvin, and ``warmup_kelvin`` (K) how far the sensor warms from power-on,
    with the bias's ``warmup_time``. Empty or 0: none.

    A wrench estimated from the joint torques instead (no wrist sensor;
    ``wrench_sim.joint_torques``): ``link_model_error`` the spread of the arm model's
    error in each link's inertial parameters, a fraction of each; ``joint_torque_offset``
    (N m) the spread of each joint torque sensor's offset. 0: a wrist sensor.
    """

    sigma_f: float = 0.0
    sigma_tau: float = 0.0
    correlation_time: float = 0.0
    resolution_f: float = 0.0
    resolution_tau: float = 0.0
    limit_f: float = 0.0
    limit_tau: float = 0.0
    calibration_accuracy: float = 0.0
    warmup_f: float = 0.0
    warmup_tau: float = 0.0
    warmup_time: float = 600.0
    random_walk_f: float = 0.0
    random_walk_tau: float = 0.0
    vibration_hz: tuple[float, ...] = ()
    vibration_damping: tuple[float, ...] = ()
    vibration_gain: float = 1.0
    hysteresis: tuple[float, ...] = ()
    nonlinearity: tuple[float, ...] = ()
    sensitivity_drift: float = 0.0
    warmup_kelvin: float = 0.0
    link_model_error: float = 0.0
    joint_torque_offset: float = 0.0

    def with_overrides(self, **values: object) -> SensorProfile:
        """This profile with the parts in ``values`` changed (names of its fields)."""
        known = {f.name for f in fields(self)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"no sensor part named {', '.join(unknown)}")
        return replace(self, **values)  # type: ignore[arg-type]

    def problems(self) -> list[str]:
        """Why these parts make no sensor ([] when they do), each naming a part, its value
        and the fix (``com_core.inputs.refusal``): a vibration mode without its damping,
        a hysteresis or non-linearity that is not six values >= 0, and a quantised axis
        without the noise that dithers it (a reading that only steps, which the
        estimator's motion test reads as motion)."""
        out = []
        if len(self.vibration_hz) != len(self.vibration_damping):
            out.append(
                refusal(
                    "vibration_damping",
                    list(self.vibration_damping),
                    f"one damping ratio per mode of vibration_hz {list(self.vibration_hz)}",
                )
            )
        for name in ("hysteresis", "nonlinearity"):
            values = getattr(self, name)
            if len(values) not in (0, 6) or any(not v >= 0 for v in values):
                out.append(
                    refusal(
                        name,
                        list(values),
                        "six values >= 0 (N for fx fy fz, N m for tx ty tz), or none",
                    )
                )
        for axis, unit in (("f", "N"), ("tau", "N m")):
            sigma, step = getattr(self, f"sigma_{axis}"), getattr(self, f"resolution_{axis}")
            if step > 0 and sigma < step / 2:
                out.append(
                    refusal(
                        f"sigma_{axis}",
                        sigma,
                        f"below half the resolution_{axis} {step:g} {unit}: a quantised "
                        "reading without noise to dither it only steps, and a step reads "
                        "as motion",
                        f"set sigma_{axis} >= {step / 2:g} {unit}, or resolution_{axis} 0 "
                        "too (or the profile 'ideal' for a sensor without noise)",
                    )
                )
        return out

    @property
    def joint_torque_estimate(self) -> bool:
        """The wrench is estimated from the arm's joint torques (an arm model's error,
        ``link_model_error`` or ``joint_torque_offset``), not read by a wrist sensor."""
        return bool(self.link_model_error or self.joint_torque_offset)

    def noise_model(self, rate_hz: float = 1000.0) -> NoiseModel:
        """The noise of this sensor's samples at ``rate_hz``, as an estimator that knew it
        would assume (``sensing.noise.ar1_noise``): AR(1) through the low-pass, and the
        quantisation's white error after it (a step / sqrt(12)), which a model of the
        low-pass alone leaves in every fit's chi^2 (the realistic sensor's force axes: 17 %
        of the whitened residual's variance)."""
        sigma = [self.sigma_f] * 3 + [self.sigma_tau] * 3
        steps = np.array([self.resolution_f] * 3 + [self.resolution_tau] * 3)
        return ar1_noise(sigma, self.correlation_time, rate_hz, steps / math.sqrt(12.0))

    def calibration(self) -> Calibration | None:
        """The calibration error's term as an estimator takes it (None: a perfect one)."""
        if self.calibration_accuracy <= 0:
            return None
        return Calibration(self.calibration_accuracy, self.limit_f, self.limit_tau)

    def stated_hysteresis(self) -> Hysteresis | None:
        """The hysteresis a user of this sensor states (its datasheet's band over its
        ranges; ``sensing.hysteresis``), None without a band or a stated accuracy (as
        ``datasheet``)."""
        if self.calibration_accuracy <= 0:
            return None
        return Hysteresis.stated(self.hysteresis, self.limit_f, self.limit_tau)

    @property
    def bias_drift_rate(self) -> tuple[float, float] | None:
        """N/s, N m/s: the 1-sigma rate of the bias's drift at its fastest, at power-on:
        the warm-up's spread over its time constant (its random walk adds
        ``random_walk / sqrt(T)`` over T s, a nineteenth of it over a minute with the
        realistic profile's figures); None for a bias that does not warm up."""
        if self.warmup_time <= 0 or not (self.warmup_f or self.warmup_tau):
            return None
        return (self.warmup_f / self.warmup_time, self.warmup_tau / self.warmup_time)

    def datasheet(self) -> dict[str, object]:
        """What a user tells the estimator of this sensor (its settings;
        ``com_core.estimation.runs.settings``): ``bias_drift_rate`` for a bias that warms
        up, and from a stated calibration accuracy ``accuracy``, ``full_scale`` and
        ``hysteresis``; {} for ``ideal`` and ``white``."""
        out: dict[str, object] = {}
        if self.bias_drift_rate is not None:
            out["bias_drift_rate"] = list(self.bias_drift_rate)
        if self.calibration_accuracy > 0:
            out |= {
                "accuracy": self.calibration_accuracy,
                "full_scale": [self.limit_f, self.limit_tau],
                "hysteresis": list(self.hysteresis or [0.0] * 6),
            }
        return out

    @property
    def modes(self) -> tuple[tuple[float, float], ...]:
        """(frequency Hz, damping ratio) per vibration mode."""
        if len(self.vibration_hz) != len(self.vibration_damping):
            raise ValueError(
                f"vibration_hz {list(self.vibration_hz)} and vibration_damping "
                f"{list(self.vibration_damping)} must have the same length (one damping per mode)"
            )
        return tuple(zip(self.vibration_hz, self.vibration_damping, strict=True))


PROFILES = {
    "ideal": SensorProfile(),
    "white": SensorProfile(sigma_f=0.1, sigma_tau=0.005),
    "realistic": SensorProfile(
        sigma_f=0.1,
        sigma_tau=0.005,
        correlation_time=0.005,
        resolution_f=1 / 16,
        resolution_tau=1 / 2000,
        limit_f=290.0,
        limit_tau=10.0,
        calibration_accuracy=0.01,
        warmup_f=0.3,
        warmup_tau=0.015,
        random_walk_f=2e-4,
        random_walk_tau=1e-5,
        vibration_hz=(12.0, 27.0),
        vibration_damping=(0.03, 0.02),
    ),
}
PROFILES["ur_e_series"] = replace(  # UR's figures (module); the rest the realistic sensor's
    PROFILES["realistic"],
    sigma_f=1.75,
    sigma_tau=0.1,
    resolution_f=0.0,
    resolution_tau=0.0,
    limit_f=50.0,
    calibration_accuracy=0.03,
)
PROFILES["xarm_ft"] = replace(  # UFACTORY's figures (module); the rest the realistic sensor's
    PROFILES["realistic"],
    resolution_f=0.1,
    resolution_tau=0.005,
    limit_f=150.0,
    limit_tau=4.0,
    calibration_accuracy=0.03,
    hysteresis=(0.025 * 150.0, 0.025 * 150.0, 0.01 * 200.0, 0.04, 0.04, 0.04),
)
PROFILES["bota_sensone"] = replace(  # Bota's figures (module); the rest the realistic sensor's
    PROFILES["realistic"],
    sigma_f=0.05,
    sigma_tau=0.002,
    resolution_f=0.0,
    resolution_tau=0.0,
    limit_f=500.0,
    limit_tau=15.0,
    calibration_accuracy=0.02,
)
PROFILES["fr3_estimated"] = replace(  # the module's figures; the rest the realistic sensor's
    PROFILES["realistic"],
    sigma_f=0.075,
    sigma_tau=0.025,
    resolution_f=0.0,
    resolution_tau=0.0,
    limit_f=0.0,
    limit_tau=0.0,
    calibration_accuracy=0.0,
    link_model_error=0.07,
    joint_torque_offset=0.2,
)
DEFAULT_PROFILE = "realistic"


def file_profile(path: Path | str) -> str | None:
    """The ``sensor_profile`` a ROS 2 parameters file names in its ``/**`` section (a robot
    configuration whose arm has its own sensor: the UR5e's), else None; None too for a file
    that cannot be read (its reader names what is wrong)."""
    try:
        document = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
        return document["/**"]["ros__parameters"].get("sensor_profile")
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError, AttributeError):
        return None
