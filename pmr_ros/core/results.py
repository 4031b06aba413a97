"""The method-neutral diagnosis result: one shape for every method, built once, never mutated.

A :class:`Diagnosis` holds one :class:`ElementDiagnosis` per element of the
controller's model.  Each element keeps its model element (:class:`ElementModel`)
and the outcome of each method that ran, as separate typed values:
:class:`ClassicResult` (the paper's Table 1: gain ratio M(0), time-constant
index, delay) and :class:`ParametricResult` (fitted dK %, dtau %, dD with
intervals and calibrated verdicts).  ``method`` says which of them gives the
element's verdict.  :meth:`Diagnosis.to_dict` is the one serialisation (JSON
reports, /diagnostics KeyValues, bags); :meth:`Diagnosis.from_dict` inverts it.

:func:`compare_diagnoses` is the one comparison of two diagnoses: verdicts,
flags, delays and strings exactly, floats to a relative tolerance (see
:data:`RELATIVE_TOLERANCE` for why a tolerance at all).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any, ClassVar

__all__ = [
    "ABSOLUTE_TOLERANCE",
    "RELATIVE_TOLERANCE",
    "VERDICTS",
    "ClassicResult",
    "DataQuality",
    "Diagnosis",
    "ElementDiagnosis",
    "ElementModel",
    "ParametricResult",
    "compare_diagnoses",
]

VERDICTS = ("ok", "mismatch", "inconclusive")
"""An element's (and a parameter's) verdict: no mismatch, mismatch, or the data cannot tell."""

PROPERTIES = ("gain", "time_constant", "delay", "interaction")
"""The properties of an element a mismatch is found in (``interaction``: an unmodeled one in an empty cell)."""

KINDS = ("foptd", "integrating", "none")
"""Element kinds of a model (:class:`ElementModel.kind`); ``none`` is an empty cell."""

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


@dataclass(frozen=True)
class ElementModel:
    """The controller model's element ``Ghat_ik`` the diagnosis compares the plant with.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`: ``foptd`` K exp(-theta s)/(tau s + 1), ``integrating``
        K exp(-theta s)/s, ``none`` an empty cell (no model; gain 0).
    gain : float
        K [output unit / input unit; per time unit when integrating].
    time_constant : float or None
        tau [time unit]; None unless ``foptd``.
    delay_samples : int
        theta / Ts [samples].
    """

    kind: str
    gain: float
    time_constant: float | None
    delay_samples: int


@dataclass(frozen=True)
class ClassicResult:
    """The paper's Table 1 diagnosis of one element.

    An ``integrating`` element has no time constant (``tau_index`` None).  The
    classic method does not test empty cells (model ``none``): those have no
    classic result.

    Attributes
    ----------
    gain_ratio : float
        ``M(0) = K / Khat``.
    tau_index : float or None
        ``-100 x`` the slope of ``M(w)/M(0)`` on ``(0, tau_band]`` [1/(rad/sample)];
        positive when the plant is slower than the model.  None unless ``foptd``.
    delay_mismatch_samples : int
        ``D - Dhat`` [samples].
    gain_mismatch, tau_mismatch, delay_mismatch : bool
        Beyond the configured thresholds.
    reasons : tuple of str
        Why the element's numbers cannot be trusted (a delay at the search
        limit); any reason makes the verdict ``inconclusive``.
    """

    gain_ratio: float
    tau_index: float | None
    delay_mismatch_samples: int
    gain_mismatch: bool
    tau_mismatch: bool
    delay_mismatch: bool
    reasons: tuple[str, ...] = ()

    NUMBERS: ClassVar[tuple[str, ...]] = ("gain_ratio", "tau_index", "delay_mismatch_samples")
    """The numeric fields (for plotting topics and tables)."""

    @property
    def mismatches(self) -> tuple[str, ...]:
        """The properties (of :data:`PROPERTIES`) found mismatched."""
        flags = (self.gain_mismatch, self.tau_mismatch, self.delay_mismatch)
        return tuple(p for p, flag in zip(PROPERTIES, flags, strict=False) if flag)

    @property
    def verdict(self) -> str:
        """``inconclusive`` with reasons, else ``mismatch`` if any property is off, else ``ok``."""
        if self.reasons:
            return "inconclusive"
        return "mismatch" if self.mismatches else "ok"

    @property
    def gain_direction(self) -> str:
        """``higher``/``lower`` plant gain than the model's, or ``ok``."""
        if not self.gain_mismatch:
            return "ok"
        return "higher" if self.gain_ratio > 1 else "lower"

    @property
    def tau_direction(self) -> str:
        """``larger``/``smaller`` plant time constant than the model's, or ``ok``."""
        if not self.tau_mismatch or self.tau_index is None:
            return "ok"
        return "larger" if self.tau_index > 0 else "smaller"

    def summary(self) -> str:
        """One line for people: ``gain +15 %, τ larger (index +20), delay +2 samples``."""
        gain = f"gain {100 * (self.gain_ratio - 1):+.0f} %" if self.gain_mismatch else "gain ok"
        parts = [gain]
        if self.tau_index is not None:
            parts.append(f"τ {self.tau_direction} (index {self.tau_index:+.0f})" if self.tau_mismatch else "τ ok")
        parts.append(f"delay {self.delay_mismatch_samples:+d} samples" if self.delay_mismatch else "delay ok")
        return _with_reasons(", ".join(parts), self.reasons)


def _with_reasons(text: str, reasons: tuple[str, ...]) -> str:
    return f"{text} (inconclusive: {'; '.join(reasons)})" if reasons else text


Interval = tuple[float, float]


@dataclass(frozen=True)
class ParametricResult:
    """The parametric (FOPTD-ratio fit) diagnosis of one element.

    Numbers are None when the data could not support a fit (then every
    verdict is ``inconclusive`` and ``reasons`` say why).  Intervals are
    ``(low, high)`` at the configured confidence level.  A verdict is None
    where the property does not apply: ``tau_verdict`` of an integrating
    element (it has no time constant), every verdict but
    ``unmodeled_verdict`` of an empty cell, ``unmodeled_verdict`` of a
    modeled element.

    Attributes
    ----------
    gain_mismatch_pct, gain_mismatch_pct_interval : float, Interval
        ``dK = (K - Khat)/Khat`` [%].
    tau_mismatch_pct, tau_mismatch_pct_interval : float, Interval
        ``dtau`` [%]; None unless the element is ``foptd``.
    delay_mismatch_samples : int
        ``dD = D - Dhat`` [samples].
    delay_confidence : float
        Profile-likelihood confidence of ``dD`` (of the interaction's delay in
        an empty cell) against its neighbours, 0..1.
    gain_verdict, tau_verdict, delay_verdict : str or None
        One of :data:`VERDICTS` per property, None where it does not apply.
    unmodeled_gain, unmodeled_gain_interval : float, Interval
        Empty cell only: the steady-state gain of the plant's interaction there
        [output unit / input unit; per time unit in an integrating row].
    unmodeled_delay_samples : int
        Empty cell only: the interaction's dead time [samples].
    unmodeled_verdict : str or None
        Empty cell only: ``mismatch`` (an interaction the model lacks), ``ok``
        (none of practical size) or ``inconclusive``.
    reasons : tuple of str
        Why a property is inconclusive.
    warnings : tuple of str
        Quality remarks that do not change a verdict.
    quality : Mapping
        Data-quality figures (coherence, excitation, condition, ...).
    """

    gain_mismatch_pct: float | None = None
    gain_mismatch_pct_interval: Interval | None = None
    tau_mismatch_pct: float | None = None
    tau_mismatch_pct_interval: Interval | None = None
    delay_mismatch_samples: int | None = None
    delay_confidence: float | None = None
    gain_verdict: str | None = "inconclusive"
    tau_verdict: str | None = "inconclusive"
    delay_verdict: str | None = "inconclusive"
    unmodeled_gain: float | None = None
    unmodeled_gain_interval: Interval | None = None
    unmodeled_delay_samples: int | None = None
    unmodeled_verdict: str | None = None
    reasons: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    quality: Mapping[str, float] = field(default_factory=dict)

    NUMBERS: ClassVar[tuple[str, ...]] = (
        "gain_mismatch_pct",
        "gain_mismatch_pct_interval",
        "tau_mismatch_pct",
        "tau_mismatch_pct_interval",
        "delay_mismatch_samples",
        "delay_confidence",
        "unmodeled_gain",
        "unmodeled_gain_interval",
        "unmodeled_delay_samples",
    )
    """The numeric fields (intervals are pairs), for plotting topics and tables."""

    @property
    def verdicts(self) -> tuple[str | None, str | None, str | None, str | None]:
        """The gain, time-constant, delay and interaction verdicts (None: does not apply)."""
        return self.gain_verdict, self.tau_verdict, self.delay_verdict, self.unmodeled_verdict

    @property
    def mismatches(self) -> tuple[str, ...]:
        """The properties (of :data:`PROPERTIES`) found mismatched."""
        return tuple(p for p, v in zip(PROPERTIES, self.verdicts, strict=True) if v == "mismatch")

    @property
    def verdict(self) -> str:
        """``mismatch`` if any property is, else ``inconclusive`` if any is, else ``ok``."""
        if "mismatch" in self.verdicts:
            return "mismatch"
        return "inconclusive" if "inconclusive" in self.verdicts else "ok"

    def summary(self) -> str:
        """One line: ``gain +15.0 % [+12.0, +18.0] MISMATCH, τ ... ok, delay +2 samples (99 %) MISMATCH``."""
        if self.unmodeled_gain is not None and self.unmodeled_gain_interval is not None:
            return self._interaction_summary()
        if self.gain_mismatch_pct is None or self.gain_mismatch_pct_interval is None:
            return "inconclusive: " + "; ".join(self.reasons)
        lo, hi = self.gain_mismatch_pct_interval
        parts = [f"gain {self.gain_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {_MARKS[self.gain_verdict]}"]
        if self.tau_mismatch_pct is not None and self.tau_mismatch_pct_interval is not None:
            lo, hi = self.tau_mismatch_pct_interval
            parts.append(f"τ {self.tau_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {_MARKS[self.tau_verdict]}")
        if self.delay_mismatch_samples is not None and self.delay_confidence is not None:
            confidence = 100 * self.delay_confidence
            parts.append(
                f"delay {self.delay_mismatch_samples:+d} samples ({confidence:.0f} %) {_MARKS[self.delay_verdict]}"
            )
        return ", ".join(parts)

    def _interaction_summary(self) -> str:
        assert self.unmodeled_gain is not None and self.unmodeled_gain_interval is not None
        lo, hi = self.unmodeled_gain_interval
        head = "unmodeled interaction" if self.unmodeled_verdict == "mismatch" else "no model"
        found = self.unmodeled_delay_samples is not None and self.unmodeled_verdict == "mismatch"
        delay = f", delay {self.unmodeled_delay_samples} samples" if found else ""
        return f"{head}: gain {self.unmodeled_gain:+.3g} [{lo:+.3g}, {hi:+.3g}]{delay} {_MARKS[self.unmodeled_verdict]}"


_MARKS = {"ok": "ok", "mismatch": "MISMATCH", "inconclusive": "?", None: "-"}
"""How :meth:`ParametricResult.summary` marks a verdict."""


@dataclass(frozen=True)
class ImpactResult:
    """What a mismatch does to control: the configured MPC on the plant as estimated vs as modelled.

    Attributes
    ----------
    ise_ratio : float
        Integrated squared tracking error (weighted by the MPC's output
        weights) on the plant as estimated over that on the plant as modelled;
        ``inf`` when the loop goes unstable.
    input_movement_ratio : float
        Sum of squared input moves (weighted by the move weights), the same ratio.
    rank : int
        1 for the element whose mismatch alone raises the tracking error most
        (among the elements with a mismatch); 0 for "all together".
    """

    ise_ratio: float
    input_movement_ratio: float
    rank: int = 0


@dataclass(frozen=True)
class DataQuality:
    """How far the data can be trusted for one element, whatever the method (never changes a verdict).

    Attributes
    ----------
    saturated_share : float or None
        Share of the diagnosed samples where the element's input sits at one of
        its limits (``mpc.u_min``, ``mpc.u_max``): samples that carry no
        excitation of it from the controller [-]; None when the limits are not
        known (plant data whose params file gives none).
    outside_share : float or None
        Share where it lies beyond them (the limits do not describe the data) [-].
    low_frequency_ratio : float or None
        The element's row: its residual spectrum at the lowest bins over its
        median (about 1 for white noise; large under a slow unmeasured
        disturbance, where the classic M(0) is read) [-]; None when the row has
        no regression.
    warnings : tuple of str
        The figures above their thresholds (``quality.*``), in words.
    """

    saturated_share: float | None
    outside_share: float | None
    low_frequency_ratio: float | None
    warnings: tuple[str, ...] = ()


Part = ClassicResult | ParametricResult
_PARTS: dict[str, type] = {"classic": ClassicResult, "parametric": ParametricResult}


@dataclass(frozen=True)
class ElementDiagnosis:
    """The diagnosis of one element ``G_ik``: its model, each method's result, the verdict.

    Attributes
    ----------
    name : str
        ``G21`` (``G2_10`` beyond 9 channels).
    row, column : int
        Zero-based position (output i, input k).
    model : ElementModel
    method : str
        The method whose result gives the verdict (``classic`` or ``parametric``).
    classic, parametric : ClassicResult, ParametricResult or None
        Each method's result, None when it did not run or the data were insufficient.
    reasons : tuple of str
        Why there is no result at all (insufficient data), empty otherwise.
    impact : ImpactResult or None
        What this element's mismatch alone does to control (elements with a mismatch verdict, when computed).
    data_quality : DataQuality or None
        Saturation of its input, slow disturbances on its row (None: not assessed, e.g. no verdict, or
        a diagnosis recorded before these figures existed).
    """

    name: str
    row: int
    column: int
    model: ElementModel
    method: str
    classic: ClassicResult | None = None
    parametric: ParametricResult | None = None
    reasons: tuple[str, ...] = ()
    impact: ImpactResult | None = None
    data_quality: DataQuality | None = None

    @property
    def result(self) -> Part | None:
        """The result of :attr:`method`, or None."""
        return self.classic if self.method == "classic" else self.parametric

    @property
    def verdict(self) -> str:
        """``ok``, ``mismatch`` or ``inconclusive`` (the data cannot say; see :attr:`all_reasons`)."""
        result = self.result
        return "inconclusive" if result is None else result.verdict

    @property
    def mismatches(self) -> tuple[str, ...]:
        """The mismatched properties by the verdict's method."""
        result = self.result
        return () if result is None else result.mismatches

    @property
    def all_reasons(self) -> tuple[str, ...]:
        """Every reason the verdict is (partly) inconclusive."""
        result = self.result
        return self.reasons + (() if result is None else result.reasons)

    def summary(self) -> str:
        """One line for people (the verdict's method)."""
        result = self.result
        if result is None:
            return "insufficient data" + (f": {self.reasons[0]}" if self.reasons else "")
        return result.summary()

    @property
    def warnings(self) -> tuple[str, ...]:
        """The data-quality warnings (saturation, slow disturbances), empty when there are none."""
        return () if self.data_quality is None else self.data_quality.warnings

    def message(self) -> str:
        """:meth:`summary`, with a short note when the data carry warnings (the /diagnostics message)."""
        count = len(self.warnings)
        return self.summary() + (f" [data: {count} warning{'s' if count > 1 else ''}]" if count else "")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: verdict, method, model, each method's result, reasons, summary."""
        return {
            "element": self.name,
            "row": self.row,
            "column": self.column,
            "verdict": self.verdict,
            "method": self.method,
            "model": _plain(self.model),
            "classic": None if self.classic is None else _part_dict(self.classic),
            "parametric": None if self.parametric is None else _part_dict(self.parametric),
            "reasons": list(self.reasons),
            "impact": None if self.impact is None else _plain(self.impact),
            "data_quality": None if self.data_quality is None else _plain(self.data_quality),
            "summary": self.summary(),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ElementDiagnosis:
        """Inverse of :meth:`to_dict` (``verdict`` and ``summary`` are derived, not read)."""
        parts = {}
        for key, part in _PARTS.items():
            value = data.get(key)
            parts[key] = None if value is None else _build(part, value)
        return cls(
            name=str(data["element"]),
            row=int(data["row"]),
            column=int(data["column"]),
            model=_build(ElementModel, data["model"]),
            method=str(data["method"]),
            reasons=tuple(data.get("reasons") or ()),
            impact=None if data.get("impact") is None else _build(ImpactResult, data["impact"]),
            data_quality=None if data.get("data_quality") is None else _build(DataQuality, data["data_quality"]),
            **parts,
        )


def _plain(value: Any) -> Any:
    """A dataclass, tuple or mapping as plain JSON-ready Python values."""
    if is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in fields(value)}
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, float) or hasattr(value, "dtype"):
        return value.item() if hasattr(value, "item") else value
    return value


def _part_dict(part: Part) -> dict[str, Any]:
    out = _plain(part)
    out["verdict"] = part.verdict
    return out


def _build(cls: type, data: Mapping[str, Any]) -> Any:
    """A result dataclass from its dict: lists back to tuples, derived keys ignored."""
    kwargs = {}
    for name in (f.name for f in fields(cls)):
        if name not in data:
            continue
        value = data[name]
        if isinstance(value, list):
            value = tuple(value)
        elif name == "quality" and isinstance(value, Mapping):
            value = dict(value)
        kwargs[name] = value
    return cls(**kwargs)


@dataclass(frozen=True)
class Diagnosis:
    """The diagnosis of every element, or why there is none.

    Attributes
    ----------
    method : str
        The method that gives the verdicts.
    status : str
        ``ok`` or ``insufficient_data`` (then ``reason`` says why, and no element has numbers).
    reason : str
    samples : int
        Samples of the diagnosed record.
    elements : Mapping
        Element name to :class:`ElementDiagnosis`, row-major.
    estimate : object, optional
        The spectral PMR estimate behind the numbers (for figures); not serialised.
    impact : ImpactResult or None
        What all the mismatches together do to control (when computed).
    """

    method: str
    status: str
    reason: str
    samples: int
    elements: Mapping[str, ElementDiagnosis]
    estimate: Any = field(default=None, repr=False, compare=False)
    impact: ImpactResult | None = None

    def __iter__(self) -> Iterator[ElementDiagnosis]:
        """The elements, row-major."""
        return iter(self.elements.values())

    @classmethod
    def insufficient(
        cls, *, method: str, models: Mapping[str, tuple[int, int, ElementModel]], reason: str, samples: int
    ) -> Diagnosis:
        """A diagnosis without numbers: every element inconclusive for ``reason``."""
        elements = {
            name: ElementDiagnosis(name, i, k, model, method, reasons=(reason,))
            for name, (i, k, model) in models.items()
        }
        return cls(method, "insufficient_data", reason, samples, elements)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: status, reason, samples, method and every element's :meth:`ElementDiagnosis.to_dict`."""
        return {
            "status": self.status,
            "reason": self.reason,
            "samples": self.samples,
            "method": self.method,
            "impact": None if self.impact is None else _plain(self.impact),
            "elements": {name: e.to_dict() for name, e in self.elements.items()},
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Diagnosis:
        """Inverse of :meth:`to_dict`."""
        elements = {name: ElementDiagnosis.from_dict(e) for name, e in data["elements"].items()}
        impact = None if data.get("impact") is None else _build(ImpactResult, data["impact"])
        status, reason, samples = str(data["status"]), str(data.get("reason", "")), int(data.get("samples", 0))
        return cls(str(data["method"]), status, reason, samples, elements, impact=impact)


DERIVED_KEYS = ("summary",)
"""Serialised keys that are derived text of numbers already compared (never compared themselves)."""

LATER_KEYS = ("data_quality",)
"""Parts that a diagnosis recorded by an earlier pmr_ros lacks (absent or None): compared only when both have them.

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
    its :meth:`~Diagnosis.to_dict` (e.g. read back from JSON).

    Returns
    -------
    list of str
        One line per difference, ``elements.G12.parametric.gain_mismatch_pct: 15.3 != 15.4``.

    Examples
    --------
    >>> compare_diagnoses({"x": 1.0}, {"x": 1.0 + 1e-12})
    []
    """
    a = first.to_dict() if isinstance(first, Diagnosis) else first
    b = second.to_dict() if isinstance(second, Diagnosis) else second
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
        if key in DERIVED_KEYS or (key in LATER_KEYS and (a.get(key) is None or b.get(key) is None)):
            continue
        where = f"{path}.{key}" if path else str(key)
        if key not in a or key not in b:
            out.append(f"{where}: only in {'the first' if key in a else 'the second'}")
        else:
            _compare(a[key], b[key], where, tolerance, out)


def _numbers_agree(a: Any, b: Any, rtol: float, atol: float) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return False
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return math.isclose(a, b, rel_tol=rtol, abs_tol=atol)
