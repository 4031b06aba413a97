"""The package's layers: what may import what, no import cycles, no rclpy in the core.

Every ``import`` and ``from ... import`` in pmr_ros (module level and inside
functions alike) is read with ``ast``; the layer rules are those of
docs/architecture.md.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pmr_ros"

LAYERS: dict[str, set[str]] = {
    # layer -> the layers it may import (itself always)
    "resources": set(),
    "_version": {"resources"},
    "_blas": set(),
    "_lazy": set(),  # the front files' names loaded on first use: every layer's front file uses it
    "core": set(),
    "progress": set(),
    "outputs": set(),  # safe output writing: used by every writer
    # models: the curve files a params file names (models.curve_files and the readers it uses import no config)
    "config": {"core", "resources", "outputs", "models"},
    "peers": {"core"},  # peer methods of the benchmark: numpy/scipy on the core's model, no ROS, no commands
    "benchmark": {"core", "config", "peers", "resources", "outputs"},  # scenarios, runs, scoring, dataset, report
    "report": {"core", "config", "data", "sweep", "outputs"},
    "contract": {"core", "config", "resources"},
    "data": {"core", "config"},
    "models": {"core", "config"},
    "sweep": {"core", "config", "progress", "outputs"},
    "bag": {"core", "config", "contract", "models"},  # models: the curve files a bag carries, read back
    # sweep: its Dask cluster (monitor, fleet, benchmark)
    "service": {"core", "config", "contract", "data", "report", "bag", "benchmark", "sweep", "progress", "outputs"},
    "ros": {"core", "config", "contract", "resources"},
    "nodes": {"core", "config", "contract", "ros", "bag", "service"},
    "node_set": {"core", "config", "contract", "ros", "nodes"},
    "commands": {
        "core",
        "config",
        "contract",
        "report",
        "data",
        "sweep",
        "bag",
        "ros",
        "nodes",
        "node_set",
        "resources",
        "progress",
        "service",
        "models",
        "outputs",
        "benchmark",
    },
    "cli": {"commands", "config", "ros", "service", "outputs"},
    "entry": set(),  # imports its commands by name (importlib) once the signals are taken
    "__init__": {"_version", "_blas", "_lazy"},  # and, imported on first use by name (importlib), the front door
    "api": {"core", "config", "service", "bag"},
}
"""Each top-level part of pmr_ros and the parts it may import."""

ROS_LAYERS = {"ros", "nodes", "node_set", "commands", "cli"}
"""The only layers that may import rclpy or ROS message packages."""

ROS_PACKAGES = (
    "rclpy",
    "rcl_interfaces",
    "builtin_interfaces",
    "std_msgs",
    "sensor_msgs",
    "diagnostic_msgs",
    "rosgraph_msgs",
)


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Absolute names of every module ``path`` imports (relative imports resolved)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            out.add(target)
            # ``from . import store`` imports a module, not a name
            out.update(
                f"{target}.{alias.name}"
                for alias in node.names
                if (PACKAGE.parent / Path(*f"{target}.{alias.name}".split("."))).with_suffix(".py").exists()
            )
    return out


def _layer(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}
GRAPH = {name: {m for m in _imports(path) if m in MODULES and m != name} for name, path in MODULES.items()}


def test_every_part_of_the_package_has_a_layer():
    assert {_layer(m) for m in MODULES} <= set(LAYERS)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_follow_the_layers(module):
    layer = _layer(module)
    # the package's own __init__ (its version) and the front files' lazy names are open to every layer
    open_to_all = (layer, "__init__", "_lazy")
    wrong = sorted(m for m in GRAPH[module] if _layer(m) not in open_to_all and _layer(m) not in LAYERS[layer])
    assert not wrong, f"{module} ({layer}) may not import {wrong}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_rclpy_only_in_the_ros_shell(module):
    if _layer(module) in ROS_LAYERS:
        return
    ros = sorted(m for m in _imports(MODULES[module]) if m.split(".")[0] in ROS_PACKAGES)
    assert not ros, f"{module} imports {ros}: the core, config, contract, bag and sweep stay free of ROS"


def _cycle() -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(GRAPH[node]):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for start in sorted(GRAPH):
        if start not in state and (found := visit(start)):
            return found
    return None


def test_no_import_cycle_anywhere():
    assert _cycle() is None, " -> ".join(_cycle() or [])


def test_the_cycle_finder_finds_a_cycle():
    GRAPH["pmr_ros.core.sim.model"].add("pmr_ros.core.pmr.classic")  # classic imports foptd: a planted cycle
    try:
        assert _cycle() is not None
    finally:
        GRAPH["pmr_ros.core.sim.model"].discard("pmr_ros.core.pmr.classic")


def test_no_two_modules_share_a_file_name():
    """A file name says which module it is: ``plant.py`` twice makes a newcomer open the wrong one."""
    seen: dict[str, list[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        if path.name != "__init__.py":
            seen.setdefault(path.name, []).append(str(path.relative_to(PACKAGE)))
    twice = {name: paths for name, paths in seen.items() if len(paths) > 1}
    assert not twice, f"module file names used more than once: {twice}"


MAX_FUNCTION_LINES = 60
MAX_MODULE_LINES = 400


def _long_functions(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            lines = (node.end_lineno or node.lineno) - first + 1
            if lines > MAX_FUNCTION_LINES:
                out.append(f"{node.name} ({lines} lines)")
    return out


@pytest.mark.parametrize("module", sorted(MODULES))
def test_modules_and_functions_are_short(module):
    path = MODULES[module]
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_MODULE_LINES, f"{module}: {lines} lines, more than {MAX_MODULE_LINES}: split it by job"
    long = _long_functions(path)
    assert not long, f"{module}: functions over {MAX_FUNCTION_LINES} lines: {long}"


def test_the_size_check_finds_a_long_function(tmp_path):
    body = "\n".join(f"    x{j} = {j}" for j in range(MAX_FUNCTION_LINES))
    path = tmp_path / "long.py"
    path.write_text(f"def long():\n{body}\n")
    assert _long_functions(path) == [f"long ({MAX_FUNCTION_LINES + 1} lines)"]


ARCHITECTURE_PAGE = PACKAGE.parent / "docs" / "architecture.md"


def _drawn_layers() -> dict[str, set[str]]:
    """docs/architecture.md's table: each row of one layer and its "may import" cell of layer names."""
    drawn = {}
    for line in ARCHITECTURE_PAGE.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        names = re.findall(r"`pmr_ros/([\w.]+?)(?:/|\.py)`", cells[0]) if line.startswith("| `pmr_ros/") else []
        if len(names) != 1 or len(cells) < 3:
            continue
        may = cells[-1]
        if may.startswith("nothing"):
            drawn[names[0]] = set()
        elif re.fullmatch(r"[\w, ]+", may) and all(m.strip() in LAYERS for m in may.split(",")):
            drawn[names[0]] = {m.strip() for m in may.split(",")}
    return drawn


def test_the_architecture_page_draws_the_layers_this_test_holds():
    drawn = _drawn_layers()
    assert len(drawn) >= 15, f"too few layer rows read from {ARCHITECTURE_PAGE.name}: {sorted(drawn)}"
    wrong = {layer: (may, LAYERS[layer]) for layer, may in drawn.items() if LAYERS.get(layer) != may}
    assert not wrong, f"docs/architecture.md (drawn, held here) differs: {wrong}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_every_module_opens_with_its_job(module):
    doc = ast.get_docstring(ast.parse(MODULES[module].read_text(encoding="utf-8")))
    assert doc and len(doc.splitlines()[0]) > 10, f"{module}: no opening docstring saying its one job"
