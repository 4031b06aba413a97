"""Reading ROS 2 params files: text checks, one fast YAML parse, the ``ros__parameters`` tree.

A pmr_ros configuration is a standard ROS 2 parameter file: everything sits
under ``/**: ros__parameters:`` (or one node's section), so one file configures
every node and the batch core alike.  Matrices are row-major flat lists (ROS
parameters have no nested arrays).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError
from .fast_yaml import load as load_yaml_text
from .yaml_guard import DocumentError

__all__ = [
    "check_parameter_files",
    "flatten_parameters",
    "load_yaml",
    "nested",
    "params_tree",
    "read_parameter_file",
    "yaml_text",
]


def yaml_text(path: Path) -> str:
    """The text of a YAML file, or one :class:`ConfigError` line saying why it cannot be read.

    Raises
    ------
    ConfigError
        The file is missing or unreadable, or not UTF-8 (with the byte offset).
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ConfigError(path, "<file>", None, f"cannot read: {exc.strerror or exc}") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise ConfigError(
            path, "<file>", None, f"not UTF-8 text: byte 0x{data[exc.start]:02x} on line {line}; save the file as UTF-8"
        ) from None


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """A YAML error as one line: what and where (libyaml's message spans several)."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    return f"not valid YAML: {' '.join(str(problem).split())}{where}"


def load_yaml(path: Path) -> Any:
    """The document of a YAML file, parsed once with libyaml's safe loader (:mod:`.fast_yaml`).

    Raises
    ------
    ConfigError
        Unreadable, not UTF-8 or not valid YAML; one line.
    """
    text = yaml_text(path)
    try:
        return load_yaml_text(text)
    except DocumentError as exc:
        field = exc.field.removeprefix("/**.").removeprefix("ros__parameters.")
        raise ConfigError(path, field, None, exc.located(str(path))) from None
    except yaml.YAMLError as exc:
        raise ConfigError(path, "<file>", None, _yaml_problem(exc)) from None


def params_tree(doc: Any, source: str | Path) -> dict[str, Any]:
    """The ``ros__parameters`` mapping of a params document.

    Accepts the wildcard section ``/**`` or a single node section.

    Raises
    ------
    ConfigError
        The document is not a params file.
    """
    if not isinstance(doc, dict):
        raise ConfigError(source, "<file>", None, f"expected a ROS 2 params file (a mapping), got {type(doc).__name__}")
    wildcard = doc.get("/**")
    sections = [v for v in doc.values() if isinstance(v, dict) and "ros__parameters" in v]
    if isinstance(wildcard, dict) and "ros__parameters" in wildcard:
        params = wildcard["ros__parameters"]
    elif len(sections) == 1:
        params = sections[0]["ros__parameters"]
    else:
        raise ConfigError(
            source, "/**.ros__parameters", None, "missing: put the parameters under '/**: ros__parameters:'"
        )
    if not isinstance(params, dict):
        raise ConfigError(source, "ros__parameters", params, "must be a mapping of parameter blocks")
    return params


def read_parameter_file(path: str | Path) -> dict[str, Any]:
    """The ``ros__parameters`` of a params file as a nested dict (parsed once).

    Raises
    ------
    ConfigError
        One line naming the file and what is wrong.
    """
    path = Path(path)
    return params_tree(load_yaml(path), path)


def check_parameter_files(args: list[str]) -> None:
    """Read every ``--params-file FILE`` of a ROS command line as pmr_ros reads a config.

    rcl's own parser keeps the last of two equal keys and expands aliases
    without a bound; a node checks its files first so that a duplicate key or
    an alias bomb is one line, as on ``pmr-ros``.

    Raises
    ------
    ConfigError
        The first file that cannot be read or is refused.
    """
    for i, arg in enumerate(args):
        if arg == "--params-file" and i + 1 < len(args):
            load_yaml(Path(args[i + 1]))


def flatten_parameters(tree: dict, prefix: str = "") -> dict[str, Any]:
    """Nested parameter dict to ROS 2 dotted names (``system.gain``).

    Examples
    --------
    >>> flatten_parameters({"mpc": {"control_horizon": 8}})
    {'mpc.control_horizon': 8}
    """
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten_parameters(value, name + "."))
        else:
            flat[name] = value
    return flat


def nested(flat: dict[str, Any]) -> dict[str, Any]:
    """Dotted names to a nested tree (the inverse of :func:`flatten_parameters`).

    Examples
    --------
    >>> nested({"mpc.control_horizon": 8})
    {'mpc': {'control_horizon': 8}}
    """
    tree: dict[str, Any] = {}
    for name, value in flat.items():
        node = tree
        parts = name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return tree
