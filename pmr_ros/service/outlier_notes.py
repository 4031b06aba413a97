"""Where the gross outliers dropped from a historian export still matter, the inconclusive verdicts name them.

Cleaning drops a cell far beyond what its tag ever moves (:mod:`pmr_ros.data.outliers`),
so a sentinel no longer swamps the spectra; but each dropped cell breaks the
record, and every stretch loses the model's settling and the end of its last
segment.  When that costs Welch segments, or an element of the affected row
(an output's outliers) or input (an input's; an instrument's, a setpoint or a dither, every row)
still ends ``inconclusive``, its reason says so, e.g. ``3 gross outliers
dropped from y1 (x_D, column XI101.PV) split the data into 4 stretches: 5
Welch segments of 512 fewer than unbroken``; with too little data for any
verdict the diagnosis's reason says it.  Verdicts are never changed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..config import PmrConfig
from ..core.pmr.checks import welch_segments
from ..core.pmr.diagnosis import stretches_welch
from ..core.results import Diagnosis, ElementDiagnosis
from ..data import PlantData

__all__ = ["OutlierCost", "outlier_cost", "with_outlier_reasons"]

INSTRUMENTS = ("r", "dither")
"""Signals every row of the diagnosis regresses on: their outliers concern every element."""


def _touches(key: tuple[str, int], row: int, column: int) -> bool:
    """Whether outliers of channel ``key`` bear on element ``(row, column)``: an instrument, its output or input."""
    signal, j = key
    return signal in INSTRUMENTS or (signal == "y" and j == row) or (signal == "u" and j == column)


@dataclass(frozen=True)
class OutlierCost:
    """The gross outliers dropped and what dropping them cost the diagnosis.

    Attributes
    ----------
    counts : dict
        ``(signal, channel)`` (``("y", 0)``) to the cells dropped there; only channels with some.
    labels : dict
        The same keys to ``y1 (x_D, column XI101.PV)``.
    stretches : int
        Unbroken stretches of the cleaned data.
    segments_lost : int
        Welch segments (of ``segment_length``) the data would give had the
        outliers been values, less those they give; 0 when the breaks cost none.
    segment_length : int
    """

    counts: dict[tuple[str, int], int]
    labels: dict[tuple[str, int], str]
    stretches: int
    segments_lost: int
    segment_length: int

    def concerns(self, row: int, column: int) -> bool:
        """Whether element ``(row, column)`` is concerned: the breaks cost segments, or outliers on its channels."""
        return self.segments_lost > 0 or any(_touches(key, row, column) for key in self.counts)

    def reason(self, row: int | None = None, column: int | None = None) -> str:
        """The reason's text, naming the channels that concern element ``(row, column)`` (all: None)."""
        keys = list(self.counts)
        if self.segments_lost == 0 and row is not None and column is not None:
            keys = [key for key in keys if _touches(key, row, column)]
        total = sum(self.counts[k] for k in keys)
        if len(keys) == 1:
            where = self.labels[keys[0]]
        else:
            where = ", ".join(f"{self.labels[k]}: {self.counts[k]}" for k in keys)
        text = f"{total} gross outlier{'s' if total > 1 else ''} dropped from {where}"
        if self.segments_lost > 0:
            lost = self.segments_lost
            text += (
                f" split the data into {self.stretches} stretches: {lost} Welch segment{'s' if lost > 1 else ''} "
                f"of {self.segment_length} fewer than unbroken"
            )
        return text


def _labels(data: PlantData, config: PmrConfig, keys: list[tuple[str, int]]) -> dict[tuple[str, int], str]:
    model = config.model
    names = {"r": model.output_names, "y": model.output_names, "u": model.input_names, "dither": model.input_names}
    return {(s, j): f"{s}{j + 1} ({names[s][j]}, column {data.columns[s][j]})" for s, j in keys}


def outlier_cost(data: PlantData, config: PmrConfig, *, method: str | None = None) -> OutlierCost | None:
    """What the gross outliers dropped from ``data`` cost a diagnosis with ``method``; None when none were dropped.

    Parameters
    ----------
    data : PlantData
        Cleaned data with their :attr:`~pmr_ros.data.PlantData.outliers`.
    config : PmrConfig
        The model and the spectral settings (the segments averaged).
    method : str, optional
        The diagnosis method (default ``config.pmr.method``).
    """
    counts = {
        (signal, j): int(n)
        for signal, mask in data.outliers.items()
        for j, n in enumerate(np.asarray(mask).sum(axis=0))
        if n
    }
    if not counts:
        return None
    broken = [b - a for a, b in data.stretch_bounds()]
    whole = [b - a for a, b in data.bounds_had_outliers_been_valid()]
    welch = stretches_welch(
        data.stretches(), model=config.model, pmr=config.pmr, parametric=config.parametric, method=method
    )
    lost = welch_segments(whole, model=config.model, welch=welch) - welch_segments(
        broken, model=config.model, welch=welch
    )
    return OutlierCost(counts, _labels(data, config, list(counts)), len(broken), max(lost, 0), welch.segment_length)


def _with_reason(element: ElementDiagnosis, reason: str) -> ElementDiagnosis:
    if element.classic is not None and element.method == "classic":
        return replace(element, classic=replace(element.classic, reasons=(*element.classic.reasons, reason)))
    if element.parametric is not None and element.method == "parametric":
        return replace(element, parametric=replace(element.parametric, reasons=(*element.parametric.reasons, reason)))
    return replace(element, reasons=(*element.reasons, reason))


def with_outlier_reasons(diagnosis: Diagnosis, cost: OutlierCost | None) -> Diagnosis:
    """``diagnosis`` whose inconclusive elements that the dropped outliers concern name them (verdicts unchanged).

    Without a verdict (too little data) the diagnosis's reason and every
    element's name them when their breaks cost segments.

    Parameters
    ----------
    diagnosis : Diagnosis
    cost : OutlierCost or None
        :func:`outlier_cost` of the diagnosed data.
    """
    if cost is None:
        return diagnosis
    if diagnosis.status != "ok":
        if cost.segments_lost == 0:
            return diagnosis
        text = cost.reason()
        elements = {name: _with_reason(e, text) for name, e in diagnosis.elements.items()}
        return replace(diagnosis, reason=f"{diagnosis.reason}; {text}", elements=elements)
    elements = dict(diagnosis.elements)
    for name, e in diagnosis.elements.items():
        if e.verdict == "inconclusive" and cost.concerns(e.row, e.column):
            elements[name] = _with_reason(e, cost.reason(e.row, e.column))
    return replace(diagnosis, elements=elements)
