"""The model params file (``system`` block) of any element type: written from curves, read into elements.

``pmr-ros model import`` writes a params file whose ``system`` block names the
curve file (``system.model_file``) and makes every pair with a curve a
``step_response`` element; ``pmr-ros model export`` reads a ``system`` block
of any element types (``foptd``, ``integrating``, ``none``, ``tf``,
``step_response``) and samples every element into a curve.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config.errors import ConfigError
from ..config.files import read_parameter_file
from ..config.schema import Shape, blocks, closest_name, element_label, parameter
from ..core.sim.elements import cell_element
from ..core.sim.lti import Element, ElementError, Empty
from ..core.sim.step_curve import dead_time_samples
from .curve_files import read_curves
from .curve_set import CurveSet, ModelFileError

__all__ = ["LoadedModel", "import_params_text", "load_model", "read_curves", "relative_model_file", "to_curve_set"]

INDENT = "    "


def _element_lines(key: str, values: list[Any], labels: list[str]) -> list[str]:
    lines = [f"{INDENT}  {key}:"]
    for label, value in zip(labels, values, strict=True):
        text = repr(value) if isinstance(value, float) else str(value)
        lines.append(f"{INDENT}    - {text:<24s} # {label}")
    return lines


def _curve_lines(curves: CurveSet, columns: list[int], labels: list[str], prefix: str = "") -> list[str]:
    """The element fields of the independents ``columns``: step_response per curve, none where it is all zeros."""
    picked = curves.curves[:, columns, :]
    flat = picked.reshape(-1, picked.shape[2])
    empty = ~np.any(flat != 0, axis=1)
    delays = [0.0 if e else dead_time_samples(c) * curves.sample_time for c, e in zip(flat, empty, strict=True)]
    gains = curves.gains[:, columns].ravel()
    lines = _element_lines(f"{prefix}gain", [0.0 if e else float(g) for g, e in zip(gains, empty, strict=True)], labels)
    lines += _element_lines(f"{prefix}time_constant", [0.0] * len(labels), labels)
    lines += _element_lines(f"{prefix}delay", delays, labels)
    return lines + _element_lines(f"{prefix}element_type", ["none" if e else "step_response" for e in empty], labels)


def import_params_text(
    curves: CurveSet, *, model_file: str, name: str, source: str, disturbances: tuple[str, ...] = ()
) -> str:
    """The params file of a model held as curves: ``step_response`` elements, ``none`` where a curve is all zeros.

    Parameters
    ----------
    curves : CurveSet
        The model.
    model_file : str
        ``system.model_file``: the curve file, relative to the params file.
    name : str
        ``system.name``.
    source : str
        Where the curves came from, for the header comment.
    disturbances : tuple of str
        Independents of the file that are measured disturbances (DMCplus
        feedforward variables): ``system.disturbance_names`` with their D
        elements; the other independents are the MVs.

    Returns
    -------
    str

    Raises
    ------
    ModelFileError
        A disturbance that is no independent of the file, or every independent a disturbance.
    """
    n_out, _, n = curves.curves.shape
    for dv in disturbances:
        if dv not in curves.input_names:
            raise ModelFileError(
                f"{source}: {dv!r} is no independent of the file (it has {', '.join(curves.input_names)})"
            )
    mvs = [k for k, tag in enumerate(curves.input_names) if tag not in disturbances]
    if not mvs:
        raise ModelFileError(f"{source}: every independent is a disturbance: the model needs at least one MV")
    dvs = [curves.input_names.index(tag) for tag in disturbances]
    shape = Shape(n_out, len(mvs), len(dvs))
    lines = [
        f"# pmr-ros model import of {source}: {n_out} outputs x {len(mvs)} inputs"
        + (f" and {len(dvs)} measured disturbances" if dvs else "")
        + f", step-response curves of {n} coefficients",
        "# The curves stay in model_file; gain (a ramp's rate per time unit) and delay are the file's, for reading.",
        "/**:",
        "  ros__parameters:",
        f"{INDENT}system:",
        f"{INDENT}  name: {json.dumps(name)}",
        f"{INDENT}  sample_time: {curves.sample_time!r}",
        f"{INDENT}  output_names: {json.dumps(list(curves.output_names))}",
        f"{INDENT}  input_names: {json.dumps([curves.input_names[k] for k in mvs])}",
        f"{INDENT}  model_file: {json.dumps(model_file)}",
    ]
    lines += _curve_lines(curves, mvs, [element_label(j, shape) for j in range(n_out * len(mvs))])
    if dvs:
        lines.append(f"{INDENT}  disturbance_names: {json.dumps(list(disturbances))}")
        labels = [element_label(j, shape, "disturbance_elements") for j in range(n_out * len(dvs))]
        lines += _curve_lines(curves, dvs, labels, "disturbance_")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class LoadedModel:
    """A model params file's elements.

    Attributes
    ----------
    name : str
    sample_time : float
        Ts [time unit].
    output_names, input_names : tuple of str
    elements : tuple of tuple of Element
        Row-major, ``elements[i][k]`` from input k to output i.
    curves : CurveSet or None
        The curve file (``system.model_file``), if any.
    disturbance_names : tuple of str
        The measured disturbances (``system.disturbance_names``).
    disturbance_elements : tuple of tuple of Element
        Row-major, ``[i][k]`` from DV k to output i (empty without DVs).
    """

    name: str
    sample_time: float
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    elements: tuple[tuple[Element, ...], ...]
    curves: CurveSet | None
    disturbance_names: tuple[str, ...] = ()
    disturbance_elements: tuple[tuple[Element, ...], ...] = ()

    @property
    def independents(self) -> tuple[str, ...]:
        """The MVs, then the DVs: the independents of a curve file."""
        return (*self.input_names, *self.disturbance_names)

    @property
    def rows(self) -> tuple[tuple[Element, ...], ...]:
        """Per output, its MV elements then its DV elements (the columns of :attr:`independents`)."""
        if not self.disturbance_names:
            return self.elements
        return tuple((*g, *d) for g, d in zip(self.elements, self.disturbance_elements, strict=True))


def _system_values(path: Path) -> dict[str, Any]:
    tree = read_parameter_file(path)
    system = tree.get("system")
    if not isinstance(system, dict):
        raise ConfigError(path, "system", None, "missing: a model file needs a system block")
    known = [p.name.split(".", 1)[1] for p in blocks()["system"].parameters]
    for key in system:
        if key not in known:
            hint = closest_name(key, known)
            raise ConfigError(path, f"system.{key}", None, "unknown" + (f"; did you mean {hint}?" if hint else ""))
    names = {}
    for key in ("output_names", "input_names", "sample_time"):
        if key not in system:
            raise ConfigError(path, f"system.{key}", None, "missing")
        names[key] = parameter(f"system.{key}").check(system[key], source=str(path))
    dvs = parameter("system.disturbance_names").check(system.get("disturbance_names", []), source=str(path))
    shape = Shape(len(names["output_names"]), len(names["input_names"]), len(dvs))
    values = dict(names)
    for key in known:
        spec = parameter(f"system.{key}")
        if key in names:
            continue
        if key not in system and spec.required:
            raise ConfigError(path, f"system.{key}", None, "missing")
        if key not in system and spec.default == [] and spec.kind == "matrix":  # a DV gain left out: 0 each
            values[key] = np.zeros((shape.n_outputs, shape.columns(spec.per)))
            continue
        values[key] = spec.check(system.get(key, spec.default), source=str(path), shape=shape)
    return values


def _curve_source(path: Path, values: dict[str, Any]) -> CurveSet | None:
    if not any(np.any(values[key] == "step_response") for key in ("element_type", "disturbance_element_type")):
        return None
    if not values["model_file"]:
        raise ConfigError(path, "system.model_file", None, "missing: step_response elements read their curves there")
    curves = read_curves(path.parent / values["model_file"])
    if not np.isclose(curves.sample_time, values["sample_time"], rtol=1e-9, atol=0.0):
        raise ConfigError(
            path,
            "system.sample_time",
            values["sample_time"],
            f"differs from the sample time {curves.sample_time:g} of model_file {values['model_file']}",
        )
    return curves


def _pair(path: Path, curves: CurveSet, output: str, input_: str) -> tuple[int, int]:
    for what, name, names in (("output", output, curves.output_names), ("input", input_, curves.input_names)):
        if name not in names:
            raise ConfigError(path, "system.model_file", None, f"has no {what} {name!r} (it has {', '.join(names)})")
    return curves.output_names.index(output), curves.input_names.index(input_)


ELEMENT_FIELDS = ("element_type", "gain", "time_constant", "delay", "numerator", "denominator")
"""A block's per-element fields; ``disturbance_`` before each: the DV elements'."""


def _element(
    path: Path, values: dict[str, Any], curves: CurveSet | None, cell: tuple[int, int], prefix: str
) -> Element:
    """Element ``cell`` of the MVs' fields, or (``prefix="disturbance_"``) of the DVs'."""
    (i, k), per = cell, "disturbance_elements" if prefix else ""
    columns = values["disturbance_names" if prefix else "input_names"]
    fields = {key: values[f"{prefix}{key}"] for key in ELEMENT_FIELDS} | {"sample_time": values["sample_time"]}
    j = i * len(columns) + k
    label = element_label(j, Shape(len(values["output_names"]), len(values["input_names"]), len(columns)), per)
    ts, kind = values["sample_time"], str(fields["element_type"][i, k])
    whole = float(fields["delay"][i, k]) / ts
    if kind != "none" and abs(whole - round(whole)) > 1e-9 * max(1.0, abs(whole)):
        raise ConfigError(
            path, f"system.{prefix}delay[{j}] ({label})", float(fields["delay"][i, k]), "must be whole samples"
        )
    curve = None
    if kind == "step_response" and curves is not None:
        io, ik = _pair(path, curves, values["output_names"][i], columns[k])
        curve = (curves.curves[io, ik], bool(curves.ramp[io, ik]))
    return cell_element(fields, i, k, name=label, curve=curve)


def load_model(path: str | Path) -> LoadedModel:
    """The elements of a model params file, of any element type.

    Raises
    ------
    ConfigError
        A missing, unknown or bad field (one line naming the file and field).
    ModelFileError
        The curve file does not read.
    """
    path = Path(path)
    values = _system_values(path)
    curves = _curve_source(path, values)
    n_out, n_in, n_dv = (len(values[key]) for key in ("output_names", "input_names", "disturbance_names"))
    try:
        elements, disturbance = (
            tuple(tuple(_element(path, values, curves, (i, k), prefix) for k in range(n)) for i in range(n_out))
            for n, prefix in ((n_in, ""), (n_dv, "disturbance_"))
        )
    except ElementError as exc:
        raise ConfigError(path, "system", None, str(exc)) from None
    names = (values["output_names"], values["input_names"])
    loaded = LoadedModel(values["name"], values["sample_time"], *names, elements, curves)
    return replace(
        loaded, disturbance_names=values["disturbance_names"], disturbance_elements=disturbance if n_dv else ()
    )


def to_curve_set(model: LoadedModel, n_coefficients: int | None = None) -> CurveSet:
    """Every element of ``model`` sampled into a curve of N coefficients.

    Parameters
    ----------
    model : LoadedModel
        The model.
    n_coefficients : int, optional
        N; default: that of the model's curve file, else enough for every
        element to settle (:meth:`Element.settle_samples`).

    Returns
    -------
    CurveSet
        Gains are the elements' steady-state gains (a ramp's rate per time
        unit); names, units and comment of the curve file carry over.

    Raises
    ------
    ElementError
        N not longer than an element's delay (one line naming it).
    """
    rows = model.rows
    flat = [e for row in rows for e in row]
    source = model.curves
    n = n_coefficients or (source.n_coefficients if source is not None else max(e.settle_samples() for e in flat))
    for j, e in enumerate(flat):
        if not isinstance(e, Empty) and n <= e.delay_samples:
            label = element_label(j, Shape(len(model.output_names), len(model.independents)))
            raise ElementError(
                f"{label}: curves of {n} coefficients are not longer than its delay of {e.delay_samples} samples"
            )
    curves = np.array([[e.step_response(n) for e in row] for row in rows])
    ramp = np.array([[e.integrating for e in row] for row in rows])
    if source is not None and source.ramp.shape == ramp.shape:  # an empty pair keeps the flag of its file
        empty = np.array([[isinstance(e, Empty) for e in row] for row in rows])
        ramp = np.where(empty, source.ramp, ramp)
    gains = np.array([[e.steady_state_gain for e in row] for row in rows])
    keep = source is not None and (source.output_names, source.input_names) == (model.output_names, model.independents)
    return CurveSet(
        model.sample_time,
        model.output_names,
        model.independents,
        curves,
        ramp,
        gains,
        output_units=source.output_units if keep and source else (),
        input_units=source.input_units if keep and source else (),
        comment=source.comment if keep and source else f"pmr-ros model export of {model.name or 'a model'}",
        extras=source.extras if keep and source else None,
    )


def relative_model_file(curve_file: str | Path, params_file: str | Path) -> str:
    """``curve_file`` as ``system.model_file`` of ``params_file``: relative to the params file's folder."""
    start = Path(params_file).resolve().parent
    return os.path.relpath(Path(curve_file).resolve(), start)
