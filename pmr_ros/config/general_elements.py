"""The ``tf`` and ``step_response`` elements of a ``system`` or ``plant`` block, built and checked in one line each.

A block with such elements (``element_type`` ``tf``: ``numerator`` and
``denominator`` strings; ``step_response``: a curve of ``model_file``) becomes
a :class:`~pmr_ros.core.sim.model.TransferMatrix` of elements
(:meth:`~pmr_ros.core.sim.model.TransferMatrix.of_elements`), every element
built by :func:`~pmr_ros.core.sim.elements.build_element`.  ``model_file`` is
relative to the params file that names it; the parameter tree keeps it as an
absolute path, so the nodes and a written model find the same file.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..core.sim.elements import cell_element
from ..core.sim.lti import Element, ElementError
from ..core.sim.model import TransferMatrix
from .errors import ConfigError
from .schema import Shape, element_label

__all__ = ["GENERAL_KINDS", "BlockFields", "block_elements", "block_numbers", "general_matrix", "model_file_path"]

GENERAL_KINDS = ("tf", "step_response")
"""Element types built as elements (not from gain, time constant and delay arrays)."""

BlockFields = dict[str, Any]
"""The checked values of a block: ``element_type``, ``gain``, ``time_constant``, ``delay`` (arrays),
``numerator``, ``denominator`` (string arrays), ``model_file`` (str)."""

ErrorMaker = Callable[[str, Any, str], ConfigError]


def model_file_path(model_file: str, source: str) -> Path:
    """``model_file`` as a path: absolute as given, else relative to the params file ``source`` (or the folder run in).

    Examples
    --------
    >>> model_file_path("curves.mdl", "/plant/unit.yaml").as_posix()
    '/plant/curves.mdl'
    """
    path = Path(model_file).expanduser()
    if path.is_absolute():
        return path
    base = Path(source)
    return (base.parent if base.suffix.lower() in (".yaml", ".yml") else Path.cwd()) / path


def _curves(block: str, fields: BlockFields, source: str, error: ErrorMaker, given: Any = None) -> Any:
    """The curve file of the block's step_response elements (``given``: its curves, not read), or None."""
    if not np.any(fields["element_type"] == "step_response"):
        return None
    from ..models.curve_files import read_curves
    from ..models.curve_set import ModelFileError

    if not fields["model_file"]:
        raise error(f"{block}.model_file", None, "missing: step_response elements read their curves there")
    try:
        curves = given if given is not None else read_curves(model_file_path(fields["model_file"], source))
    except ModelFileError as exc:
        raise error(f"{block}.model_file", fields["model_file"], str(exc)) from None
    if not np.isclose(curves.sample_time, fields["sample_time"], rtol=1e-9, atol=0.0):
        raise error(
            f"{block}.model_file",
            fields["model_file"],
            f"its sample time {curves.sample_time:g} differs from system.sample_time {fields['sample_time']:g}",
        )
    return curves


def _curve(block: str, curves: Any, names: tuple[str, str], error: ErrorMaker) -> tuple[list[float], bool]:
    """The curve and ramp flag of the pair (output, input) ``names`` in the curve file."""
    where = []
    for what, name, known in zip(("output", "input"), names, (curves.output_names, curves.input_names), strict=True):
        if name not in known:
            raise error(f"{block}.model_file", None, f"has no {what} {name!r} (it has {', '.join(known)})")
        where.append(known.index(name))
    io, ik = where
    return curves.curves[io, ik].tolist(), bool(curves.ramp[io, ik])


def _element_error(
    block: str, j: int, label: str, fields: BlockFields, exc: ElementError, *, prefix: str = ""
) -> tuple[str, Any, str]:
    """``(field, value, reason)`` of an element that does not build: the field the message is about."""
    i, k = divmod(j, fields["element_type"].shape[1])
    reason = str(exc).removeprefix(f"{label}: ")
    kind = fields["element_type"][i, k]
    if kind == "step_response":
        return f"{block}.{prefix}delay[{j}] ({label})", float(fields["delay"][i, k]), f"{reason} (model_file)"
    key = "denominator" if reason.startswith(("denominator", "unstable")) else "numerator"
    return f"{block}.{prefix}{key}[{j}] ({label})", str(fields[key][i, k]), reason


def general_matrix(
    fields: BlockFields,
    *,
    block: str,
    names: tuple[tuple[str, ...], tuple[str, ...], str],
    source: str,
    error: ErrorMaker,
    prefix: str = "",
    curves: Any = None,
) -> TransferMatrix:
    """The block's elements of any type as a :class:`TransferMatrix` (delays checked whole before).

    Parameters
    ----------
    fields : dict
        The block's checked values (:data:`BlockFields`) and ``sample_time``.
    block : str
        ``system`` or ``plant``, for messages.
    names : (output_names, input_names, name)
        The channels and the system's name.
    source : str
        The params file (``model_file`` is relative to it).
    error : callable
        ``error(field, value, reason)`` -> the :class:`ConfigError` to raise.
    prefix : str
        ``disturbance_``: the block's DV elements (``D11`` ..., fields ``disturbance_numerator`` ...);
        their curves are the pairs (CV, DV) of the same ``model_file``.
    curves : CurveSet, optional
        The curves of ``model_file`` already read (a bag's embedded copy): the file is not read.

    Raises
    ------
    ConfigError
        One line: a tf string that does not parse, an improper or unstable tf,
        a curve file that does not read or lacks a pair, a curve shorter than its delay.
    """
    outputs, inputs, name = names
    kinds, ts = fields["element_type"], float(fields["sample_time"])
    shape = Shape(kinds.shape[0], kinds.shape[1], kinds.shape[1])
    per = "disturbance_elements" if prefix else ""
    curves = _curves(block, fields, source, error, curves)
    rows: list[list[Element]] = []
    for i in range(kinds.shape[0]):
        rows.append([])
        for k in range(kinds.shape[1]):
            j = i * kinds.shape[1] + k
            label = element_label(j, shape, per)
            curve = None if kinds[i, k] != "step_response" else _curve(block, curves, (outputs[i], inputs[k]), error)
            try:
                rows[i].append(cell_element(fields, i, k, name=label, curve=curve))
            except ElementError as exc:
                raise error(*_element_error(block, j, label, fields, exc, prefix=prefix)) from None
    return TransferMatrix.of_elements(rows, sample_time=ts, output_names=outputs, input_names=inputs, name=name)


class _Values(Protocol):
    """What :mod:`.build` gives: checked values by dotted name, the effective tree, sources and errors."""

    tree: dict[str, dict[str, Any]]
    curve_sets: Mapping[str, Any]

    def __getitem__(self, name: str) -> Any: ...

    def source_of(self, name: str) -> str: ...

    def error(self, name: str, value: Any, reason: str) -> ConfigError: ...


def block_numbers(v: _Values, name: str, kinds: np.ndarray) -> np.ndarray:
    """A gain or time-constant matrix; zeros when left out of a block of tf, step_response and empty elements alone.

    A DV gain left at its declared ``[]`` counts as left out.
    """
    block, key = name.split(".", 1)
    given = v.tree.get(block, {}).get(key, [])
    if (isinstance(given, list) and not given) and not np.isin(kinds, ("foptd", "integrating")).any():
        return np.zeros(kinds.shape)
    return np.asarray(v[name], dtype=float)


def block_elements(
    v: _Values,
    block: str,
    fields: BlockFields,
    *,
    names: tuple[tuple[str, ...], tuple[str, ...], str],
    prefix: str = "",
) -> TransferMatrix:
    """:func:`general_matrix` of ``block`` (its ``numerator``, ``denominator`` and ``model_file`` read here).

    ``prefix="disturbance_"``: the DV elements (``disturbance_numerator`` ...,
    the same ``model_file``).  ``v.curve_sets`` may hold the curves of
    ``block.model_file`` already (a bag's embedded copy).  The tree's ``model_file`` becomes the absolute
    path of the file read, so the nodes and a written model read the same file
    wherever they run.
    """
    for key in ("numerator", "denominator"):
        fields[key] = v[f"{block}.{prefix}{key}"]
    fields["model_file"] = v[f"{block}.model_file"]
    fields["sample_time"] = v["system.sample_time"]
    source = v.source_of(f"{block}.model_file")
    given = v.curve_sets.get(f"{block}.model_file")
    model = general_matrix(fields, block=block, names=names, source=source, error=v.error, prefix=prefix, curves=given)
    if fields["model_file"]:
        v.tree[block]["model_file"] = str(model_file_path(fields["model_file"], source).resolve())
    return model
