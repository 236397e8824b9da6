"""The sensor's calibration identified in place, from a reference weight of known mass.

A sensor reads C w = (I + S E S^-1) w (``com_core.sensing.calibration``): E, its gain and
cross-talk error, is what limits the accuracy of every estimate once the noise has been
averaged down, and repeating runs does not average it away. A reference weight of known
mass, held through the poses of a static exploration with the empty hand at the same poses
(its tare pass), is fitted by ``known_gravity.kinematic_ml`` with the reference as a
prior on the object (``Reference``) and the sensor's stated accuracy as the prior of E;
what the windows' misfit says of E is its best linear unbiased prediction
(``KinematicFit.calibration_error``), with the covariance of what is left: taken at the
readings, it is of the error as read, E' with C^-1 = I - S E' S^-1
(``com_core.sensing.calibration``).

What the poses can identify: under gravity alone a rigid load's wrench is
(I + S E S^-1) [I; [p]_x] m g, so of E's 36 elements the windows see 18 combinations, less
what the unknown hand and bias absorb:

- force from force (9): the gains and the cross-talk between forces, through the
  reference's known mass (the empty hand adds the directions in which the force's size
  would change with the pose);
- torque from force (9): its symmetric part; the antisymmetric part is indistinguishable
  from the reference's COM unless the reference's COM is given;
- torque from torque and force from torque (18): only through the reference's lever, a
  small share.

Each block's share of its prior variance that is left (``InPlaceCalibration.left``, 0:
identified, 1: untouched) says what was identified and what was not, and the estimates
carry the rest as their calibration term. The model is linear: a sensor's hysteresis and
non-linearity are not in it, and what they leave shows in the fit's chi-square
(``InPlaceCalibration.p_value``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from com_core.estimation.fits.errors import EstimationError
from com_core.estimation.fits.known_gravity import (
    KinematicFit,
    Observation,
    Reference,
    kinematic_ml,
)
from com_core.estimation.fits.stats import chi2_sf
from com_core.robot.model import DEFAULT_GRAVITY
from com_core.sensing.calibration import Calibration

__all__ = ["BLOCKS", "MAX_FORCE_LEFT", "InPlaceCalibration", "calibrate_in_place"]

BLOCKS = {
    "force from force": (slice(0, 3), slice(0, 3)),
    "force from torque": (slice(0, 3), slice(3, 6)),
    "torque from force": (slice(3, 6), slice(0, 3)),
    "torque from torque": (slice(3, 6), slice(3, 6)),
}
"""E's blocks (rows: what is read; columns: what is loaded)."""
MAX_FORCE_LEFT = 0.25
"""The share of the force block's prior variance a calibration may leave: more, and the
reference or its poses did not identify the gains it is run for."""


@dataclass(frozen=True)
class InPlaceCalibration:
    """A sensor's calibration identified in place: ``calibration`` (the stated accuracy,
    the estimate E^ and the covariance of what is left), from ``reference``, with the
    fit's ``chi2`` on ``dof`` and its ``poses``."""

    calibration: Calibration
    reference: Reference
    chi2: float
    dof: int
    poses: tuple[str, ...]

    @property
    def p_value(self) -> float:
        """The chance of a chi-square this large from the noise alone."""
        return chi2_sf(self.chi2, self.dof) if self.dof > 0 else 1.0

    @property
    def left(self) -> dict[str, float]:
        """Per block of E (``BLOCKS``), the share of its prior variance left (0..1)."""
        index = np.arange(36).reshape(6, 6)
        prior = self.calibration.sigma**2
        diagonal = np.diag(self.calibration.error_cov)
        return {
            name: float(np.mean(diagonal[index[rows, columns].ravel()]) / prior)
            for name, (rows, columns) in BLOCKS.items()
        }

    def problems(self, alpha: float) -> list[str]:
        """Why this calibration should not be used ([] when it may): the force block
        left above ``MAX_FORCE_LEFT`` (too light a reference, or too few poses), or a
        misfit the noise explains with probability below ``alpha`` (the reference moved
        in the grasp, or hysteresis and non-linearity beyond what a linear calibration
        can take)."""
        out = []
        force = self.left["force from force"]
        if force > MAX_FORCE_LEFT:
            out.append(
                f"the poses leave {force:.0%} of the force gains' error (allowed "
                f"{MAX_FORCE_LEFT:.0%}): a heavier reference, or more tilt"
            )
        if self.p_value < alpha:
            out.append(
                f"the reference's windows leave chi^2 {self.chi2:.1f} on {self.dof} dof "
                f"(p {self.p_value:.2g} < {alpha:g}): did it move in the grasp, or does the "
                "sensor's hysteresis exceed what a linear calibration takes?"
            )
        return out

    def summary(self) -> str:
        """One line: the reference and each block's share identified."""
        parts = ", ".join(f"{name} {1 - share:.0%}" for name, share in self.left.items())
        return (
            f"calibrated in place with {self.reference.mass * 1e3:.1f} g over "
            f"{len(self.poses)} poses: identified {parts}; chi^2/dof "
            f"{self.chi2 / max(self.dof, 1):.2f}"
        )


def calibrate_in_place(
    observations: Sequence[Observation],
    reference: Reference,
    stated: Calibration,
    gravity: ArrayLike = DEFAULT_GRAVITY,
    drift_rate_sigma: tuple[float, float] | None = None,
    nuisance_cov: NDArray[np.float64] | None = None,
) -> tuple[InPlaceCalibration, KinematicFit]:
    """The calibration the windows identify (module): ``observations`` of the empty hand
    and of the ``reference`` at static poses, read raw (not corrected by an earlier
    calibration); ``stated`` the sensor's stated accuracy and full scales, the prior of E.
    With the fit it came from. EstimationError without both empty-hand and reference
    windows;
    the fit's own errors (``kinematic_ml``) when the poses do not resolve it.
    ``nuisance_cov``: that of the windows' ``nuisance`` (the sensor's hysteresis)."""
    observations = list(observations)
    if not any(o.load for o in observations) or all(o.load for o in observations):
        raise EstimationError("a calibration in place needs the empty hand and the reference")
    prior = Calibration(stated.accuracy, stated.full_scale_f, stated.full_scale_tau)
    fit = kinematic_ml(
        observations, gravity, drift_rate_sigma=drift_rate_sigma, calibration=prior,
        reference=reference, nuisance_cov=nuisance_cov,
    )  # fmt: skip
    fit = kinematic_ml(
        observations, gravity, drift_rate_sigma=drift_rate_sigma, calibration=prior,
        uncalibrated=fit.bias[0], reference=reference, nuisance_cov=nuisance_cov,
    )  # fmt: skip
    estimate, left = fit.calibration_error()
    calibrated = replace(prior, estimate=estimate, residual_cov=left)
    result = InPlaceCalibration(
        calibrated, reference, fit.estimate.chi2, fit.estimate.dof, fit.estimate.poses
    )
    return result, fit
