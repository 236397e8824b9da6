"""Tare passes kept in a file and reused while they stay valid.

The empty hand's wrench in every pose of a plan (its tare windows) depends on the hand
and the plan only, so one tare pass serves many objects, on the sensor it was read by: its
bias, noise and calibration are the sensor's (``cache_owner``: the hand on the sensor,
named by the robot configuration's ``hand_id`` and ``sensor_id``). The file holds one
entry per owner and plan: the windows (mean and covariance of the mean per pose, to the last bit:
JSON floats round-trip) with their joint positions and times, the signature of what
they were taken for (``signature``), and when; and which entry is ``current`` (the one
the running exploration uses, which the estimator reads). With the wrenches alone a run
reuses an entry when its signature matches, it is young enough, and a short fresh tare
window at home agrees with it (``drift``); a run with another plan adds its own entry
beside it. With the joint positions an entry is a model of the hand at any orientation
(``known_gravity``): the newest one of the hand serves any plan
(``latest_hand_model``). A run that reuses one keeps a copy beside its bag
(``tare.json``, one entry) so the offline replay sees the same tare as the node did.
A file of one entry without ``entries`` (as the sample bag's tare.json) loads too.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from com_core.estimation.fits.stats import chi2_sf
from com_core.estimation.fits.windows import Window, window_from_mean
from com_core.sensing.hysteresis import Way
from com_core.sensing.noise import NoiseModel

__all__ = [
    "BAG_TARE_FILE",
    "DRIFT_ALPHA",
    "TareCache",
    "cache_owner",
    "drift",
    "drift_accepted",
    "latest_hand_model",
    "load_tares",
    "reusable",
    "save_tares",
    "tare_signature",
    "use_tares",
]

BAG_TARE_FILE = "tare.json"
DRIFT_ALPHA = 1e-3
"""False-alarm rate of the drift test: a fresh window that agrees with p >= this reuses."""


@dataclass(frozen=True)
class TareCache:
    """Tare windows by pose, what they were taken for, and when (unix time, s); with the
    joint positions of each window (rad, m, by joint name), the hand's wrench is known
    at any orientation (``known_gravity``), not only at these poses; ``times`` are the
    windows' middles (s, the sensor's clock), for a bias that drifts within the pass;
    ``noise`` the sensor's noise learnt from the pass (``com_core.sensing.noise``);
    ``ways`` each window's way from the one before it in the pass, as read, for a sensor
    of stated hysteresis (``com_core.sensing.hysteresis.Way``: the fits weigh the cached
    windows as the pass's own run did)."""

    signature: str
    created: float
    windows: dict[str, Window]
    joints: dict[str, dict[str, float]] = field(default_factory=dict)
    times: dict[str, float] = field(default_factory=dict)
    noise: NoiseModel | None = None
    ways: dict[str, Way] = field(default_factory=dict)

    def age(self) -> float:
        return time.time() - self.created

    def corrected(self, correction: NDArray[np.float64]) -> TareCache:
        """The pass as read through ``correction`` (6, 6; a calibration in place, a
        hysteresis's gain: ``sensing.calibration.reading_correction``): each window's
        mean and covariance, and each way, so mapped."""
        m = correction
        windows = {pose: replace(w, mean=m @ w.mean, cov=m @ w.cov @ m.T)
                   for pose, w in self.windows.items()}  # fmt: skip
        ways = {pose: way.corrected(m) for pose, way in self.ways.items()}
        return replace(self, windows=windows, ways=ways)

    @property
    def owner(self) -> str:
        """The hand on the sensor it was taken with (``cache_owner``)."""
        return self.signature.split("|", 1)[0]

    @property
    def has_joints(self) -> bool:
        """Every window has its joint positions (a hand model can be fitted)."""
        return bool(self.windows) and self.windows.keys() <= self.joints.keys()

    def as_json(self) -> dict:
        windows: dict = {}
        for pose, w in self.windows.items():
            windows[pose] = {"mean": w.mean.tolist(), "cov": w.cov.tolist(), "n": w.n}
            if pose in self.joints:
                windows[pose]["joints"] = self.joints[pose]
            if pose in self.times:
                windows[pose]["time"] = self.times[pose]
            if (way := self.ways.get(pose)) is not None:
                windows[pose]["way"] = {
                    "beyond": way.beyond.tolist(),
                    **({} if way.travel is None else {"travel": way.travel.tolist()}),
                    **({} if way.reach is None else {"reach": way.reach.tolist()}),
                }
        out = {"signature": self.signature, "created": self.created, "windows": windows}
        if self.noise is not None:
            out["noise"] = self.noise.as_dict()
        return out

    @staticmethod
    def from_json(data: dict) -> TareCache:
        windows = {
            pose: window_from_mean(pose, w["mean"], w["cov"], w["n"])
            for pose, w in data["windows"].items()
        }
        joints = {
            pose: {name: float(q) for name, q in w["joints"].items()}
            for pose, w in data["windows"].items()
            if "joints" in w
        }
        times = {pose: float(w["time"]) for pose, w in data["windows"].items() if "time" in w}
        noise = NoiseModel.from_dict(data["noise"]) if "noise" in data else None
        ways = {pose: _way_from_json(w["way"]) for pose, w in data["windows"].items()
                if "way" in w}  # fmt: skip
        return TareCache(
            data["signature"], float(data["created"]), windows, joints, times, noise, ways
        )


def _way_from_json(data: dict) -> Way:
    """A window's ``Way`` as ``TareCache.as_json`` writes it."""
    travel, reach = (np.array(data[key], dtype=np.float64) if key in data else None
                     for key in ("travel", "reach"))  # fmt: skip
    return Way(travel, reach, np.array(data["beyond"], dtype=np.float64))


def cache_owner(hand_id: str, sensor_id: str) -> str:
    """What a cached tare, hand model or hand motion belongs to: the hand ``hand_id`` on
    the sensor ``sensor_id`` (its serial or name and settings; '' an unnamed one). Another
    sensor, or the same one recalibrated, has its own bias, noise and calibration: none
    of its cached things serves another."""
    return f"{hand_id} on {sensor_id or 'an unnamed sensor'}"


def tare_signature(owner: str, poses: Sequence[tuple[str, Sequence[float]]]) -> str:
    """What a tare pass was taken for: the hand on the sensor (``cache_owner``), and each
    pose's name and joints (rad, to 0.1 mrad), so a plan with another tilt, other axes or
    another choreography has an entry of its own."""
    joints = "|".join(f"{name} {[round(q, 4) for q in js]}" for name, js in poses)
    return f"{owner}|{joints}"


def _read(path: Path) -> tuple[dict[str, TareCache], str | None]:
    """(entries by signature, current signature) of a cache file; ({}, None) if none."""
    if not path.is_file():
        return {}, None
    data = json.loads(path.read_text())
    if "entries" not in data:  # one entry
        entry = TareCache.from_json(data)
        return {entry.signature: entry}, entry.signature
    entries = {sig: TareCache.from_json(e) for sig, e in data["entries"].items()}
    return entries, data.get("current")


def _write(path: Path, entries: dict[str, TareCache], current: str | None) -> None:
    """Write atomically (a reader never sees half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {"current": current, "entries": {sig: e.as_json() for sig, e in entries.items()}}
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def _read_or_empty(path: Path) -> dict[str, TareCache]:
    """The entries of ``path``; none when it is missing or broken (it is then rewritten)."""
    try:
        return _read(path)[0]
    except (ValueError, KeyError, TypeError, OSError):
        return {}


def save_tares(
    path: Path | str,
    signature: str,
    windows: dict[str, Window],
    joints: dict[str, dict[str, float]] | None = None,
    times: dict[str, float] | None = None,
    noise: NoiseModel | None = None,
    ways: dict[str, Way] | None = None,
) -> None:
    """Add (or replace) the entry for ``signature``, taken now, and make it current;
    ``joints`` and ``times``: each window's joint positions (rad, m, by joint name) and
    time (s, the middle of the window, the sensor's clock); ``noise``: the sensor's;
    ``ways``: each window's way, as read (``TareCache``)."""
    path = Path(path)
    entries = _read_or_empty(path)
    entries[signature] = TareCache(
        signature, time.time(), dict(windows), dict(joints or {}), dict(times or {}), noise,
        dict(ways or {}),
    )  # fmt: skip
    _write(path, entries, signature)


def use_tares(path: Path | str, entry: TareCache) -> None:
    """Make ``entry`` the current one of the cache in ``path`` (adding it if missing)."""
    path = Path(path)
    entries = _read_or_empty(path)
    entries.setdefault(entry.signature, entry)
    _write(path, entries, entry.signature)


def load_tares(path: Path | str, signature: str | None = None) -> TareCache | None:
    """The entry for ``signature`` in ``path`` (default: the current one), or None when
    there is no file or no such entry (a broken file raises)."""
    entries, current = _read(Path(path))
    return entries.get(signature if signature is not None else current or "")


def latest_hand_model(path: Path | str, owner: str) -> TareCache | None:
    """The newest entry of ``path`` of ``owner`` (``cache_owner``) whose windows all have
    their joint positions: it gives the hand's wrench at any pose, whatever plan it was
    taken for (None when there is none or no file; a broken file raises)."""
    entries, _ = _read(Path(path))
    usable = [e for e in entries.values() if e.owner == owner and e.has_joints]
    return max(usable, key=lambda e: e.created, default=None)


def drift(cached: Window, fresh: Window) -> tuple[float, float]:
    """(chi-square, p-value) that two windows of the same empty-hand pose differ.

    d = mean difference, chi2 = d^T (C1 + C2)^-1 d with 6 degrees of freedom.
    """
    d = fresh.mean - cached.mean
    chi2 = float(d @ np.linalg.solve(cached.cov + fresh.cov, d))
    return chi2, chi2_sf(chi2, 6) if math.isfinite(chi2) else 0.0


def reusable(cache: TareCache | None, max_age: float, poses: Iterable[str]) -> bool:
    """A cached entry serves a run: it exists (for the run's signature), it is younger
    than ``max_age`` s and it has a window for every pose of the plan. The drift check
    at home decides the rest (``drift_accepted``)."""
    return cache is not None and cache.age() < max_age and set(poses) <= cache.windows.keys()


def drift_accepted(cached: Window, fresh: Window | None) -> tuple[bool, float, float]:
    """(reuse, chi-square, p-value): the fresh window at home agrees with the cached one
    at false-alarm rate DRIFT_ALPHA (no fresh window: not reused)."""
    chi2, p = drift(cached, fresh) if fresh is not None else (math.inf, 0.0)
    return p >= DRIFT_ALPHA, chi2, p
