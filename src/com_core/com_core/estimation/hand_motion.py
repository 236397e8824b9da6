"""The empty hand's motion fit kept in a file and reused, as a tare pass is
(``tare_cache``): the hand's inertial parameters do not change from object to object.

The estimator writes it after a usable exploration in motion that moved the empty hand
(``motion/tare``), into ``HAND_MOTION_FILE`` beside its tare cache; a later run of the
same hand, robot model and motion reuses it while it is younger than the sequencer's
``tare_max_age``: the sequencer then moves the empty hand only at rest (the noise model,
the grasp check), keeps a copy beside the run's bag, and the estimator (and the offline
replay, from the copy) fits the object with the cached hand taken off. The same motion
matters: the calibration's error on the hand's wrench cancels between the hand's fit and
the object's only along the same trajectory (``motion.fit_motion``). JSON floats
round-trip, so a reused fit is the fit, to the last bit.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from com_core.estimation.motion import MotionFit

__all__ = ["HAND_MOTION_FILE", "HandMotion", "hand_motion_path", "load_hand_motion",
           "save_hand_motion"]  # fmt: skip

HAND_MOTION_FILE = "hand_motion.json"
"""The cache's name beside the tare cache, and its copy's beside a run's bag."""


@dataclass(frozen=True)
class HandMotion:
    """The empty hand's ``fit`` along a motion of ``span`` s (its label's span: the
    excitation's period and the rest after it), of the hand ``hand_id`` on the robot
    model of URDF ``urdf_sha256``, saved at ``saved`` (unix time, s)."""

    hand_id: str
    urdf_sha256: str
    span: float
    saved: float
    fit: MotionFit

    def age(self) -> float:
        """s since it was saved."""
        return time.time() - self.saved

    def serves(self, hand_id: str, urdf_sha256: str, span: float, max_age: float) -> str:
        """'' when it serves a run of ``hand_id`` on that model with a motion of ``span``
        s, no older than ``max_age`` s; else why not."""
        for what, ours, theirs in (
            ("hand", self.hand_id, hand_id),
            ("robot model", self.urdf_sha256[:12], urdf_sha256[:12]),
        ):
            if ours != theirs:
                return f"it is of another {what} ({ours!r}, this run's {theirs!r})"
        if abs(self.span - span) > 1e-3:
            return f"it is of a {self.span:.3f} s motion, this run's is {span:.3f} s"
        if self.age() > max_age:
            return f"it is {self.age():.0f} s old (tare_max_age {max_age:g} s)"
        return ""


def hand_motion_path(tare_cache: str | Path) -> Path:
    """The hand's motion cache beside the tare cache ``tare_cache``."""
    return Path(tare_cache).with_name(HAND_MOTION_FILE)


def save_hand_motion(path: str | Path, entry: HandMotion) -> None:
    """Write ``entry`` to ``path`` (whole to a temporary file, then renamed: a reader
    never sees half of it)."""
    fields = asdict(entry) | {"fit": {k: np.asarray(v).tolist() if isinstance(v, np.ndarray)
                                      else v for k, v in asdict(entry.fit).items()}}  # fmt: skip
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}")
    temporary.write_text(json.dumps(fields))
    temporary.replace(path)


def load_hand_motion(path: str | Path) -> HandMotion | None:
    """The entry in ``path``; None for '', a missing file or one that does not parse."""
    if not str(path):
        return None
    try:
        data = json.loads(Path(path).read_text())
        fit = {k: np.array(v) if isinstance(v, list) else v for k, v in data["fit"].items()}
        return HandMotion(data["hand_id"], data["urdf_sha256"], float(data["span"]),
                          float(data["saved"]), MotionFit(**fit))  # fmt: skip
    except (OSError, ValueError, KeyError, TypeError):
        return None
