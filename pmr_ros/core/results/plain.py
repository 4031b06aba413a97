"""One result dataclass as plain JSON-ready values: the piece every flat form of :mod:`.codec` is made of.

:func:`part_plain` spells a part (``ElementModel``, ``ClassicResult`` ...) field by field, an interval as
its ``_low``/``_high`` bounds, a method's result with its ``verdict``; :func:`plain` turns one value
(tuples, mappings, numpy scalars) into plain Python.  A year's monitor spells about 40,000 parts (352
windows of 32 elements), so each type's keys are made once, and the values that are plain already -- nearly
all -- pass without a call.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import fields
from operator import attrgetter
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

_Keys = tuple[Callable[[Any], tuple[Any, ...]], tuple[tuple[str | None, str], ...], bool]
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
    # texts and pairs (a tuple: decided without a call), copied whole when every item is plain
    if type(value) is tuple or isinstance(value, (tuple, list)):
        return list(value) if _SCALARS.issuperset(map(type, value)) else [plain(v) for v in value]
    if type(value) is dict or isinstance(value, Mapping):  # the abstract check costs ten times the first
        if _TEXT.issuperset(map(type, value)) and _SCALARS.issuperset(map(type, value.values())):
            return dict(value.items())  # text keys and plain values (quality figures, instrument shares)
        return {str(k): plain(v) for k, v in value.items()}
    return value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value


def _keys(cls: type) -> _Keys:
    """A result type's getter of its field values, each field's keys, and whether it carries a verdict.

    The getter reads every field in one call (``attrgetter``: a tuple from two fields on), not a ``getattr``
    a field; a field's keys are an interval's two bounds', else None and its name.
    """
    names = [f.name for f in fields(cls)]
    values = attrgetter(*names) if len(names) > 1 else lambda part: tuple(getattr(part, n) for n in names)
    keys = tuple(
        (name[: -len(INTERVAL)] + LOW, name[: -len(INTERVAL)] + HIGH) if name.endswith(INTERVAL) else (None, name)
        for name in names
    )
    return _KEYS.setdefault(cls, (values, keys, issubclass(cls, (ClassicResult, ParametricResult))))


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
    values, keys, verdict = _KEYS.get(type(part)) or _keys(type(part))
    out: dict[str, Any] = {}
    for (low, key), value in zip(keys, values(part), strict=True):
        if low is None:  # not an interval: its value checked here rather than in a call
            out[key] = value if type(value) in _SCALARS else plain(value)
        elif value is None:
            out[low] = out[key] = None  # targets assigned left to right: the low bound's key first
        else:  # the bounds: plain floats nearly always, checked here too
            low_value, high_value = value
            out[low] = low_value if type(low_value) in _SCALARS else plain(low_value)
            out[key] = high_value if type(high_value) in _SCALARS else plain(high_value)
    if verdict:
        out["verdict"] = part.verdict
    return out
