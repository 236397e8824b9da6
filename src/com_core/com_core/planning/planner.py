"""The tilt plan of an exploration and what is known of it before the arm moves.

A ``Plan`` is the poses (home, then +-``tilt`` about each of ``axes``, sensor frame), the
dwell, settle and motion per pose, the sensor's noise, and the guesses of the object, the
hand and gravity at home. The covariance of its windows follows from the sensor noise,
the rate and the dwell: cov = S c with c = 1/N + 1/N_tare, the window variance factor
(``Plan._variance_factor``), N = dwell * rate samples (the window mean minus its pose's
tare mean) and S what one sample is worth in a long window's mean (``Plan.sample_cov``):
the noise's per-sample covariance times its long-run factor, so a sensor whose samples are
correlated is planned by its effective number of samples, N / f (``com_core.sensing.noise``).

What a plan will give: ``com_core.planning.prediction``; the plan a target asks for:
``com_core.planning.dwell``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.known_gravity import BIAS_DRIFT_RATE
from com_core.sensing.calibration import Calibration
from com_core.sensing.hysteresis import Hysteresis
from com_core.sensing.noise import COV_FLOOR, NoiseModel, white_noise
from com_core.sensing.wrench_model import SensorModel, as_vector, rotation_about

__all__ = ["HOME", "Plan"]

HOME = "home"


@dataclass(frozen=True)
class Plan:
    """A tilt plan and what is known before moving.

    Attributes
    ----------
    tilt : rad; wrist tilt from home, about each axis of ``axes`` (sensor frame).
    axes : tilt axes, e.g. ('x', 'y'); the paper tilts once about x.
    both_directions : tilt +tilt and -tilt about each axis (else +tilt only).
    dwell : s of samples averaged per pose.
    tare_dwell : s per pose of the tare windows; None = same as ``dwell``; inf = the
        hand's wrench is known exactly (no tare noise).
    settle : s waited after each motion before the window starts.
    move_time : s per motion between poses.
    sensor : noise and rate of the F/T sensor (per sample).
    noise : the sensor's noise as learnt (a tare pass's, ``com_core.sensing.noise``) or assumed;
        None: white at ``sensor``'s sigma.
    calibration : the sensor's stated accuracy (``com_core.sensing.calibration``): the kinematic
        fit's prediction holds its systematic share, a floor no dwell lowers.
    hysteresis : the sensor's stated hysteresis (``com_core.sensing.hysteresis``): the
        kinematic fit's prediction holds what its gain leaves; None: none.
    mass_guess : kg. com_guess : shape (3,); m; sensor frame.
    gravity_home : shape (3,); gravity direction at home in the sensor frame (measure it
        from the tare's force; the paper's top grasp is (0, 0, -1)).
    bias_dwell : s of the empty-hand window of the object run that fits the sensor's
        bias (kinematic information; 0: the bias is fitted from the object windows).
    bias_drift_rate : N/s, N m/s; the estimator's prior on the bias's drift rate within
        a run (``known_gravity``).
    hand_mass_guess : kg. hand_com_guess : shape (3,); m; sensor frame (the hand's load
        is what resolves the mounting of ``kinematics+mount``).
    """

    tilt: float = math.pi / 6
    axes: tuple[str, ...] = ("x", "y")
    both_directions: bool = True
    dwell: float = 1.0
    tare_dwell: float | None = None
    settle: float = 0.3
    move_time: float = 1.0
    sensor: SensorModel = field(default_factory=lambda: SensorModel.from_scalars(0.1, 0.005))
    mass_guess: float = 0.1
    com_guess: tuple[float, float, float] = (0.0, 0.0, 0.05)
    gravity_home: tuple[float, float, float] = (0.0, 0.0, -1.0)
    bias_dwell: float = 3.0
    bias_drift_rate: tuple[float, float] = BIAS_DRIFT_RATE
    hand_mass_guess: float = 1.0
    hand_com_guess: tuple[float, float, float] = (0.0, 0.0, 0.04)
    noise: NoiseModel | None = None
    calibration: Calibration | None = None
    hysteresis: Hysteresis | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.tilt < math.pi / 2:
            raise ValueError(f"tilt must be in (0, pi/2) rad, got {self.tilt}")
        if not self.axes or any(a not in ("x", "y", "z") for a in self.axes):
            raise ValueError(f"axes must be a non-empty subset of x, y, z, got {self.axes}")
        if not self.dwell > 0 or not self.mass_guess > 0:
            raise ValueError("dwell and mass_guess must be > 0")
        if self.tare_dwell is not None and not self.tare_dwell > 0:
            raise ValueError(f"tare_dwell must be > 0 or None, got {self.tare_dwell}")
        if not self.bias_dwell >= 0:
            raise ValueError(f"bias_dwell must be >= 0, got {self.bias_dwell}")

    def tare_plan(self) -> Plan:
        """The plan of the tare pass: both directions about x, y and the plan's axes. A
        hand model needs tilts about two axes, and a pass cut to fewer poses
        (``fewer_poses``) then finds its poses tared."""
        axes = tuple(dict.fromkeys((*self.axes, "x", "y")))
        return replace(self, axes=axes, both_directions=True)

    def poses(self) -> list[tuple[str, NDArray[np.float64]]]:
        """(name, R_home_pose) per pose, home first: 'home', 'tilt_x+', 'tilt_x-', ..."""
        out = [(HOME, np.eye(3))]
        signs = (1, -1) if self.both_directions else (1,)
        for axis in self.axes:
            for sign in signs:
                name = f"tilt_{axis}{'+' if sign > 0 else '-'}"
                out.append((name, rotation_about(axis, sign * self.tilt)))
        return out

    def gravity_directions(self) -> NDArray[np.float64]:
        """Unit gravity direction per pose in the sensor frame, shape (n, 3)."""
        g_home = as_vector(self.gravity_home, 3, "gravity_home")
        g_home = g_home / np.linalg.norm(g_home)
        return np.array([R.T @ g_home for _, R in self.poses()])

    def samples_per_window(self) -> int:
        return max(1, round(self.dwell * self.sensor.rate_hz))

    def noise_model(self) -> NoiseModel:
        """The sensor's noise planned for: ``noise``, else white at ``sensor``'s."""
        if self.noise is not None:
            return self.noise
        return white_noise(self.sensor.sample_covariance(), self.sensor.rate_hz)

    def sample_cov(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of what one sample is worth in a long window's mean: the
        noise's per-sample covariance scaled per axis pair by sqrt(f_a f_b), f its
        long-run factor (n correlated samples are worth n / f independent ones), plus
        ``COV_FLOOR``^2 so that a noise-free sensor plans (its shortest dwell serves)."""
        noise = self.noise_model()
        root = np.sqrt(noise.long_run_factor)
        return noise.cov * np.outer(root, root) + np.diag(COV_FLOOR**2)

    def window_cov(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of each tare-subtracted window mean; N, N m."""
        return self.sample_cov() * self._variance_factor(self.dwell)

    def _variance_factor(self, dwell: float) -> float:
        """1/N + 1/N_tare for a window of ``dwell`` s."""
        rate = self.sensor.rate_hz
        tare = dwell if self.tare_dwell is None else self.tare_dwell
        return 1.0 / max(1.0, round(dwell * rate)) + (
            0.0 if math.isinf(tare) else 1.0 / max(1.0, round(tare * rate))
        )

    def duration(self) -> float:
        """s of one object pass: every pose's motion, settle and dwell."""
        return len(self.poses()) * (self.move_time + self.settle + self.dwell)
