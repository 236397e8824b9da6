"""com_core.estimation.runs.hand_motion: the empty hand's motion fit serves the hand on the
sensor it was read by, on its robot model, along its motion, while young enough."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from com_core.estimation.fits.motion import MotionFit
from com_core.estimation.runs.hand_motion import HandMotion, load_hand_motion, save_hand_motion
from com_core.estimation.runs.tare_cache import cache_owner

OWNER = cache_owner("panda_hand", "ft-1")


def entry(owner: str = OWNER) -> HandMotion:
    zeros = np.zeros((10, 10))
    fit = MotionFit(np.ones(10), np.ones(10), zeros, zeros, zeros, np.zeros((10, 36)),
                    np.zeros(6), 0.0, 10.0, 10, False, 1000, 1.0, 0.0,
                    np.ones((75, 6)))  # fmt: skip
    times = np.linspace(0.0, 3.0, 7)
    return HandMotion(owner, "sha", 5, times, np.zeros((7, 2)), 0.0, fit)


def path(t: np.ndarray) -> np.ndarray:
    return np.zeros((len(t), 2))


def test_the_hand_motion_serves_its_own_hand_on_its_own_sensor_only(tmp_path):
    """Saved and read back, it serves its owner along its path; the same hand on another
    sensor, another robot model, another path or a longer motion (more cycles) is told
    why not."""
    file = tmp_path / "hand_motion.json"
    save_hand_motion(file, entry())
    saved = load_hand_motion(file)
    assert saved is not None and saved.owner == OWNER
    assert saved.serves(OWNER, "sha", path, 3.0, max_age=np.inf) == ""
    other = cache_owner("panda_hand", "ft-2")
    assert saved.serves(other, "sha", path, 3.0, np.inf).startswith("it is of another hand or")
    assert saved.serves(OWNER, "other", path, 3.0, np.inf).startswith("it is of another robot")
    assert saved.serves(OWNER, "sha", lambda t: path(t) + 1.0, 3.0, np.inf).startswith(
        "it is of another motion"
    )
    assert saved.serves(OWNER, "sha", path, 6.0, np.inf).startswith("it is of a shorter motion")


def test_a_hand_motion_of_more_periods_serves_a_run_along_its_first():
    """The empty hand moved along four periods of 3 s: a run whose object moves along one
    (the command at rest at home after it) is served while the kept path is its path over
    those 3 s, whatever the hand did after; not when they part within them."""
    times = np.linspace(0.0, 12.0, 30)
    ran_on = np.where(times[:, None] > 3.0, 1.0, 0.0) * np.ones((1, 2))
    longer = replace(entry(), times=times, positions=ran_on)
    assert longer.serves(OWNER, "sha", path, 3.0, np.inf) == ""
    early = np.where(times[:, None] > 2.0, 1.0, 0.0) * np.ones((1, 2))
    parted = replace(longer, positions=early)
    assert parted.serves(OWNER, "sha", path, 3.0, np.inf).startswith("it is of another motion")
