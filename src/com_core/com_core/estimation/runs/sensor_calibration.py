"""A sensor's calibration in place (``estimation.fits.in_place``) kept in a file, per
sensor, and applied to every run of that sensor.

The file (``CALIBRATION_FILE`` beside the tare cache) holds one entry per sensor, by its
``sensor_id`` (the robot configuration's: its serial or name and settings); a calibration
of one sensor never serves another. The estimator (and the offline replay, from the copy
the sequencer keeps beside each bag) applies the entry of its sensor: readings corrected
by the estimate, the fits weighing what is left of the error in place of the stated
accuracy (``sensing.calibration``). Everything cached of the sensor before (the tare
windows, the hand model, the hand's motion) belongs to its old calibration:
``calibrated_owner`` names the calibration in the owner those caches are keyed by, so a
new calibration takes fresh ones. JSON floats round-trip: a copy is the calibration, to
the last bit.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from com_core.estimation.fits.in_place import InPlaceCalibration
from com_core.estimation.fits.known_gravity import Reference
from com_core.sensing.calibration import Calibration

__all__ = [
    "CALIBRATION_FILE",
    "SensorCalibration",
    "calibrated_owner",
    "calibration_path",
    "kept_calibration",
    "load_calibration",
    "save_calibration",
]

CALIBRATION_FILE = "sensor_calibration.json"
"""The file's name beside the tare cache, and its copy's (one entry) beside a run's bag."""


@dataclass(frozen=True)
class SensorCalibration:
    """The calibration of the sensor ``sensor_id``, identified in place, saved at
    ``saved`` (unix time, s)."""

    sensor_id: str
    saved: float
    result: InPlaceCalibration

    @property
    def calibration(self) -> Calibration:
        return self.result.calibration

    @property
    def tag(self) -> str:
        """Names this calibration among the sensor's: when it was saved (UTC)."""
        return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self.saved))

    def as_json(self) -> dict:
        c, r = self.result.calibration, self.result.reference
        assert c.estimate is not None and c.residual_cov is not None
        return {
            "sensor_id": self.sensor_id,
            "saved": self.saved,
            "accuracy": c.accuracy,
            "full_scale": [c.full_scale_f, c.full_scale_tau],
            "estimate": c.estimate.tolist(),
            "residual_cov": c.residual_cov.tolist(),
            "reference": {
                "mass": r.mass,
                "mass_sigma": r.mass_sigma,
                "com": None if r.com is None else list(r.com),
                "com_sigma": r.com_sigma,
            },
            "chi2": self.result.chi2,
            "dof": self.result.dof,
            "poses": list(self.result.poses),
        }

    @staticmethod
    def from_json(data: dict) -> SensorCalibration:
        """The entry ``data`` holds; ValueError (or KeyError, TypeError) when it is none."""
        estimate = np.array(data["estimate"], dtype=np.float64)
        left = np.array(data["residual_cov"], dtype=np.float64)
        if estimate.shape != (6, 6) or left.shape != (36, 36):
            raise ValueError("a calibration's estimate is (6, 6) and its rest (36, 36)")
        if not (np.all(np.isfinite(estimate)) and np.all(np.isfinite(left))):
            raise ValueError("a calibration's numbers are finite")
        f, tau = (float(x) for x in data["full_scale"])
        calibration = Calibration(float(data["accuracy"]), f, tau, estimate, left)
        r = data["reference"]
        com = None if r["com"] is None else tuple(float(x) for x in r["com"])
        reference = Reference(float(r["mass"]), float(r["mass_sigma"]), com,  # type: ignore[arg-type]
                              float(r["com_sigma"]))  # fmt: skip
        result = InPlaceCalibration(calibration, reference, float(data["chi2"]), int(data["dof"]),
                                    tuple(str(p) for p in data["poses"]))  # fmt: skip
        return SensorCalibration(str(data["sensor_id"]), float(data["saved"]), result)


def calibration_path(tare_cache: str | Path) -> Path:
    """The calibrations' file beside the tare cache ``tare_cache``."""
    return Path(tare_cache).with_name(CALIBRATION_FILE)


def kept_calibration(tare_cache: str | Path, sensor_id: str) -> SensorCalibration | None:
    """The calibration kept for ``sensor_id`` beside the tare cache ``tare_cache`` (what
    the estimator applies, and the sequencer plans with); None without either, or none
    kept."""
    if not str(tare_cache) or not sensor_id:
        return None
    return load_calibration(calibration_path(tare_cache), sensor_id)


def calibrated_owner(owner: str, entry: SensorCalibration | None) -> str:
    """``owner`` (``tare_cache.cache_owner``) with the sensor's calibration, when it has
    one: what its cached tares, hand model and hand motion are keyed by."""
    return owner if entry is None else f"{owner} calibrated {entry.tag}"


def _entries(path: Path) -> dict[str, dict]:
    """The file's entries by sensor ({} when there is none, or it is broken)."""
    try:
        data = json.loads(path.read_text())
        return {str(k): v for k, v in data["sensors"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def save_calibration(path: str | Path, entry: SensorCalibration) -> None:
    """Add (or replace) the entry of its sensor in ``path`` (whole to a temporary file,
    then renamed: a reader never sees half of it)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    entries = _entries(path) | {entry.sensor_id: entry.as_json()}
    temporary = path.with_name(f".{path.name}.{os.getpid()}")
    temporary.write_text(json.dumps({"sensors": entries}))
    temporary.replace(path)


def load_calibration(path: str | Path, sensor_id: str) -> SensorCalibration | None:
    """The entry of ``sensor_id`` in ``path``; None for '', a missing file, no entry of
    that sensor or one that is broken (the sensor is then taken at its stated accuracy)."""
    if not str(path):
        return None
    data = _entries(Path(path)).get(sensor_id)
    try:
        return None if data is None else SensorCalibration.from_json(data)
    except (ValueError, KeyError, TypeError):
        return None
