"""What each input means, and the one check every input goes through where it enters.

A node's parameters (at start and at every set), the demo's flags, an Explore goal's
options and the replay's options are described by ``Input`` rows: the value's type, its
range or choices, the lengths a list may have, the values that mean "someone else's"
(NaN: the sensor profile's; '': none), the unit and the fix to suggest. ``Input.problem``
checks one value against its row and says why it is refused in a line that names the
input, the value, what is allowed and, where there is one, the fix::

    tilt=3.0 refused: must be in [0.01, pi/2) rad; a tilt the wrist makes from home, ...

Checks between values (a profile's noise against its resolution, a COM inside the
object) and against the arm (reach, the plan's information) stay with the tables and
the planner that know them; they word their refusals the same way (``refusal``).
Nothing here imports rclpy.
"""

from __future__ import annotations

import math
import tempfile
from array import array
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "Input",
    "InputError",
    "number_text",
    "problems",
    "refusal",
    "table_of",
    "unwritable",
]

KINDS = ("float", "int", "bool", "str", "floats", "strings")
"""An input's type: a number, a flag, a text, or a list of numbers or of texts."""


class InputError(ValueError):
    """A value refused where it enters; the message names the input, the value, what is
    allowed and the fix."""


def number_text(x: float) -> str:
    """A bound as a reader types it: pi/2, pi/6 and pi by name, an integer whole, others
    in 6 digits."""
    for name, value in (("pi/2", math.pi / 2), ("pi", math.pi), ("pi/6", math.pi / 6)):
        if abs(x) == value:
            return name if x > 0 else f"-{name}"
    if isinstance(x, int):
        return str(x)
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.6g}"


def refusal(name: str, value: Any, why: str, fix: str = "") -> str:
    """The line a refused value gets: ``name=value refused: why; fix``."""
    return f"{name}={value!r} refused: {why}" + (f"; {fix}" if fix else "")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _same(value: Any, other: Any) -> bool:
    """``value == other``, with NaN equal to NaN and lists equal to tuples."""
    if isinstance(value, (list, tuple)) and isinstance(other, (list, tuple)):
        return len(value) == len(other) and all(map(_same, value, other))
    if _is_number(value) and _is_number(other) and math.isnan(value) and math.isnan(other):
        return True
    return type(value) is type(other) and value == other


@dataclass(frozen=True)
class Input:
    """One input: its name, default, meaning (with units) and what it takes.

    ``low``/``high`` bound a number or each number of a list (``low_open``: the bound
    itself is refused; numbers are always finite);
    ``choices`` lists what a text (or each text of a list) may be; ``lengths`` the lengths
    a list may have (empty: any but none); ``keep`` values that mean "not set here" and
    are taken as they are; ``fix`` what to do when refused; ``check`` a further test of an
    otherwise accepted value ('' when fine, else why).
    """

    name: str
    default: Any
    description: str
    kind: str = "float"
    unit: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[Any, ...] = ()
    lengths: tuple[int, ...] = ()
    keep: tuple[Any, ...] = ()
    fix: str = ""
    read_only: bool = False
    check: Callable[[Any], str] | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"{self.name}: kind {self.kind!r} is none of {KINDS}")

    def allowed(self) -> str:
        """What the input takes, as a reader of the parameter table reads it."""
        if self.choices:
            text = " | ".join(str(c) for c in self.choices)
        elif self.kind == "bool":
            text = "true | false"
        elif self.kind in ("str", "strings"):
            text = "a text"
        else:
            text = self._interval() or "finite"
            text = f"integer, {text}" if self.kind == "int" else text
        if self.kind in ("floats", "strings"):
            count = " or ".join(str(n) for n in self.lengths) if self.lengths else "1 or more"
            text = f"{count} values, each {text}"
        if self.unit:
            text += f" {self.unit}"
        if self.keep:
            text += "; or " + ", ".join(_keep_text(k) for k in self.keep)
        return text

    def descriptor(self) -> dict[str, Any]:
        """The fields of a ROS ParameterDescriptor (rcl_interfaces) for this input: what
        ``ros2 param describe`` shows. Typed dynamically, so that every value reaches
        ``problem`` and is refused in its words (``tilt:=1`` is the number 1)."""
        return {
            "description": self.description,
            "additional_constraints": self.allowed(),
            "read_only": self.read_only,
            "dynamic_typing": True,
        }

    def problem(self, value: Any, called: str = "") -> str:
        """Why ``value`` is refused ('' when accepted): the refusal line (``refusal``),
        naming the input ``called`` when given (a command line's flag), else its name."""
        if isinstance(value, array):  # a ROS parameter's list
            value = value.tolist()
        if any(_same(value, k) for k in self.keep):
            return ""
        why = self._why(value)
        if not why and self.check is not None:
            why = self.check(value)
        return refusal(called or self.name, value, why, self.fix) if why else ""

    def _why(self, value: Any) -> str:
        kind = self.kind
        if kind == "bool":
            return "" if isinstance(value, bool) else "must be true or false"
        if kind == "str":
            if not isinstance(value, str):
                return "must be a text"
            return self._choice(value)
        if kind in ("floats", "strings"):
            if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
                return f"must be a list ({self.allowed()})"
            if (self.lengths and len(value) not in self.lengths) or not value:
                return f"must be {self.allowed()}; got {len(value)} values"
            for item in value:
                if why := (self._number(item) if kind == "floats" else self._text(item)):
                    return f"{why} (each of the list)"
            return ""
        if kind == "int" and not (isinstance(value, int) and not isinstance(value, bool)):
            return "must be an integer"
        return self._number(value)

    def _text(self, value: Any) -> str:
        return self._choice(value) if isinstance(value, str) else "must be texts"

    def _choice(self, value: str) -> str:
        if self.choices and value not in self.choices:
            return f"must be one of {list(self.choices)}"
        return ""

    def _number(self, value: Any) -> str:
        if not _is_number(value):
            return "must be a number"
        where = " ".join(x for x in (self._interval(), self.unit) if x)
        if not math.isfinite(value):
            return f"must be a finite number {where}".rstrip()
        low, high = self.low, self.high
        if (low is not None and (value < low or (self.low_open and value == low))) or (
            high is not None and (value > high or (self.high_open and value == high))
        ):
            return f"must be in {where}"
        return ""

    def _interval(self) -> str:
        """The numbers' range: ``[0, inf)``, ``(0, pi/2)``; '' when unbounded."""
        if self.low is None and self.high is None:
            return ""
        low = "-inf" if self.low is None else number_text(self.low)
        high = "inf" if self.high is None else number_text(self.high)
        left = "(" if self.low_open or self.low is None else "["
        right = ")" if self.high_open or self.high is None else "]"
        return f"{left}{low}, {high}{right}"


def _keep_text(value: Any) -> str:
    if value is None:
        return "unset"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    return str(list(value)) if isinstance(value, (list, tuple)) else str(value)


def problems(table: Mapping[str, Input], values: Mapping[str, Any]) -> list[str]:
    """The refusal of each value of ``values`` its input in ``table`` refuses, and of each
    name the table does not know."""
    out = []
    for name, value in values.items():
        row = table.get(name)
        if row is None:
            out.append(f"{name!r} is no input here (known: {', '.join(sorted(table))})")
        elif why := row.problem(value):
            out.append(why)
    return out


def table_of(rows: Iterable[Input]) -> dict[str, Input]:
    """The rows by name (each name once)."""
    out: dict[str, Input] = {}
    for row in rows:
        if row.name in out:
            raise ValueError(f"input {row.name!r} twice")
        out[row.name] = row
    return out


def unwritable(name: str, path: str | Path, directory: bool = False) -> str:
    """Why the input ``name`` cannot have ``path`` to write to ('' when it can): a
    ``directory`` (or a file's directory) is created if missing and must take a new
    file; a file that is there must open for appending (it is left as it was)."""
    path = Path(path)
    folder = path if directory else path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not directory and path.exists():
            with path.open("a"):
                pass
        else:
            with tempfile.TemporaryFile(dir=folder):
                pass
    except OSError as error:
        return refusal(name, str(path), f"cannot be written ({error.strerror or error})")
    return ""
