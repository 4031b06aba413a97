"""Writing params files: a model (and the settings it runs with) as a ROS 2 params file people can read.

The ``system`` block is written one element per line, each with its name as a
comment, and a change note where a corrected model replaced the element; the
other blocks are plain YAML.  Floats are written with ``repr`` (lossless), so
the file reads back to the same model.  A model of ``tf`` elements is written
with its ``numerator`` and ``denominator`` strings; one of ``step_response``
elements names its curve file (``model_file``), which :func:`write_curve_file`
writes beside the params file in the format of the file the model came from.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..core.sim.model import TransferMatrix
from ..core.sim.rational import TransferFunction
from ..outputs import write_text
from .errors import ConfigError

__all__ = [
    "SIMULATION_TRUTH",
    "configured_system_tree",
    "curve_file_path",
    "model_params_text",
    "system_tree",
    "tf_strings",
    "write_curve_file",
    "write_params_file",
]

SIMULATION_TRUTH = ("mismatch", "plant")
"""Blocks that describe a simulated plant, not the controller: never written into a model file."""

INDENT = "    "


UNIT_KEYS = ("output_units", "input_units", "disturbance_units", "time_unit")
"""The ``system`` block's units, kept in a corrected model's file."""


def tf_strings(model: TransferMatrix) -> tuple[list[str], list[str]]:
    """``system.numerator`` and ``system.denominator`` of a model: each tf element's coefficients, '' elsewhere.

    Coefficients in descending powers of s, written with ``repr`` (lossless).
    """
    numerator, denominator = [], []
    for row in model.element_rows():
        for element in row:
            if isinstance(element, TransferFunction):
                numerator.append(", ".join(map(repr, element.numerator)))
                denominator.append(", ".join(map(repr, element.denominator)))
            else:
                numerator.append("")
                denominator.append("")
    return numerator, denominator


def system_tree(model: TransferMatrix, *, model_file: str = "") -> dict[str, Any]:
    """The ``system`` block of a model, row-major flat lists (delays in time units).

    Parameters
    ----------
    model : TransferMatrix
        The model; its ``tf`` elements add ``numerator`` and ``denominator``.
    model_file : str
        ``system.model_file``, written when the model has ``step_response`` elements or it is given
        (the curves of step_response DV elements).
    """
    tau = np.where(np.isnan(model.time_constant), 0.0, model.time_constant)
    extra: dict[str, Any] = {}
    if np.any(model.element_type == "tf"):
        extra["numerator"], extra["denominator"] = tf_strings(model)
    if model_file or np.any(model.element_type == "step_response"):
        extra["model_file"] = model_file
    return {
        "name": model.name,
        "sample_time": float(model.sample_time),
        "output_names": list(model.output_names),
        "input_names": list(model.input_names),
        "gain": [float(v) for v in model.gain.ravel()],
        "time_constant": [float(v) for v in tau.ravel()],
        "delay": [float(v) for v in model.delay.ravel()],
        "element_type": [str(v) for v in model.element_type.ravel()],
        **extra,
    }


def configured_system_tree(model: TransferMatrix, parameters: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`system_tree` of ``model`` naming the curve file of the parameter tree ``parameters`` (its ``system``)."""
    return system_tree(model, model_file=str(dict(parameters.get("system", {})).get("model_file", "")))


def _scalar(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).strip().removesuffix("\n...").strip()


def _system_lines(model: TransferMatrix, notes: Mapping[str, str], model_file: str) -> list[str]:
    tree = system_tree(model, model_file=model_file)
    names = model.element_names()
    lines = [f"{INDENT}system:"]
    for key in ("name", "sample_time", "output_names", "input_names", "model_file"):
        if key in tree:
            lines.append(f"{INDENT}  {key}: {_scalar(tree[key])}")
    for key in ("gain", "time_constant", "delay", "element_type", "numerator", "denominator"):
        if key not in tree:
            continue
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
    model_file: str = "",
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
    model_file : str
        ``system.model_file`` of a model with ``step_response`` elements
        (:func:`write_curve_file` writes it).

    Returns
    -------
    str
        The file's text.
    """
    lines = [f"# {line}" for line in header]
    lines += ["/**:", "  ros__parameters:", *_system_lines(model, notes or {}, model_file)]
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


def curve_file_path(params_path: str | Path, original: str) -> Path:
    """Where a written model's curves go: beside its params file, in the format (suffix) of ``original``.

    Examples
    --------
    >>> curve_file_path("/out/corrected.yaml", "/plant/unit.mdl").as_posix()
    '/out/corrected.mdl'
    """
    suffix = Path(original).suffix.lower() if Path(original).suffix.lower() in (".mdl", ".csv") else ".mdl"
    return Path(params_path).with_suffix(suffix)


def write_curve_file(model: TransferMatrix, path: str | Path, *, original: str = "") -> None:
    """Every element of ``model`` as a step-response curve, written as ``.mdl`` or ``.csv`` by ``path``'s suffix.

    The curves are as long as the longest of the model's ``step_response``
    elements (a slower corrected curve is longer than the file's); names,
    units and comment carry over from the ``original`` curve file when it reads.

    Raises
    ------
    ConfigError
        The file cannot be written (one line naming it).
    """
    from ..models import LoadedModel, ModelFileError, read_curves, to_curve_set, write_csv_curves, write_mdl

    rows = model.element_rows()
    longest = max(len(e.curve) for row in rows for e in row if e.kind == "step_response")  # type: ignore[attr-defined]
    try:
        source = read_curves(original) if original else None
    except ModelFileError:
        source = None
    names = (model.output_names, model.input_names)
    loaded = LoadedModel(model.name, model.sample_time, *names, tuple(tuple(row) for row in rows), source)
    curves = to_curve_set(loaded, max(longest, source.n_coefficients if source is not None else 0))
    try:
        (write_mdl if Path(path).suffix.lower() == ".mdl" else write_csv_curves)(curves, path)
    except ModelFileError as exc:
        raise ConfigError(path, "<file>", None, str(exc)) from None
