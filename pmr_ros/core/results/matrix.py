"""The diagnosis of each element and of the whole model matrix: built once, never mutated.

A :class:`Diagnosis` holds one :class:`ElementDiagnosis` per element of the
controller's model.  Each element keeps its model element and the outcome of
each method that ran (:mod:`.findings`); ``method`` says which of them gives
the element's verdict.  Their flat forms (JSON, KeyValues, estimates, CSV)
are made by :mod:`.codec`, the one place that spells them.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from .findings import ClassicResult, DataQuality, ElementModel, ImpactResult, ParametricResult

__all__ = ["Diagnosis", "ElementDiagnosis", "Part"]

Part = ClassicResult | ParametricResult


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

    def verdict_counts(self) -> str:
        """``1 mismatch, 0 inconclusive, 3 ok of 4 modeled elements``: the verdicts in one line.

        Empty cells are counted apart, with those where an interaction the model lacks was found.
        """
        counts = {"mismatch": 0, "inconclusive": 0, "ok": 0}
        empty = lacking = 0
        for element in self:
            if element.model.kind == "none":
                empty += 1
                lacking += element.verdict == "mismatch"
            else:
                counts[element.verdict] = counts.get(element.verdict, 0) + 1
        told = ", ".join(f"{n} {verdict}" for verdict, n in counts.items())
        line = f"{told} of {sum(counts.values())} modeled elements"
        return line + (f"; {empty} empty cells, {lacking} with an interaction the model lacks" if empty else "")

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
