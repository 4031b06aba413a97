"""Whether two diagnoses agree: verdicts, flags, delays and strings exactly, floats to a tolerance.

:func:`compare_diagnoses` is the one comparison of two diagnoses (see
:data:`RELATIVE_TOLERANCE` for why a tolerance at all).  Both sides are
compared in their JSON form (:func:`.codec.diagnosis_to_json`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .codec import diagnosis_to_json
from .matrix import Diagnosis

__all__ = ["ABSOLUTE_TOLERANCE", "DERIVED_KEYS", "LATER_KEYS", "RELATIVE_TOLERANCE", "compare_diagnoses"]

RELATIVE_TOLERANCE = 1e-6
"""Floats of two diagnoses agree within this relative difference.

The same record diagnosed on two machines differs only through the BLAS
kernel's summation order: measured up to 1e-13 relative in fitted numbers
(and a simulated trajectory by up to 4e-4, which is why records are compared
only where both come from one process).  1e-6 is far above that noise and far
below any difference that matters for a verdict (an interval moving by a
millionth of its value), so a disagreement beyond it is a real one."""

ABSOLUTE_TOLERANCE = 1e-9
"""... or within this absolute difference, for numbers that are zero in one of them (in their unit)."""

DERIVED_KEYS = ("summary",)
"""Serialised keys that are derived text of numbers already compared (never compared themselves)."""

LATER_KEYS = ("data_quality", "instrument_shares")
"""Parts an earlier pmr_ros recording lacks (absent, None or empty): compared only when both have them.

They never change a verdict, so a recording from before they existed still agrees on everything it holds."""


def compare_diagnoses(
    first: Diagnosis | Mapping[str, Any],
    second: Diagnosis | Mapping[str, Any],
    *,
    rtol: float = RELATIVE_TOLERANCE,
    atol: float = ABSOLUTE_TOLERANCE,
) -> list[str]:
    """The differences between two diagnoses; empty when they agree.

    Verdicts, flags, delays (integers), statuses and strings must be equal;
    floats may differ by ``rtol`` relative or ``atol`` absolute (see
    :data:`RELATIVE_TOLERANCE`); the parts of :data:`LATER_KEYS` are compared
    only where both sides have them.  Either side may be a :class:`Diagnosis` or
    its JSON form (:func:`.codec.diagnosis_to_json`, e.g. read back from a file).

    Returns
    -------
    list of str
        One line per difference, ``elements.G12.parametric.gain_mismatch_pct: 15.3 != 15.4``.

    Examples
    --------
    >>> compare_diagnoses({"x": 1.0}, {"x": 1.0 + 1e-12})
    []
    """
    a = diagnosis_to_json(first) if isinstance(first, Diagnosis) else first
    b = diagnosis_to_json(second) if isinstance(second, Diagnosis) else second
    out: list[str] = []
    _compare(a, b, "", _Tolerance(rtol, atol), out)
    return out


@dataclass(frozen=True)
class _Tolerance:
    rtol: float
    atol: float


def _compare(a: Any, b: Any, path: str, tolerance: _Tolerance, out: list[str]) -> None:
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        _compare_mappings(a, b, path, tolerance, out)
    elif isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            out.append(f"{path}: {len(a)} entries != {len(b)}")
            return
        for j, (x, y) in enumerate(zip(a, b, strict=True)):
            _compare(x, y, f"{path}[{j}]", tolerance, out)
    elif isinstance(a, float) or isinstance(b, float):
        if not _numbers_agree(a, b, tolerance.rtol, tolerance.atol):
            out.append(f"{path}: {a!r} != {b!r}")
    elif not (a == b and type(a) is type(b)):
        out.append(f"{path}: {a!r} != {b!r}")


def _compare_mappings(
    a: Mapping[str, Any], b: Mapping[str, Any], path: str, tolerance: _Tolerance, out: list[str]
) -> None:
    for key in sorted(set(a) | set(b)):
        if key in DERIVED_KEYS or (key in LATER_KEYS and (_absent(a.get(key)) or _absent(b.get(key)))):
            continue
        where = f"{path}.{key}" if path else str(key)
        if key not in a or key not in b:
            out.append(f"{where}: only in {'the first' if key in a else 'the second'}")
        else:
            _compare(a[key], b[key], where, tolerance, out)


def _absent(value: Any) -> bool:
    """A :data:`LATER_KEYS` part an earlier recording lacks: None, or an empty mapping."""
    return value is None or (isinstance(value, Mapping) and not value)


def _numbers_agree(a: Any, b: Any, rtol: float, atol: float) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return False
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return math.isclose(a, b, rel_tol=rtol, abs_tol=atol)
