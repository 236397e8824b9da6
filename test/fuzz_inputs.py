"""Values to try on every input (``com_core.inputs.Input``): the boundary cases of its kind
and range (0, negative, NaN, inf, huge, just outside each bound, wrong length, wrong
type, empty text) and values drawn inside its range from a seeded generator."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from com_core.inputs import Input

WRONG_TYPES: tuple[Any, ...] = ("x", True, [1.0], None)
"""A value of another kind than any row's (None: what an unset parameter reads as)."""


def boundary_values(row: Input) -> list[Any]:
    """The values at and beyond the edges of what ``row`` takes."""
    if row.kind == "bool":
        return [True, False, 1, "true", 0.0]
    if row.kind == "str":
        return ["", " ", "x" * 300, 1.0, *row.choices, *(c.upper() for c in row.choices)]
    if row.kind in ("float", "int"):
        numbers = [0.0, -1.0, 1e9, -1e9, math.nan, math.inf, -math.inf, 1e-300]
        for bound, step in ((row.low, -1.0), (row.high, 1.0)):
            if bound is not None and math.isfinite(bound):
                numbers += [bound, bound + step * max(abs(bound), 1.0) * 1e-6]
        if row.kind == "int":
            return [int(x) for x in numbers if math.isfinite(x)] + [1.5, 2**70, "1", True]
        return [*numbers, 0, *WRONG_TYPES]
    item = row.choices[0] if row.choices else (row.low if row.low is not None else 0.0)
    lengths = row.lengths or (1,)
    values: list[Any] = [[], [item] * (max(lengths) + 1), "x", 0.0]
    if row.kind == "floats":
        values += [[math.nan] * lengths[0], [math.inf] * lengths[0], [1e9] * lengths[0]]
        values += [["x"] * lengths[0]]
    else:
        values += [[""] * lengths[0], ["z"] * lengths[0], [1.0] * lengths[0]]
    return values


def valid_values(row: Input, rng: np.random.Generator, count: int = 3) -> list[Any]:
    """``count`` values drawn inside what ``row`` takes (its default first)."""
    out = [row.default]
    for _ in range(count - 1):
        if row.kind == "bool":
            out.append(bool(rng.integers(2)))
        elif row.choices:
            pick = [str(c) for c in rng.permutation(list(row.choices))]
            out.append(pick[0] if row.kind == "str" else pick[: rng.integers(1, len(pick) + 1)])
        elif row.kind in ("float", "int", "floats"):
            low = row.low if row.low is not None else -10.0
            high = row.high if row.high is not None else 10.0
            high = min(high, low + 10.0 * max(1.0, abs(low)))  # a value a user would give
            n = (row.lengths or (1,))[0]
            drawn = rng.uniform(low, high, n)
            drawn = np.where(drawn == low, (low + high) / 2, drawn)  # open bounds
            if row.kind == "int":
                out.append(int(drawn[0]))
            else:
                out.append(float(drawn[0]) if row.kind == "float" else drawn.tolist())
    return out


def values_of(row: Input, seed: int = 0) -> list[Any]:
    """Every value to try on ``row``: its boundary cases, then drawn ones."""
    return boundary_values(row) + valid_values(row, np.random.default_rng(seed))
