"""The method-neutral per-element outcome every peer method returns, and the verdict rule the quantifying ones share.

A :class:`PeerOutcome` is one element's answer from one method: detected or
not, a score for ROC curves, and -- where the method quantifies -- dK %,
dtau %, dD with intervals and verdicts.  :func:`from_diagnosis` turns a
project :class:`~pmr_ros.core.results.Diagnosis` (classic or parametric PMR)
into the same shape, so a benchmark calls every method the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = ["SCORE_KINDS", "PeerOutcome", "Tolerances", "from_diagnosis", "overall_verdict"]

SCORE_KINDS = ("p_value", "statistic")
"""``p_value``: smaller is stronger evidence of a mismatch; ``statistic``: larger is."""


@dataclass(frozen=True)
class Tolerances:
    """The verdict rule's numbers (the ``parametric`` block of the configuration).

    Attributes
    ----------
    gain_pct, tau_pct : float
        Practical tolerances on dK and dtau [%].
    ok_band_factor : float
        ``ok`` needs the interval within this many tolerances of zero.
    max_interval_pct : float
        ``ok`` needs a half width no larger than this [percentage points].
    confidence_level : float
        Of the intervals, e.g. 0.95.
    delay_confidence_min : float
        A delay verdict needs this profile-likelihood confidence (0..1).
    """

    gain_pct: float = 3.0
    tau_pct: float = 5.0
    ok_band_factor: float = 2.0
    max_interval_pct: float = 15.0
    confidence_level: float = 0.95
    delay_confidence_min: float = 0.95

    @classmethod
    def from_settings(cls, settings: Any) -> Tolerances:
        """From a ``ParametricSettings`` (``config.parametric``), read by attribute name."""
        return cls(
            gain_pct=float(settings.gain_tolerance_pct),
            tau_pct=float(settings.tau_tolerance_pct),
            ok_band_factor=float(settings.ok_band_factor),
            max_interval_pct=float(settings.max_interval_pct),
            confidence_level=float(settings.confidence_level),
            delay_confidence_min=float(settings.delay_confidence_min),
        )


@dataclass(frozen=True)
class PeerOutcome:
    """One method's answer on one element ``G_ik``.

    Attributes
    ----------
    element : str
        ``G21`` style name.
    row, column : int
        Zero-based output i and input k.
    method : str
        ``partial_correlation``, ``pem_oe``, ``pem_bj``, ``classic`` or ``parametric``.
    detected : bool
        The method flags a mismatch on this element.
    score : float
        Evidence for ROC curves, of kind :attr:`score_kind`; NaN where there is none.
    score_kind : str
        One of :data:`SCORE_KINDS`.
    verdict : str
        ``ok``, ``mismatch`` or ``inconclusive``.
    gain_pct, tau_pct : float or None
        Estimated dK = (K - Khat)/Khat and dtau [%]; None where not quantified.
    gain_interval, tau_interval : (float, float) or None
        Their confidence intervals [%].
    delay_samples : int or None
        Estimated dD = D - Dhat [samples].
    gain_verdict, tau_verdict, delay_verdict : str or None
        Per-parameter verdicts where the method gives them.
    reasons : tuple of str
        Why an element is inconclusive, in words.
    """

    element: str
    row: int
    column: int
    method: str
    detected: bool
    score: float
    score_kind: str
    verdict: str
    gain_pct: float | None = None
    gain_interval: tuple[float, float] | None = None
    tau_pct: float | None = None
    tau_interval: tuple[float, float] | None = None
    delay_samples: int | None = None
    gain_verdict: str | None = None
    tau_verdict: str | None = None
    delay_verdict: str | None = None
    reasons: tuple[str, ...] = ()

    @property
    def evidence(self) -> float:
        """:attr:`score` as larger-is-stronger (``-log10 p`` for a p-value), for one ROC code path."""
        if self.score_kind == "p_value":
            return -math.log10(max(self.score, 1e-300)) if math.isfinite(self.score) else math.nan
        return self.score


def overall_verdict(*verdicts: str | None) -> str:
    """``mismatch`` if any parameter is, else ``inconclusive`` if any is, else ``ok`` (None: does not apply)."""
    if "mismatch" in verdicts:
        return "mismatch"
    return "inconclusive" if "inconclusive" in verdicts else "ok"


def _classic_outcome(name: str, row: int, column: int, part: Any) -> PeerOutcome:
    """The classic Table 1 result: flags, ``|M(0) - 1|`` as the score, dK from M(0) without an interval."""
    flags = ("mismatch" if part.gain_mismatch else "ok", "mismatch" if part.tau_mismatch else "ok")
    delay = "mismatch" if part.delay_mismatch else "ok"
    verdict = "inconclusive" if part.reasons else overall_verdict(*flags, delay)
    return PeerOutcome(
        element=name,
        row=row,
        column=column,
        method="classic",
        detected=verdict == "mismatch",
        score=abs(float(part.gain_ratio) - 1.0),
        score_kind="statistic",
        verdict=verdict,
        gain_pct=100.0 * (float(part.gain_ratio) - 1.0),
        delay_samples=int(part.delay_mismatch_samples),
        gain_verdict=flags[0],
        tau_verdict=None if part.tau_index is None else flags[1],
        delay_verdict=delay,
        reasons=tuple(part.reasons),
    )


def _parametric_score(part: Any) -> float:
    """Largest standardized gain or time-constant change (estimate over half the interval, times z)."""
    z = 1.96  # the intervals are ~normal at the configured level; the score only orders elements
    best = 0.0
    for value, interval in (
        (part.gain_mismatch_pct, part.gain_mismatch_pct_interval),
        (part.tau_mismatch_pct, part.tau_mismatch_pct_interval),
    ):
        if value is None or interval is None:
            continue
        half = (interval[1] - interval[0]) / 2.0
        if half > 0 and math.isfinite(half):
            best = max(best, abs(value) * z / half)
    return best


def _parametric_outcome(name: str, row: int, column: int, part: Any) -> PeerOutcome:
    verdict = part.verdict
    return PeerOutcome(
        element=name,
        row=row,
        column=column,
        method="parametric",
        detected=verdict == "mismatch",
        score=_parametric_score(part),
        score_kind="statistic",
        verdict=verdict,
        gain_pct=part.gain_mismatch_pct,
        gain_interval=part.gain_mismatch_pct_interval,
        tau_pct=part.tau_mismatch_pct,
        tau_interval=part.tau_mismatch_pct_interval,
        delay_samples=part.delay_mismatch_samples,
        gain_verdict=part.gain_verdict,
        tau_verdict=part.tau_verdict,
        delay_verdict=part.delay_verdict,
        reasons=tuple(part.reasons),
    )


def from_diagnosis(diagnosis: Any) -> dict[str, PeerOutcome]:
    """A project ``Diagnosis`` (classic or parametric PMR) as :class:`PeerOutcome` per element, row-major.

    Elements without a result (insufficient data, an empty cell the classic
    method does not test) are ``inconclusive`` with their reasons.
    """
    out = {}
    for e in diagnosis.elements.values():
        part = e.result
        if part is None:
            out[e.name] = PeerOutcome(
                e.name,
                e.row,
                e.column,
                e.method,
                False,
                math.nan,
                "statistic",
                "inconclusive",
                reasons=tuple(e.all_reasons),
            )
        elif e.method == "classic":
            out[e.name] = _classic_outcome(e.name, e.row, e.column, part)
        else:
            out[e.name] = _parametric_outcome(e.name, e.row, e.column, part)
    return out
