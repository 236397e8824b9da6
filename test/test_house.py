"""The core's wings stand in the pipeline's order (docs/design.md, Architecture): a module
imports from its own wing or from the wings below it, never from one above; ``bags``
depends on nothing of the core; ``runtime`` stands apart."""

from __future__ import annotations

import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[1] / "src" / "com_core" / "com_core"
FLOORS = {
    "contract": 0,
    "inputs": 0,
    "bags": 0,
    "runtime": 0,
    "sensing": 1,
    "robot": 2,
    "estimation": 3,
    "planning": 4,
    "payload": 4,
    "report": 4,
    "paper": 5,
    "sequencing": 5,
}
"""The wings from the bottom up; wings on one floor do not import each other."""


def wing_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "com_core" and len(parts) > 1 else None


def core_imports(path: Path) -> set[str]:
    """The com_core modules ``path`` imports, at any depth of the file (also under
    TYPE_CHECKING and inside functions)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out |= {alias.name for alias in node.names}
    return {m for m in out if m.startswith("com_core.")}


def test_every_wing_has_a_floor():
    modules = {p.stem for p in CORE.glob("*.py")} - {"__init__"}
    packages = {p.name for p in CORE.iterdir() if (p / "__init__.py").is_file()}
    assert modules | packages == set(FLOORS)


def test_nothing_imports_upward_nor_sideways():
    wrong = []
    for path in CORE.rglob("*.py"):
        here = path.relative_to(CORE).parts[0].removesuffix(".py")
        if here == "__init__":
            continue
        for module in core_imports(path):
            there = wing_of(module)
            if there != here and FLOORS[there] >= FLOORS[here]:
                wrong.append(f"{path.relative_to(CORE)} imports {module}")
    assert not wrong, "\n".join(sorted(wrong))


SUB_WINGS = {"fits": 0, "runs": 1, "recordings": 2}
"""The estimation wing's sub-wings from the bottom up: the sequencer's labelled runs and
any recording end in the same fits (docs/design.md, Decisions)."""


def test_the_estimation_sub_wings_import_downward_only():
    estimation = CORE / "estimation"
    packages = {p.name for p in estimation.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(SUB_WINGS)
    assert not [p.name for p in estimation.glob("*.py") if p.name != "__init__.py"]
    wrong = []
    for path in estimation.rglob("*.py"):
        here = path.relative_to(estimation).parts[0]
        if here == "__init__.py":
            continue
        for module in core_imports(path):
            parts = module.split(".")
            inside = parts[1] == "estimation" and len(parts) > 2
            if inside and SUB_WINGS[parts[2]] > SUB_WINGS[here]:
                wrong.append(f"{path.relative_to(CORE)} imports {module}")
    assert not wrong
