"""The paper's method reproduced: synthetic explorations and the Monte Carlo study.

The study's names are imported from ``com_core.paper.study`` when first used, so that
``python -m com_core.paper.study`` runs the module once, as ``__main__``.
"""

from typing import Any

from com_core.paper.synthetic import (
    Load,
    Stream,
    exploration_samples,
    exploration_stream,
    object_windows,
)

_STUDY = ("PAPER_LOAD", "Cell", "main", "run_cell", "table_cells")

__all__ = [
    "PAPER_LOAD",
    "Cell",
    "Load",
    "Stream",
    "exploration_samples",
    "exploration_stream",
    "main",
    "object_windows",
    "run_cell",
    "table_cells",
]


def __getattr__(name: str) -> Any:
    """``com_core.paper.<name>`` for a name of the study (imported on first use)."""
    if name in _STUDY:
        from com_core.paper import study

        return getattr(study, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
