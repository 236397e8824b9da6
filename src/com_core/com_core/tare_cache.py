"""A tare pass kept in a file and reused while it stays valid.

The empty hand's wrench in every pose of a plan (its tare windows) depends on the hand
and the plan only, so one tare pass serves many objects. The file holds the windows
(mean and covariance of the mean per pose, to the last bit: JSON floats round-trip)
and a signature of what they were taken for (hand, plan); a run reuses it when the
signature matches, it is young enough, and a short fresh tare window at home agrees
with the cached one (``drift``). A run that reuses it keeps a copy beside its bag
(``tare.json``) so the offline replay sees the same tare as the node did.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .stats import chi2_sf
from .windows import Window, window_from_mean

__all__ = ["BAG_TARE_FILE", "TareCache", "drift", "load_tares", "save_tares"]

BAG_TARE_FILE = "tare.json"


@dataclass(frozen=True)
class TareCache:
    """Tare windows by pose, what they were taken for, and when (unix time, s)."""

    signature: str
    created: float
    windows: dict[str, Window]

    def age(self) -> float:
        return time.time() - self.created


def save_tares(path: Path | str, signature: str, windows: dict[str, Window]) -> None:
    """Write the tare windows atomically (a reader never sees half a file)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {
        "signature": signature,
        "created": time.time(),
        "windows": {
            pose: {"mean": w.mean.tolist(), "cov": w.cov.tolist(), "n": w.n}
            for pose, w in windows.items()
        },
    }
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def load_tares(path: Path | str) -> TareCache | None:
    """The cache in ``path``, or None when there is no file (a broken file raises)."""
    path = Path(path)
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    windows = {
        pose: window_from_mean(pose, w["mean"], w["cov"], w["n"])
        for pose, w in data["windows"].items()
    }
    return TareCache(data["signature"], float(data["created"]), windows)


def drift(cached: Window, fresh: Window) -> tuple[float, float]:
    """(chi-square, p-value) that two windows of the same empty-hand pose differ.

    d = mean difference, chi2 = d^T (C1 + C2)^-1 d with 6 degrees of freedom.
    """
    d = fresh.mean - cached.mean
    chi2 = float(d @ np.linalg.solve(cached.cov + fresh.cov, d))
    return chi2, chi2_sf(chi2, 6) if math.isfinite(chi2) else 0.0
