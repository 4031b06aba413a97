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
from dataclasses import dataclass
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
from .curve_set import CurveSet

__all__ = ["LoadedModel", "import_params_text", "load_model", "read_curves", "relative_model_file", "to_curve_set"]

INDENT = "    "


def _element_lines(key: str, values: list[Any], labels: list[str]) -> list[str]:
    lines = [f"{INDENT}  {key}:"]
    for label, value in zip(labels, values, strict=True):
        text = repr(value) if isinstance(value, float) else str(value)
        lines.append(f"{INDENT}    - {text:<24s} # {label}")
    return lines


def import_params_text(curves: CurveSet, *, model_file: str, name: str, source: str) -> str:
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

    Returns
    -------
    str
    """
    n_out, n_in, n = curves.curves.shape
    shape = Shape(n_out, n_in)
    labels = [element_label(j, shape) for j in range(n_out * n_in)]
    flat = curves.curves.reshape(n_out * n_in, n)
    empty = ~np.any(flat != 0, axis=1)
    delays = [0.0 if e else dead_time_samples(c) * curves.sample_time for c, e in zip(flat, empty, strict=True)]
    lines = [
        f"# pmr-ros model import of {source}: {n_out} outputs x {n_in} inputs, step-response curves of {n} "
        "coefficients",
        "# The curves stay in model_file; gain (a ramp's rate per time unit) and delay are the file's, for reading.",
        "/**:",
        "  ros__parameters:",
        f"{INDENT}system:",
        f"{INDENT}  name: {json.dumps(name)}",
        f"{INDENT}  sample_time: {curves.sample_time!r}",
        f"{INDENT}  output_names: {json.dumps(list(curves.output_names))}",
        f"{INDENT}  input_names: {json.dumps(list(curves.input_names))}",
        f"{INDENT}  model_file: {json.dumps(model_file)}",
    ]
    lines += _element_lines(
        "gain", [0.0 if e else float(g) for g, e in zip(curves.gains.ravel(), empty, strict=True)], labels
    )
    lines += _element_lines("time_constant", [0.0] * len(labels), labels)
    lines += _element_lines("delay", delays, labels)
    lines += _element_lines("element_type", ["none" if e else "step_response" for e in empty], labels)
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
    """

    name: str
    sample_time: float
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    elements: tuple[tuple[Element, ...], ...]
    curves: CurveSet | None


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
        values[key] = spec.check(system.get(key, spec.default), source=str(path), shape=shape)
    return values


def _curve_source(path: Path, values: dict[str, Any]) -> CurveSet | None:
    if not np.any(values["element_type"] == "step_response"):
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


def _element(path: Path, values: dict[str, Any], curves: CurveSet | None, i: int, k: int) -> Element:
    n_in = len(values["input_names"])
    label = element_label(i * n_in + k, Shape(len(values["output_names"]), n_in))
    ts, kind = values["sample_time"], str(values["element_type"][i, k])
    whole = float(values["delay"][i, k]) / ts
    if kind != "none" and abs(whole - round(whole)) > 1e-9 * max(1.0, abs(whole)):
        raise ConfigError(
            path, f"system.delay[{i * n_in + k}] ({label})", float(values["delay"][i, k]), "must be whole samples"
        )
    curve = None
    if kind == "step_response" and curves is not None:
        io, ik = _pair(path, curves, values["output_names"][i], values["input_names"][k])
        curve = (curves.curves[io, ik], bool(curves.ramp[io, ik]))
    return cell_element(values, i, k, name=label, curve=curve)


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
    n_out, n_in = len(values["output_names"]), len(values["input_names"])
    try:
        elements = tuple(tuple(_element(path, values, curves, i, k) for k in range(n_in)) for i in range(n_out))
    except ElementError as exc:
        raise ConfigError(path, "system", None, str(exc)) from None
    names = (values["output_names"], values["input_names"])
    return LoadedModel(values["name"], values["sample_time"], *names, elements, curves)


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
    flat = [e for row in model.elements for e in row]
    source = model.curves
    n = n_coefficients or (source.n_coefficients if source is not None else max(e.settle_samples() for e in flat))
    for j, e in enumerate(flat):
        if not isinstance(e, Empty) and n <= e.delay_samples:
            label = element_label(j, Shape(len(model.output_names), len(model.input_names)))
            raise ElementError(
                f"{label}: curves of {n} coefficients are not longer than its delay of {e.delay_samples} samples"
            )
    curves = np.array([[e.step_response(n) for e in row] for row in model.elements])
    ramp = np.array([[e.integrating for e in row] for row in model.elements])
    if source is not None and source.ramp.shape == ramp.shape:  # an empty pair keeps the flag of its file
        empty = np.array([[isinstance(e, Empty) for e in row] for row in model.elements])
        ramp = np.where(empty, source.ramp, ramp)
    gains = np.array([[e.steady_state_gain for e in row] for row in model.elements])
    keep = source is not None and (source.output_names, source.input_names) == (model.output_names, model.input_names)
    return CurveSet(
        model.sample_time,
        model.output_names,
        model.input_names,
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
