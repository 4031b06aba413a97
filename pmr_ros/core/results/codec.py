"""The one place a result is spelled flat: JSON, /diagnostics KeyValues, the estimates message, the sweep CSV row.

One spelling in every form: a field of the result objects is named by its
dotted path (``parametric.gain_mismatch_pct``, ``model.gain``,
``parametric.quality.coherence``, ``data_quality.warnings``); an interval
(``gain_mismatch_pct_interval`` of the objects) is always the two fields
``gain_mismatch_pct_low`` and ``gain_mismatch_pct_high`` [same unit as the
estimate]; texts (reasons, warnings) are lists; a part that is absent is
None (``classic: null``); each method's part also carries its derived
``verdict`` (never read back).

* JSON (:func:`diagnosis_to_json`): the paths nested, plus the element's ``summary``.
* KeyValues (:func:`status_key_values`): the paths flat, each value a string:
  text as it is, anything else JSON (floats as their shortest round-tripping
  ``repr``: lossless), plus the diagnosis-wide ``status``, ``reason``, window
  and ``impact_all.*``.  rclpy messages are built by :mod:`pmr_ros.ros.convert`.
* Estimates (:func:`estimate_names_values`): ``<element>/<path>`` of every
  number (NaN where there is none), so every message of a run has the same names.
* CSV (:func:`csv_fields`): the fields of the element's verdict method,
  unprefixed (the row's ``method`` column names the method).

Decoding reads every form back to the objects, and reads the spellings of
earlier versions (:func:`element_from_json`): intervals as ``[low, high]``
lists (``..._interval``) and the flat statuses and reports of pmr_ros 0.1
(``gain_ratio`` at the top of an element), which the reference bag holds.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import fields
from typing import Any

from .findings import ClassicResult, DataQuality, ElementModel, ImpactResult, ParametricResult
from .legacy import element_from_v01, status_from_v01
from .matrix import Diagnosis, ElementDiagnosis, Part
from .plain import HIGH, INTERVAL, LOW, part_plain, plain

__all__ = [
    "CSV_FIELDS",
    "IMPACT_KEY",
    "STATUS_KEYS",
    "WINDOW_KEYS",
    "csv_fields",
    "decode_value",
    "diagnosis_from_json",
    "diagnosis_from_key_values",
    "diagnosis_to_json",
    "element_from_json",
    "element_key_values",
    "element_to_json",
    "encode_value",
    "estimate_fields",
    "estimate_names_values",
    "estimates_from_names_values",
    "result_from_csv_fields",
    "status_key_values",
]

WINDOW_KEYS = ("window_samples", "first_sample", "last_sample")
"""KeyValues of the diagnosed window [samples]."""

STATUS_KEYS = ("status", "reason", *WINDOW_KEYS)
"""KeyValues of the diagnosis as a whole, beside the element's own."""

IMPACT_KEY = "impact_all"
"""Prefix of the KeyValues of the diagnosis-wide control impact (all mismatches together)."""

SUMMARY_KEY = "summary"
"""The element's one-line summary: in JSON; on /diagnostics it is the status message, not a KeyValue."""

PARTS: dict[str, type[ClassicResult] | type[ParametricResult]] = {
    "classic": ClassicResult,
    "parametric": ParametricResult,
}
"""Each method's result type, by the name of its part."""

CSV_FIELDS = tuple(
    "gain_ratio tau_index gain_mismatch_pct gain_mismatch_pct_low gain_mismatch_pct_high tau_mismatch_pct "
    "tau_mismatch_pct_low tau_mismatch_pct_high delay_mismatch_samples delay_confidence gain_mismatch tau_mismatch "
    "delay_mismatch gain_verdict tau_verdict delay_verdict verdict".split()
)
"""The sweep CSV's result columns: a classic row fills ``gain_ratio``, ``tau_index``, the delay and the three
flags; a parametric row the fitted changes with their intervals, the delay with its confidence and the three
verdicts; both the element's ``verdict``."""

CSV_TYPES: dict[str, type] = {
    **dict.fromkeys(("delay_mismatch_samples",), int),
    **dict.fromkeys(("gain_mismatch", "tau_mismatch", "delay_mismatch"), bool),
    **dict.fromkeys(("gain_verdict", "tau_verdict", "delay_verdict", "verdict"), str),
}
"""The type of each CSV result column that is not a float."""


def encode_value(value: Any) -> str:
    """A KeyValue's string: text as it is, everything else as JSON (floats lossless)."""
    if isinstance(value, str):
        return value
    return json.dumps(plain(value))


def decode_value(text: str) -> Any:
    """Inverse of :func:`encode_value` (a string that is not JSON stays a string)."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def _flatten(tree: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dicts to dotted paths (an empty dict has no path; None stays a value)."""
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _nest(flat: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted paths to nested dicts (inverse of :func:`_flatten`)."""
    tree: dict[str, Any] = {}
    for path, value in flat.items():
        node = tree
        *parents, last = path.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[last] = value
    return tree


def _optional_json(part: Any) -> dict[str, Any] | None:
    return None if part is None else part_plain(part)


def element_to_json(element: ElementDiagnosis) -> dict[str, Any]:
    """One element as JSON-ready values: position, verdict, method, model, each method's result, summary."""
    return {
        "element": element.name,
        "row": element.row,
        "column": element.column,
        "verdict": element.verdict,
        "method": element.method,
        "model": part_plain(element.model),
        "classic": _optional_json(element.classic),
        "parametric": _optional_json(element.parametric),
        "reasons": list(element.reasons),
        "impact": _optional_json(element.impact),
        "data_quality": _optional_json(element.data_quality),
        SUMMARY_KEY: element.summary(),
    }


def diagnosis_to_json(diagnosis: Diagnosis) -> dict[str, Any]:
    """A diagnosis as JSON-ready values: status, reason, samples, method, impact and every element."""
    return {
        "status": diagnosis.status,
        "reason": diagnosis.reason,
        "samples": diagnosis.samples,
        "method": diagnosis.method,
        "impact": _optional_json(diagnosis.impact),
        "elements": {name: element_to_json(e) for name, e in diagnosis.elements.items()},
    }


def _interval_from(data: Mapping[str, Any], name: str) -> tuple[float, float] | None:
    base = name[: -len(INTERVAL)]
    if base + LOW in data or base + HIGH in data:
        low, high = data.get(base + LOW), data.get(base + HIGH)
    else:  # the earlier spelling: one [low, high] list
        low, high = data.get(name) or (None, None)
    return None if low is None or high is None else (float(low), float(high))


def _part_from(cls: type, data: Mapping[str, Any]) -> Any:
    """A result dataclass from its fields; lists back to tuples, derived and unknown keys ignored."""
    kwargs: dict[str, Any] = {}
    for name in (f.name for f in fields(cls)):
        if name.endswith(INTERVAL):
            kwargs[name] = _interval_from(data, name)
        elif name in data:
            value = data[name]
            kwargs[name] = (
                tuple(value) if isinstance(value, list) else dict(value) if isinstance(value, Mapping) else value
            )
    return cls(**kwargs)


def _optional_from(cls: type, data: Any) -> Any:
    return None if data is None else _part_from(cls, data)


def element_from_json(
    data: Mapping[str, Any],
    *,
    name: str | None = None,
    models: Mapping[str, tuple[int, int, ElementModel]] | None = None,
) -> ElementDiagnosis:
    """Inverse of :func:`element_to_json` (derived keys are not read); pmr_ros 0.1's flat element too.

    ``name`` and ``models`` (element name to ``(row, column, ElementModel)``)
    serve only the 0.1 spelling, which carried neither the name nor the model.
    """
    if "element" not in data:
        return element_from_v01(data, name or "", models)
    return ElementDiagnosis(
        name=str(data["element"]),
        row=int(data["row"]),
        column=int(data["column"]),
        model=_part_from(ElementModel, data["model"]),
        method=str(data["method"]),
        classic=_optional_from(ClassicResult, data.get("classic")),
        parametric=_optional_from(ParametricResult, data.get("parametric")),
        reasons=tuple(data.get("reasons") or ()),
        impact=_optional_from(ImpactResult, data.get("impact")),
        data_quality=_optional_from(DataQuality, data.get("data_quality")),
    )


def diagnosis_from_json(
    data: Mapping[str, Any], *, models: Mapping[str, tuple[int, int, ElementModel]] | None = None
) -> Diagnosis:
    """Inverse of :func:`diagnosis_to_json`; a pmr_ros 0.1 report too (``models``: see :func:`element_from_json`)."""
    elements = {name: element_from_json(e, name=name, models=models) for name, e in data["elements"].items()}
    return Diagnosis(
        str(data["method"]),
        str(data["status"]),
        str(data.get("reason", "")),
        int(data.get("samples", 0)),
        elements,
        impact=_optional_from(ImpactResult, data.get("impact")),
    )


def element_key_values(element: ElementDiagnosis) -> list[tuple[str, str]]:
    """The KeyValues of one element (without the diagnosis-wide :data:`STATUS_KEYS`)."""
    flat = _flatten(element_to_json(element))
    flat.pop(SUMMARY_KEY)
    return [(key, encode_value(value)) for key, value in flat.items()]


def status_key_values(
    diagnosis: Diagnosis, element: ElementDiagnosis, *, state: str, window: Mapping[str, int]
) -> list[tuple[str, str]]:
    """Every KeyValue of the /diagnostics status of ``element``: the diagnosis-wide ones, then its own.

    ``state`` is the ``status`` word (``ok``, ``insufficient_data``, ``stale``,
    ``conflict``, ``failed``); ``window`` the :data:`WINDOW_KEYS` of the diagnosed window.
    """
    common: dict[str, Any] = {"status": state, "reason": diagnosis.reason, **window}
    if diagnosis.impact is not None:
        common.update(_flatten({IMPACT_KEY: part_plain(diagnosis.impact)}))
    return [(key, encode_value(value)) for key, value in common.items()] + element_key_values(element)


def _element_from_key_values(
    pairs: Iterable[tuple[str, str]], name: str, models: Mapping[str, tuple[int, int, ElementModel]] | None
) -> tuple[ElementDiagnosis, dict[str, Any]]:
    """One status's element and its diagnosis-wide values."""
    raw = dict(pairs)
    if "element" not in raw:  # a status of pmr_ros 0.1
        return status_from_v01(raw, name, models)
    values = {key: decode_value(text) for key, text in raw.items()}
    wide = [key for key in values if key in STATUS_KEYS or key.startswith(f"{IMPACT_KEY}.")]
    common = {key: values.pop(key) for key in wide}
    return element_from_json(_nest(values)), common


def diagnosis_from_key_values(
    statuses: Mapping[str, Iterable[tuple[str, str]]],
    *,
    models: Mapping[str, tuple[int, int, ElementModel]] | None = None,
) -> tuple[Diagnosis, dict[str, Any]]:
    """Inverse of :func:`status_key_values` over the statuses of one diagnosis.

    ``statuses``: element name to the KeyValue pairs of its status, row-major; ``models`` only for the
    statuses of pmr_ros 0.1 (see :func:`element_from_json`).  Returns the diagnosis (``insufficient_data`` for
    stale and conflicting data too) and the diagnosis-wide ``status`` word, ``reason`` and window.
    """
    elements: dict[str, ElementDiagnosis] = {}
    common: dict[str, Any] = {"status": "ok", "reason": ""}
    for name, pairs in statuses.items():
        elements[name], common = _element_from_key_values(pairs, name, models)
    state = str(common.get("status", "ok"))
    impact = {key.split(".", 1)[1]: v for key, v in common.items() if key.startswith(f"{IMPACT_KEY}.")}
    diagnosis = Diagnosis(
        next((e.method for e in elements.values()), "classic"),
        "ok" if state == "ok" else "insufficient_data",
        str(common.get("reason", "")),
        int(common.get("window_samples", 0) or 0),
        elements,
        impact=_part_from(ImpactResult, impact) if impact else None,
    )
    window = {key: common[key] for key in WINDOW_KEYS if key in common}
    return diagnosis, {"status": state, "reason": diagnosis.reason, **window}


def _number(value: Any) -> float:
    return math.nan if value is None else float(value)


def estimate_fields(element: ElementDiagnosis) -> dict[str, float]:
    """The numbers of an element's results: ``classic.gain_ratio``, ``parametric.gain_mismatch_pct_low`` ...

    Every numeric field (``NUMBERS`` of each result type) of the classic part,
    and of the parametric part when the element was diagnosed with the
    parametric method; NaN where there is no number.
    """
    out: dict[str, float] = {}
    parts = ("classic", "parametric") if element.method == "parametric" else ("classic",)
    for part in parts:
        result = getattr(element, part)
        for key in PARTS[part].NUMBERS:
            value = None if result is None else getattr(result, key)
            if key.endswith(INTERVAL):
                base = f"{part}.{key[: -len(INTERVAL)]}"
                low, high = (None, None) if value is None else value
                out[base + LOW], out[base + HIGH] = _number(low), _number(high)
            else:
                out[f"{part}.{key}"] = _number(value)
    return out


def estimate_names_values(diagnosis: Diagnosis) -> tuple[list[str], list[float]]:
    """The estimates message's ``name`` (``<element>/<path>``) and ``position`` of a diagnosis."""
    names: list[str] = []
    values: list[float] = []
    for name, element in diagnosis.elements.items():
        for quantity, value in estimate_fields(element).items():
            names.append(f"{name}/{quantity}")
            values.append(value)
    return names, values


def estimates_from_names_values(names: Sequence[str], values: Sequence[float]) -> dict[str, dict[str, float]]:
    """Element -> path -> value of an estimates message (an earlier ``..._interval.low`` read as ``..._low``)."""
    out: dict[str, dict[str, float]] = {}
    for name, value in zip(names, values, strict=False):
        element, _, quantity = name.partition("/")
        quantity = quantity.replace(f"{INTERVAL}.low", LOW).replace(f"{INTERVAL}.high", HIGH)
        out.setdefault(element, {})[quantity] = float(value)
    return out


def csv_fields(element: ElementDiagnosis) -> dict[str, Any]:
    """The :data:`CSV_FIELDS` of one element by its verdict method (None where the method has no such field)."""
    out: dict[str, Any] = dict.fromkeys(CSV_FIELDS)
    result = element.result
    if result is not None:
        out.update({key: value for key, value in part_plain(result).items() if key in out})
    out["verdict"] = element.verdict
    return out


def result_from_csv_fields(row: Mapping[str, Any], method: str) -> Part | None:
    """The ``method``'s result of a CSV row (its :data:`CSV_FIELDS`); None when the row has no numbers.

    The CSV carries the numbers, flags and verdicts, not the reasons, warnings,
    data-quality figures or an empty cell's interaction: those come back empty.
    """
    cls = PARTS[method]
    if all(row.get(f.name) is None for f in fields(cls)):
        return None
    return _part_from(cls, {key: value for key, value in row.items() if key != "verdict"})
