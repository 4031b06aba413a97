"""The codec's reader of pmr_ros 0.1's spelling: one flat field per number, as the reference bag recorded them.

pmr_ros 0.1 published each element as flat KeyValues (``gain_ratio``,
``tau_index``, ``gain_mismatch_pct_low`` ..., values as Python ``repr``;
with the parametric method the classic numbers as ``classic.gain_ratio``)
and wrote its JSON reports with the same flat element fields (intervals as
``..._interval`` lists).  Neither carried the element's name, position or
model.  Only :mod:`.codec` calls this module; nothing writes the spelling.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from .findings import ClassicResult, ElementModel, ParametricResult
from .matrix import ElementDiagnosis

__all__ = ["element_from_v01", "status_from_v01"]

_UNKNOWN_MODEL = ElementModel("foptd", float("nan"), None, 0)
"""The model of an element whose recording did not carry it (0.1 without ``models``)."""

_NAME = re.compile(r"G(\d)(\d)$|G(\d+)_(\d+)$")
"""``G21``, or ``G2_10`` beyond 9 channels: one-based output and input."""


def _position(name: str) -> tuple[int, int]:
    """Zero-based (row, column) of an element's name, (-1, -1) when it is not one."""
    found = _NAME.match(name)
    if found is None:
        return -1, -1
    i, k = (g for g in found.groups() if g is not None)
    return int(i) - 1, int(k) - 1


def _interval(values: Mapping[str, Any], key: str) -> tuple[float, float] | None:
    low, high = values.get(f"{key}_low"), values.get(f"{key}_high")
    if low is None and high is None:
        low, high = values.get(f"{key}_interval") or (None, None)
    return None if low is None or high is None else (float(low), float(high))


def _texts(values: Mapping[str, Any], key: str) -> tuple[str, ...]:
    """Reasons or warnings: a JSON list, or a KeyValue joined by `` | ``."""
    text = values.get(key)
    if isinstance(text, list):
        return tuple(str(t) for t in text)
    return () if not text else tuple(str(text).split(" | "))


def _classic(values: Mapping[str, Any], prefix: str) -> ClassicResult:
    return ClassicResult(
        gain_ratio=float(values[f"{prefix}gain_ratio"]),
        tau_index=None if values.get(f"{prefix}tau_index") is None else float(values[f"{prefix}tau_index"]),
        delay_mismatch_samples=int(values[f"{prefix}delay_mismatch_samples"]),
        # 0.1 statuses of the parametric method carried only the classic numbers, not its flags
        gain_mismatch=bool(values.get("gain_mismatch")) if not prefix else False,
        tau_mismatch=bool(values.get("tau_mismatch")) if not prefix else False,
        delay_mismatch=bool(values.get("delay_mismatch")) if not prefix else False,
        reasons=_texts(values, "reasons") if not prefix else (),
    )


def _parametric(values: Mapping[str, Any]) -> ParametricResult:
    return ParametricResult(
        gain_mismatch_pct=values.get("gain_mismatch_pct"),
        gain_mismatch_pct_interval=_interval(values, "gain_mismatch_pct"),
        tau_mismatch_pct=values.get("tau_mismatch_pct"),
        tau_mismatch_pct_interval=_interval(values, "tau_mismatch_pct"),
        delay_mismatch_samples=values.get("delay_mismatch_samples"),
        delay_confidence=values.get("delay_confidence"),
        gain_verdict=str(values.get("gain_verdict", "inconclusive")),
        tau_verdict=str(values.get("tau_verdict", "inconclusive")),
        delay_verdict=str(values.get("delay_verdict", "inconclusive")),
        reasons=_texts(values, "reasons"),
        warnings=_texts(values, "warnings"),
        quality={key[len("quality.") :]: v for key, v in values.items() if key.startswith("quality.")},
    )


def element_from_v01(
    values: Mapping[str, Any], name: str, models: Mapping[str, tuple[int, int, ElementModel]] | None
) -> ElementDiagnosis:
    """An element of a pmr_ros 0.1 status or report (values already decoded).

    ``models`` (element name to ``(row, column, ElementModel)``) gives what 0.1
    did not record; without it the position comes from the name and the model
    is unknown (NaN gain).
    """
    i, k = _position(name)
    i, k, model = (models or {}).get(name, (i, k, _UNKNOWN_MODEL))
    method = "parametric" if values.get("method") == "parametric" else "classic"
    if values.get("verdict") == "insufficient_data":
        return ElementDiagnosis(name, i, k, model, method, reasons=(str(values.get("reason", "")),))
    prefix = "classic." if method == "parametric" else ""
    parametric = _parametric(values) if method == "parametric" else None
    return ElementDiagnosis(name, i, k, model, method, classic=_classic(values, prefix), parametric=parametric)


def _value(text: str) -> Any:
    """A pmr_ros 0.1 KeyValue (``repr``/``str`` of the Python value)."""
    if text in ("True", "False"):
        return text == "True"
    if text == "None":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def status_from_v01(
    raw: Mapping[str, str], name: str, models: Mapping[str, tuple[int, int, ElementModel]] | None
) -> tuple[ElementDiagnosis, dict[str, Any]]:
    """The element of one pmr_ros 0.1 /diagnostics status, and the status's diagnosis-wide values."""
    values = {key: _value(text) for key, text in raw.items()}
    no_verdict = values.get("verdict") == "insufficient_data"
    common: dict[str, Any] = {
        "status": str(values.get("status", "insufficient_data")) if no_verdict else "ok",
        "reason": str(values.get("reason", "")),
        **{key: values[key] for key in ("window_samples", "first_sample", "last_sample") if key in values},
    }
    return element_from_v01(values, name, models), common
