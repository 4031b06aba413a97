"""Configuration: ROS 2 params files checked against one declaration, into the core's typed settings.

``schema`` reads the declaration (``config/parameters.yaml``: every default,
range and meaning), ``files`` reads params files, ``build`` turns a parameter
tree into a :class:`PmrConfig` (``pmr_config``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..resources import share_dir
from .build import check_tree, parse_config
from .data import DataSettings
from .errors import ConfigError
from .files import flatten_parameters, nested, read_parameter_file
from .pmr_config import DiagnosticianSettings, PmrConfig, RunSettings, SimulationSettings
from .schema import SCHEMA_FILE

__all__ = [
    "DEFAULT_SYSTEM",
    "ConfigError",
    "DataSettings",
    "DiagnosticianSettings",
    "PmrConfig",
    "RunSettings",
    "SimulationSettings",
    "check_tree",
    "config_dir",
    "flatten_parameters",
    "load_config",
    "nested",
    "parse_config",
    "read_parameter_file",
]

DEFAULT_SYSTEM = "wood_berry.yaml"
"""The system ``pmr-ros`` runs when no ``--config`` is given (the reference case)."""

COMMAND_LINE = "command line"
"""The source named for values given as command-line options."""


def config_dir() -> Path:
    """The folder with the shipped configuration files (see :func:`pmr_ros.resources.share_dir`)."""
    return share_dir("config", SCHEMA_FILE)


def _lay_over(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = {block: dict(values) if isinstance(values, Mapping) else values for block, values in base.items()}
    for block, values in over.items():
        if isinstance(values, Mapping) and isinstance(out.get(block), dict):
            out[block].update(values)
        else:
            out[block] = dict(values) if isinstance(values, Mapping) else values
    return out


def load_config(path: str | Path | None = None, overrides: Mapping[str, Mapping[str, Any]] | None = None) -> PmrConfig:
    """Load and check a params file; what it leaves out takes the declared defaults.

    Parameters
    ----------
    path : str or Path, optional
        A ROS 2 params file with at least the ``system`` block; default: the
        shipped Wood-Berry column.
    overrides : mapping, optional
        Nested values applied last (command-line options); errors in them name
        the command line, not the file.

    Raises
    ------
    ConfigError
        With the file (or command line), field and value that are wrong.
    """
    path = Path(path) if path is not None else config_dir() / DEFAULT_SYSTEM
    tree = read_parameter_file(path)
    sources = {}
    if overrides:
        check_tree(overrides, COMMAND_LINE)
        tree = _lay_over(check_tree(tree, str(path)), overrides)
        sources = {f"{block}.{key}": COMMAND_LINE for block, values in overrides.items() for key in values}
    return parse_config(tree, str(path), sources=sources)
