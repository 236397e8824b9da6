"""The empty hand's motion fit kept in a file and reused, as a tare pass is
(``tare_cache``): the hand's inertial parameters do not change from object to object.

The estimator writes it after a usable exploration in motion that moved the empty hand
(``motion/tare``), into ``HAND_MOTION_FILE`` beside its tare cache, with the path the
joints took; a later run of the same hand and robot model whose motion follows that path
reuses it while it is younger than the sequencer's ``tare_max_age``: the sequencer then
moves the empty hand only at rest (the noise model, the grasp check), keeps a copy beside
the run's bag, and the estimator (and the offline replay, from the copy) fits the object
with the cached hand taken off. The same motion matters: the calibration's error on the
hand's wrench cancels between the hand's fit and the object's only along the same
trajectory (``motion.fit_motion``). JSON floats round-trip, so a reused fit is the fit,
to the last bit."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.motion import MotionFit

__all__ = ["HAND_MOTION_FILE", "HandMotion", "hand_motion_path", "load_hand_motion",
           "save_hand_motion"]  # fmt: skip

HAND_MOTION_FILE = "hand_motion.json"
"""The cache's name beside the tare cache, and its copy's beside a run's bag."""


PATH_POINTS = 30
"""Joint states of the hand's motion kept with its fit: the path a later run compares."""
PATH_TOLERANCE = 0.2
"""rad: a later motion whose command is this close to the kept path, at every point, is the
same motion: the simulated arm follows the excitation within 0.09 rad, two designs of
the wrist's motion stand some 3 rad apart."""


@dataclass(frozen=True)
class HandMotion:
    """The empty hand's ``fit`` along a motion that began at ``stamp_ns`` (sensor time),
    of the hand on the sensor ``owner`` (``tare_cache.cache_owner``) on the robot model
    of URDF ``urdf_sha256``; ``times`` (s
    from the motion's start) and ``positions`` (rad, ``joint_names`` of the model) are
    ``PATH_POINTS`` of its joint states, the path it took; saved at ``saved`` (unix
    time, s)."""

    owner: str
    urdf_sha256: str
    stamp_ns: int
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    saved: float
    fit: MotionFit

    def age(self) -> float:
        """s since it was saved."""
        return time.time() - self.saved

    def other_owner(self, owner: str, urdf_sha256: str) -> str:
        """'' when it is of the hand on the sensor ``owner`` on the robot model of URDF
        ``urdf_sha256``; else which differs."""
        if self.owner != owner:
            return f"it is of another hand or sensor ({self.owner!r}, this run's {owner!r})"
        if self.urdf_sha256 != urdf_sha256:
            return (f"it is of another robot model ({self.urdf_sha256[:12]!r}, this run's "
                    f"{urdf_sha256[:12]!r})")  # fmt: skip
        return ""

    def serves(
        self,
        owner: str,
        urdf_sha256: str,
        path: Callable[[NDArray[np.float64]], NDArray[np.float64]],
        duration: float,
        max_age: float,
    ) -> str:
        """'' when it serves a run of ``owner`` on that model whose motion is commanded
        to ``path(t)`` (rad, s from its start; ``joint_names``' positions) for
        ``duration`` s, within ``PATH_TOLERANCE`` of the kept path over those ``duration``
        s (the hand's may have run more periods), no older than ``max_age`` s; else why
        not."""
        if other := self.other_owner(owner, urdf_sha256):
            return other
        if self.times[-1] < duration:
            return f"it is of a shorter motion ({self.times[-1]:.1f} s, this one {duration:g} s)"
        within = self.times <= duration
        kept, positions = self.times[within], self.positions[within]
        apart = float(np.max(np.abs(path(kept) - positions)))
        if not apart <= PATH_TOLERANCE:
            return f"it is of another motion ({apart:.3f} rad apart)"
        if self.age() > max_age:
            return f"it is {self.age():.0f} s old (tare_max_age {max_age:g} s)"
        return ""


def hand_motion_path(tare_cache: str | Path) -> Path:
    """The hand's motion cache beside the tare cache ``tare_cache``."""
    return Path(tare_cache).with_name(HAND_MOTION_FILE)


def save_hand_motion(path: str | Path, entry: HandMotion) -> None:
    """Write ``entry`` to ``path`` (whole to a temporary file, then renamed: a reader
    never sees half of it)."""

    def plain(values: dict) -> dict:
        return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in values.items()}

    fields = plain(asdict(entry)) | {"fit": plain(asdict(entry.fit))}
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}")
    temporary.write_text(json.dumps(fields))
    temporary.replace(path)


_SHAPES = {"pi": (10,), "least_squares": (10,), "cov": (10, 10), "bound": (10, 10),
           "calibration_cov": (10, 10), "calibration_gain": (10, 36), "bias": (6,),
           "residual_blocks": (-1, 6)}  # fmt: skip
"""The fit's arrays and their shapes (-1: any length)."""


def load_hand_motion(path: str | Path) -> HandMotion | None:
    """The entry in ``path``; None for '', a missing file or one that is not an entry
    (another format, arrays of other shapes, numbers that are not finite)."""
    if not str(path):
        return None
    try:
        data = json.loads(Path(path).read_text())
        fit = {k: np.array(v, dtype=np.float64) if k in _SHAPES else v
               for k, v in data["fit"].items()}  # fmt: skip
        times = np.array(data["times"], dtype=np.float64)
        positions = np.array(data["positions"], dtype=np.float64)
        shapes = all(
            fit[k].ndim == len(shape)
            and all(n in (-1, m) for n, m in zip(shape, fit[k].shape, strict=True))
            for k, shape in _SHAPES.items()
        )
        arrays = [*(fit[k] for k in _SHAPES), times, positions]
        if (
            not shapes
            or len(positions) != len(times)
            or not all(np.all(np.isfinite(a)) for a in arrays)
        ):
            return None
        return HandMotion(str(data["owner"]), str(data["urdf_sha256"]), int(data["stamp_ns"]),
                          times, positions, float(data["saved"]), MotionFit(**fit))  # fmt: skip
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
