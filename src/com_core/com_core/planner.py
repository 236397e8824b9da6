"""Exploration planner: predict the accuracy of a tilt plan before moving, and invert it.

The prediction is the Cramer-Rao bound of the ``ml`` estimator (``estimators.crlb``)
evaluated at a guess of the object, for windows whose covariance follows from the
sensor noise, the rate and the dwell: cov = S (1/N + 1/N_tare) with S the per-sample
covariance and N = dwell * rate samples. The ML estimator reaches the bound, so the
prediction is the spread a user will see.

Information about the COM component along gravity grows with sin^2(tilt): at 0.05 rad
a plan needs ~100x the dwell of pi/6 for the same sigma. ``dwell_for_target`` says so
before the robot moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from .estimators import crlb
from .wrench_model import SensorModel, as_vector, rotation_about

__all__ = ["HOME", "Advice", "Plan", "Prediction", "dwell_for_target", "predict"]

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
    mass_guess : kg. com_guess : shape (3,); m; sensor frame.
    gravity_home : shape (3,); gravity direction at home in the sensor frame (measure it
        from the tare's force; the paper's top grasp is (0, 0, -1)).
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

    def __post_init__(self) -> None:
        if not 0.0 < self.tilt < math.pi / 2:
            raise ValueError(f"tilt must be in (0, pi/2) rad, got {self.tilt}")
        if not self.axes or any(a not in ("x", "y", "z") for a in self.axes):
            raise ValueError(f"axes must be a non-empty subset of x, y, z, got {self.axes}")
        if not self.dwell > 0 or not self.mass_guess > 0:
            raise ValueError("dwell and mass_guess must be > 0")
        if self.tare_dwell is not None and not self.tare_dwell > 0:
            raise ValueError(f"tare_dwell must be > 0 or None, got {self.tare_dwell}")

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

    def window_cov(self) -> NDArray[np.float64]:
        """Covariance (6, 6) of each tare-subtracted window mean; N, N m."""
        return self.sensor.sample_covariance() * self._variance_factor(self.dwell)

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


@dataclass(frozen=True)
class Prediction:
    """Predicted 1-sigma of the ML estimate for a plan."""

    sigma_mass: float  # kg
    sigma_com: NDArray[np.float64]  # (3,) m, sensor frame
    cov: NDArray[np.float64]  # (4, 4)

    def __str__(self) -> str:
        s = self.sigma_com * 1e3
        return (
            f"sigma mass {self.sigma_mass * 1e3:.3g} g, COM ({s[0]:.3g}, {s[1]:.3g}, "
            f"{s[2]:.3g}) mm"
        )


def predict(plan: Plan) -> Prediction:
    """Predicted sigma of mass and each COM axis for ``plan`` (the CRLB; see module)."""
    n = len(plan.poses())
    cov = crlb(
        plan.mass_guess,
        plan.com_guess,
        plan.gravity_directions(),
        np.repeat(plan.window_cov()[None], n, axis=0),
    )
    return Prediction(math.sqrt(cov[0, 0]), np.sqrt(np.diag(cov)[1:]), cov)


@dataclass(frozen=True)
class Advice:
    """Answer to "what dwell meets this COM sigma?".

    ``feasible`` False comes with ``reason``; ``plan`` is then the best plan within the
    limits and ``prediction`` what it reaches.
    """

    feasible: bool
    plan: Plan
    prediction: Prediction
    reason: str = ""


def dwell_for_target(
    plan: Plan,
    target_com_sigma: float,
    max_tilt: float | None = None,
    max_time: float = math.inf,
) -> Advice:
    """Shortest dwell whose predicted worst COM-axis sigma is <= ``target_com_sigma`` (m).

    The tilt is raised to ``max_tilt`` (more tilt only helps); the CRLB scales with the
    window variance factor c = 1/N + 1/N_tare, so the needed N is solved in closed form.
    Infeasible when the tare's own noise already exceeds the target, or when the pass
    would take longer than ``max_time`` s; the answer then states the limit and the
    sigma reachable within it.
    """
    if not target_com_sigma > 0:
        raise ValueError(f"target_com_sigma must be > 0 m, got {target_com_sigma}")
    tilt = plan.tilt if max_tilt is None else max_tilt
    base = replace(plan, tilt=tilt)
    unit = predict(base)  # at base.dwell
    c_now = base._variance_factor(base.dwell)
    worst_unit = float(unit.sigma_com.max()) / math.sqrt(c_now)  # sigma at c = 1
    c_needed = (target_com_sigma / worst_unit) ** 2
    rate = base.sensor.rate_hz
    fixed_tare = base.tare_dwell is not None
    tare_term = 0.0
    if fixed_tare and not math.isinf(base.tare_dwell):
        tare_term = 1.0 / max(1.0, round(base.tare_dwell * rate))
    if fixed_tare and c_needed <= tare_term:
        best = predict(replace(base, dwell=max(base.dwell, 1e3)))
        return Advice(
            False,
            base,
            best,
            f"the tare ({base.tare_dwell:g} s per pose) alone gives COM sigma "
            f"{worst_unit * math.sqrt(tare_term) * 1e3:.3g} mm > target "
            f"{target_com_sigma * 1e3:.3g} mm; take a longer tare",
        )
    per_window = (1.0 if fixed_tare else 2.0) / (c_needed - tare_term)
    dwell = math.ceil(per_window) / rate
    needed = replace(base, dwell=dwell)
    if needed.duration() <= max_time:
        return Advice(True, needed, predict(needed))
    n = len(base.poses())
    dwell_max = max_time / n - base.move_time - base.settle
    if dwell_max <= 0:
        return Advice(False, base, unit, f"{n} poses cannot even be visited in {max_time:g} s")
    best_plan = replace(base, dwell=dwell_max)
    best = predict(best_plan)
    return Advice(
        False,
        best_plan,
        best,
        f"COM sigma {target_com_sigma * 1e3:.3g} mm at tilt {tilt:.3g} rad needs "
        f"{dwell:.3g} s per pose ({needed.duration():.3g} s in all) > limit {max_time:g} s; "
        f"within the limit: {best}",
    )
