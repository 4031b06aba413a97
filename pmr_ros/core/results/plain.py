"""One result dataclass as plain JSON-ready values: the piece every flat form of :mod:`.codec` is made of.

:func:`part_plain` spells a part (``ElementModel``, ``ClassicResult`` ...) field by field, an interval as
its ``_low``/``_high`` bounds, a method's result with its ``verdict``; :func:`plain` turns one value
(tuples, mappings, numpy scalars) into plain Python.  A year's monitor spells about 40,000 parts (352
windows of 32 elements), so each type's keys are made once, and the values that are plain already -- nearly
all -- pass without a call.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from .findings import ClassicResult, ParametricResult

__all__ = ["HIGH", "INTERVAL", "LOW", "part_plain", "plain"]

LOW, HIGH = "_low", "_high"
"""Suffixes of an interval's bounds, in every flat form."""

INTERVAL = "_interval"
"""Suffix of an interval field of the result objects (a ``(low, high)`` pair)."""

_SCALARS = frozenset({float, int, str, bool, type(None)})
"""The types :func:`plain` returns as they are (``type(v) in`` a set: one hash, no ``isinstance`` walk)."""

_TEXT = frozenset({str})

_Keys = tuple[tuple[tuple[str, str | None, str], ...], bool]
_KEYS: dict[type, _Keys] = {}
"""Each result type's :func:`_keys`, made on its first part."""


def plain(value: Any) -> Any:
    """Tuples, mappings and numpy scalars as plain JSON-ready Python values.

    Examples
    --------
    >>> import numpy as np
    >>> plain({"coherence": np.float64(0.5), "bins": (np.int64(3), None)})
    {'coherence': 0.5, 'bins': [3, None]}
    """
    if type(value) in _SCALARS:  # most values: checked first
        return value
    if isinstance(value, (tuple, list)):  # texts, pairs: copied whole when every item is plain
        return list(value) if _SCALARS.issuperset(map(type, value)) else [plain(v) for v in value]
    if type(value) is dict or isinstance(value, Mapping):  # the abstract check costs ten times the first
        if _TEXT.issuperset(map(type, value)) and _SCALARS.issuperset(map(type, value.values())):
            return dict(value.items())  # text keys and plain values (quality figures, instrument shares)
        return {str(k): plain(v) for k, v in value.items()}
    return value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value


def _keys(cls: type) -> _Keys:
    """Per field of a result type: name, bounds' keys (an interval's; else None and the name); if it has a verdict."""
    keys = tuple(
        (f.name, f.name[: -len(INTERVAL)] + LOW, f.name[: -len(INTERVAL)] + HIGH)
        if f.name.endswith(INTERVAL)
        else (f.name, None, f.name)
        for f in fields(cls)
    )
    return _KEYS.setdefault(cls, (keys, issubclass(cls, (ClassicResult, ParametricResult))))


def part_plain(part: Any) -> dict[str, Any]:
    """The fields of a result dataclass as plain values, an interval as its ``_low``/``_high`` bounds.

    A method's result (``ClassicResult``, ``ParametricResult``) also carries its derived ``verdict``, last.

    Examples
    --------
    >>> from pmr_ros.core.results import ParametricResult
    >>> spelt = part_plain(ParametricResult(gain_mismatch_pct=12.0, gain_mismatch_pct_interval=(9.0, 15.0)))
    >>> list(spelt.items())[:3]
    [('gain_mismatch_pct', 12.0), ('gain_mismatch_pct_low', 9.0), ('gain_mismatch_pct_high', 15.0)]
    >>> spelt["tau_mismatch_pct_low"], spelt["tau_mismatch_pct_high"], spelt["verdict"]
    (None, None, 'inconclusive')
    """
    keys, verdict = _KEYS.get(type(part)) or _keys(type(part))
    out: dict[str, Any] = {}
    for name, low, key in keys:
        value = getattr(part, name)
        if low is None:  # not an interval: its value checked here rather than in a call
            out[key] = value if type(value) in _SCALARS else plain(value)
        elif value is None:
            out[low] = out[key] = None  # targets assigned left to right: the low bound's key first
        else:
            low_value, high_value = value
            out[low], out[key] = plain(low_value), plain(high_value)
    if verdict:
        out["verdict"] = part.verdict
    return out
