"""Writing params files: a model (and the settings it runs with) as a ROS 2 params file people can read.

The ``system`` block is written one element per line, each with its name as a
comment, and a change note where a corrected model replaced the element; the
other blocks are plain YAML.  Floats are written with ``repr`` (lossless), so
the file reads back to the same model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..core.sim.model import TransferMatrix
from ..outputs import write_text
from .errors import ConfigError

__all__ = ["SIMULATION_TRUTH", "model_params_text", "system_tree", "write_params_file"]

SIMULATION_TRUTH = ("mismatch", "plant")
"""Blocks that describe a simulated plant, not the controller: never written into a model file."""

INDENT = "    "


UNIT_KEYS = ("output_units", "input_units", "disturbance_units", "time_unit")
"""The ``system`` block's units, kept in a corrected model's file."""


def system_tree(model: TransferMatrix) -> dict[str, Any]:
    """The ``system`` block of a model, row-major flat lists (delays in time units)."""
    tau = np.where(np.isnan(model.time_constant), 0.0, model.time_constant)
    return {
        "name": model.name,
        "sample_time": float(model.sample_time),
        "output_names": list(model.output_names),
        "input_names": list(model.input_names),
        "gain": [float(v) for v in model.gain.ravel()],
        "time_constant": [float(v) for v in tau.ravel()],
        "delay": [float(v) for v in model.delay.ravel()],
        "element_type": [str(v) for v in model.element_type.ravel()],
    }


def _scalar(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).strip().removesuffix("\n...").strip()


def _system_lines(model: TransferMatrix, notes: Mapping[str, str]) -> list[str]:
    tree = system_tree(model)
    names = model.element_names()
    lines = [f"{INDENT}system:"]
    for key in ("name", "sample_time", "output_names", "input_names"):
        lines.append(f"{INDENT}  {key}: {_scalar(tree[key])}")
    for key in ("gain", "time_constant", "delay", "element_type"):
        lines.append(f"{INDENT}  {key}:")
        for name, value in zip(names, tree[key], strict=True):
            note = f": {notes[name]}" if name in notes and key == "gain" else ""
            lines.append(f"{INDENT}    - {_scalar(value):<22s} # {name}{note}")
    return lines


def model_params_text(
    model: TransferMatrix,
    *,
    settings: Mapping[str, Any],
    header: Sequence[str] = (),
    notes: Mapping[str, str] | None = None,
) -> str:
    """A params file of ``model`` with the other blocks of ``settings`` (simulation truth left out).

    Parameters
    ----------
    model : TransferMatrix
        Written as the ``system`` block.
    settings : mapping
        A nested parameter tree (e.g. ``PmrConfig.parameters``); its blocks
        other than ``system`` and :data:`SIMULATION_TRUTH` follow the system.
    header : sequence of str
        Comment lines at the top.
    notes : mapping, optional
        Element name -> a change note, written beside its gain entry.

    Returns
    -------
    str
        The file's text.
    """
    lines = [f"# {line}" for line in header]
    lines += ["/**:", "  ros__parameters:", *_system_lines(model, notes or {})]
    # the measured disturbances' model is the controller's too: kept as it is
    dvs = {k: v for k, v in dict(settings.get("system", {})).items() if k.startswith("disturbance_") and v != []}
    if dvs.get("disturbance_names"):
        dumped = yaml.safe_dump(dvs, sort_keys=False, default_flow_style=None, width=120)
        lines += [f"{INDENT}  {line}" for line in dumped.splitlines()]
    # the units stay the system's: the corrected model's numbers are in them
    units = {k: v for k, v in dict(settings.get("system", {})).items() if k in UNIT_KEYS and v not in ([], "none")}
    if units:
        dumped = yaml.safe_dump(units, sort_keys=False, default_flow_style=None, width=120, allow_unicode=True)
        lines += [f"{INDENT}  {line}" for line in dumped.splitlines()]
    rest = {k: v for k, v in settings.items() if k != "system" and k not in SIMULATION_TRUTH}
    if rest:
        dumped = yaml.safe_dump(rest, sort_keys=False, default_flow_style=None, width=120)
        lines += [f"{INDENT}{line}" for line in dumped.splitlines()]
    return "\n".join(lines) + "\n"


def write_params_file(path: str | Path, text: str) -> None:
    """Write a params file.

    Raises
    ------
    ConfigError
        The file cannot be written (one line naming it).
    """
    try:
        write_text(path, text)  # atomic: a full disk leaves the previous file whole
    except OSError as exc:
        raise ConfigError(path, "<file>", None, f"cannot write: {exc.strerror or exc}") from None
