"""Every module a package's Python files import is declared in its package.xml with a key
that rosdep resolves, and every declared key is imported (README, Packaging): on a Jazzy
machine ``rosdep install --from-paths . --ignore-src`` installs all that the nodes import.
The simulator is an optional dependency of the sequencer: the node never imports it, and
the demo says so when it is missing."""

from __future__ import annotations

import ast
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from functools import cache
from pathlib import Path
from typing import NamedTuple

from com_core.contract import TOPIC_TYPES

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {
    "com_core": ROOT / "src" / "com_core",
    "com_estimator": ROOT / "com_estimator",
    "wrench_sim": ROOT / "wrench_sim",
    "exploration_sequencer": ROOT / "exploration_sequencer",
}
"""The ament_python packages and their directories (com_interfaces has no Python)."""
OWN_PACKAGES = frozenset({*PACKAGES, "com_interfaces"})
"""This repository's packages: rosdep finds them in the workspace (``--ignore-src``)."""

ROS_PACKAGES = frozenset(
    {
        "action_msgs",
        "ament_index_python",
        "builtin_interfaces",
        "control_msgs",
        "diagnostic_msgs",
        "geometry_msgs",
        "pinocchio",
        "rcl_interfaces",
        "rclpy",
        "rosgraph_msgs",
        "sensor_msgs",
        "std_msgs",
        "std_srvs",
        "trajectory_msgs",
    }
)
"""Modules that are ROS 2 Jazzy packages of the same name: rosdep resolves a package's name
from ros/rosdistro ``jazzy/distribution.yaml`` (pinocchio is released there too, as
ros-jazzy-pinocchio)."""

ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "ruamel": "python3-ruamel.yaml",
    "rosbags": "python3-rosbags-pip",
    "mcap": "mcap-ros2-support",  # no key installs mcap alone; mcap-ros2-support requires it
    "pybullet": "python3-pybullet-pip",
    "pybullet_data": "python3-pybullet-pip",  # both in PyPI's pybullet
    "pybullet_utils": "python3-pybullet-pip",
    "setuptools": "python3-setuptools",
    "pytest": "python3-pytest",
}
"""Other third-party modules (the top-level name an import uses) and the rosdep keys that
install them, from ros/rosdistro ``rosdep/python.yaml``. A ``-pip`` key installs from PyPI;
on Ubuntu 24.04 rosdep needs PIP_BREAK_SYSTEM_PACKAGES=1 for it."""

BUILD_FILES = frozenset({"setup.py"})
"""Files colcon runs to build a package: their imports are build dependencies."""
RUN_TAGS = ("depend", "exec_depend")
BUILD_TAGS = ("depend", "build_depend", "buildtool_depend")
ALL_TAGS = (*RUN_TAGS, "build_depend", "buildtool_depend", "test_depend")

OPTIONAL = {
    ("exploration_sequencer", "exploration_sequencer/demo.py", "wrench_sim"): (
        "the demo starts the simulator; a real arm's install has none, so wrench_sim is a"
        " test_depend (the tests run the demo), and the demo says so when it is missing"
    ),
    ("com_core", "com_core/robot/config.py", "pybullet_data"): (
        "a `pybullet_data:<path>` URDF is the simulator's: wrench_sim, the one package that"
        " loads a configuration's URDF file, declares python3-pybullet-pip"
    ),
}
"""Imports allowed without a run dependency of their package: (package, file under the
package's directory, module) -> why. Each sits inside a function, so that importing the file
needs none of it."""

NOT_IMPORTED = {
    "python3-pytest": "the packages' tests (the repository's test/) run under pytest",
}
"""Declared keys that no file imports, and why they are declared."""

DYNAMIC_IMPORTS = {
    ("exploration_sequencer", "exploration_sequencer/recorder.py"): frozenset(
        msgtype.split("/")[0] for msgtype in TOPIC_TYPES.values()
    ),
}
"""Files that import modules by name at run time (importlib), and the modules they import:
the recorder, each recorded topic's message package (``com_core.contract.TOPIC_TYPES``)."""


class Import(NamedTuple):
    file: str  # under the package's directory
    module: str  # the top-level name
    line: int
    lazy: bool  # inside a function: importing the file does not import it


def rosdep_key(module: str) -> str | None:
    """The rosdep key that installs ``module`` (None: none known)."""
    if module in OWN_PACKAGES or module in ROS_PACKAGES:
        return module
    return ROSDEP_KEYS.get(module)


def declared(package: str, tags: tuple[str, ...]) -> set[str]:
    """The keys ``package``'s package.xml declares with any of ``tags``."""
    root = ET.parse(PACKAGES[package] / "package.xml").getroot()
    return {(e.text or "").strip() for tag in tags for e in root.iter(tag)}


@cache
def parsed(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def python_files(package: str) -> Iterator[Path]:
    yield from sorted(PACKAGES[package].rglob("*.py"))


def imports_of(path: Path, base: Path) -> Iterator[Import]:
    """The modules ``path`` imports (top-level names, not the standard library's nor
    relative), at any depth of the file (also under TYPE_CHECKING and inside functions)."""
    file = path.relative_to(base).as_posix()

    def walk(node: ast.AST, lazy: bool) -> Iterator[Import]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                names = [child.module]
            else:
                inner = isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
                yield from walk(child, lazy or inner)
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names:
                    yield Import(file, top, child.lineno, lazy)

    yield from walk(parsed(path), False)


def imports_by_name(path: Path) -> int | None:
    """The first line where ``path`` imports a module by a name computed at run time
    (None: nowhere)."""
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in {"import_module", "__import__"}:
                return node.lineno
    return None


def package_imports(package: str) -> Iterator[Import]:
    """Every module ``package``'s files import but itself, once a file (lazy only when the
    file imports it nowhere but inside functions), those imported by name at run time
    included."""
    base = PACKAGES[package]
    for path in python_files(package):
        file = path.relative_to(base).as_posix()
        first: dict[str, Import] = {}
        for found in imports_of(path, base):
            seen = first.get(found.module)  # its first import outside a function, if any
            if seen is None or (seen.lazy and not found.lazy):
                first[found.module] = found
        first.pop(package, None)
        yield from first.values()
        for module in sorted(DYNAMIC_IMPORTS.get((package, file), ())):
            yield Import(file, module, imports_by_name(path) or 0, False)


def test_every_import_has_a_declared_key():
    wrong = []
    for package in PACKAGES:
        run, build = declared(package, RUN_TAGS), declared(package, BUILD_TAGS)
        for found in package_imports(package):
            where = f"{package}/{found.file}:{found.line} imports {found.module}"
            key = rosdep_key(found.module)
            if key is None:
                wrong.append(
                    f"{where}: no rosdep key known (add it to ROSDEP_KEYS or ROS_PACKAGES)"
                )
            elif (package, found.file, found.module) in OPTIONAL:
                if not found.lazy:
                    wrong.append(f"{where}: an optional dependency, imported outside a function")
            elif Path(found.file).name in BUILD_FILES:
                if key not in build:
                    wrong.append(f"{where}: package.xml lacks <buildtool_depend> {key}")
            elif key not in run:
                wrong.append(f"{where}: package.xml lacks <exec_depend> {key}")
    assert not wrong, "\n".join(wrong)


def test_every_declared_key_is_imported():
    stale = []
    for package in PACKAGES:
        used = {rosdep_key(found.module) for found in package_imports(package)}
        for key in sorted(declared(package, ALL_TAGS) - used - set(NOT_IMPORTED)):
            stale.append(f"{package}/package.xml declares {key}, which nothing imports")
    assert not stale, "\n".join(stale)


def test_every_run_time_import_is_listed():
    unlisted = [
        f"{package}/{path.relative_to(PACKAGES[package]).as_posix()}"
        for package in PACKAGES
        for path in python_files(package)
        if imports_by_name(path) is not None
        and (package, path.relative_to(PACKAGES[package]).as_posix()) not in DYNAMIC_IMPORTS
    ]
    assert not unlisted, f"import modules by name, not listed in DYNAMIC_IMPORTS: {unlisted}"


def test_the_exceptions_are_still_needed():
    every = {(package, found.file, found.module) for package in PACKAGES
             for found in package_imports(package)}  # fmt: skip
    assert set(OPTIONAL) <= every
    keys = set().union(*(declared(package, ALL_TAGS) for package in PACKAGES))
    assert set(NOT_IMPORTED) <= keys


def test_the_checks_see_imports(tmp_path: Path):
    source = tmp_path / "m.py"
    source.write_text(
        "import os\nimport numpy.linalg\nfrom . import x\n"
        "def f():\n    from rosbags.typesys import get_typestore\n"
    )
    assert [(i.module, i.lazy) for i in imports_of(source, tmp_path)] == [
        ("numpy", False),
        ("rosbags", True),
    ]
    by_name = tmp_path / "n.py"
    by_name.write_text("import importlib\nimportlib.import_module('std_msgs.msg')\n")
    assert imports_by_name(by_name) == 2
    assert imports_by_name(source) is None
    assert "python3-numpy" in declared("com_core", RUN_TAGS)


BLOCK_THE_SIMULATOR = """
import importlib, importlib.abc, pkgutil, sys

BLOCKED = {"wrench_sim", "pybullet", "pybullet_data", "pybullet_utils"}


class Absent(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


sys.meta_path.insert(0, Absent())
import exploration_sequencer

for module in pkgutil.walk_packages(exploration_sequencer.__path__, "exploration_sequencer."):
    importlib.import_module(module.name)
from exploration_sequencer import demo

sys.exit(demo.main([]))
"""


def test_the_sequencer_runs_without_the_simulator():
    """Every module of exploration_sequencer imports without wrench_sim and pybullet; the
    demo then ends with 2, naming the missing package, before it starts anything."""
    done = subprocess.run(
        [sys.executable, "-c", BLOCK_THE_SIMULATOR],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert "wrench_sim package is not installed" in done.stderr
    assert "started" not in done.stdout
