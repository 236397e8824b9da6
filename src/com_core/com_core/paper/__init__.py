"""The paper's method reproduced: synthetic explorations and the Monte Carlo study."""

from com_core.paper.study import (
    PAPER_LOAD,
    Cell,
    main,
    run_cell,
    table_cells,
)
from com_core.paper.synthetic import (
    Load,
    Stream,
    exploration_samples,
    exploration_stream,
    object_windows,
)

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
