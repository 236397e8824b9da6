"""Exceptions raised by the core; each carries a message a user can act on."""

from __future__ import annotations

__all__ = [
    "EstimationError",
    "IllConditionedError",
    "MissingTareError",
    "MotionError",
    "NonFiniteError",
    "NonPositiveMassError",
    "SaturationError",
    "TooFewPosesError",
    "WindowError",
]


class EstimationError(ValueError):
    """Base class: the data cannot give a trustworthy estimate."""


class WindowError(EstimationError):
    """A static window cannot be used."""


class NonFiniteError(WindowError):
    """A sample or window holds NaN or inf."""


class SaturationError(WindowError):
    """A sample reached the sensor's measuring range."""


class MotionError(WindowError):
    """The load moved inside a window that should be static."""


class MissingTareError(EstimationError):
    """An object window has no tare window of the same pose."""


class TooFewPosesError(EstimationError):
    """Fewer than two usable poses."""


class IllConditionedError(EstimationError):
    """The gravity directions of the poses are (nearly) parallel."""


class NonPositiveMassError(EstimationError):
    """The sensed load is not a positive mass (nothing grasped, or a bad tare)."""
