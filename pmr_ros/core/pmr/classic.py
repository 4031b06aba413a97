"""The classic PMR diagnosis of the paper's Table 1, and the spectral settings both methods share.

Per element: the gain ratio from ``G_PMR(0)``, the time-constant index
``-100 x`` the slope of ``M(w)/M(0)`` on ``(0, tau_band]``, and the delay
mismatch from the Hilbert/Hamon-Hannan search (:mod:`pmr_ros.core.pmr.delay`).
An integrating element's ratio is ``(K/Khat) z^-dD``: gain and delay, no
time-constant index; its row is differenced, so its gain is read at the
lowest nonzero bin.  The classic regression holds the modeled elements only,
as the paper's: an empty cell's regressor would share the zero bin with them,
where an offset-free controller ties the inputs to the setpoints (measured
on a 3 x 5: M(0) off by 10-25 % without noise), so empty cells are left to
the parametric method, which weighs every bin by what it knows.  A delay
found at the edge of the search makes the element inconclusive.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..records import Record, total_samples
from ..results import ClassicResult, Diagnosis, ElementDiagnosis
from ..sim.model import TransferMatrix
from .checks import InsufficientData
from .delay import hamon_hannan_delay, informative_band, search_limit_reason
from .implicit import PmrEstimate, estimate_pmr
from .spectra import WelchSettings

__all__ = [
    "MAX_CONDITION",
    "PmrSettings",
    "classic_estimate",
    "classic_results",
    "diagnose_classic",
    "gain_bin",
    "readable",
    "row_refusal",
]

MAX_CONDITION = 1e6
"""Largest condition number of a row regression the classic method accepts in its band."""

NOT_TESTED = (
    "the classic method does not test empty cells (its one-bin M(0) cannot separate an unmodeled interaction "
    "in closed loop); the parametric method does"
)
"""Why an empty cell has no classic result."""


@dataclass(frozen=True)
class PmrSettings:
    """Spectral estimate and classic-diagnosis thresholds (the ``pmr`` block).

    Defaults and ranges: ``config/parameters.yaml``.

    Attributes
    ----------
    method : str
        ``classic`` or ``parametric``: which method gives the verdicts.
    window, segment_length, overlap
        Welch estimator (see :class:`~pmr_ros.core.pmr.spectra.WelchSettings`).
    tau_band : float
        Upper end of the band of the time-constant slope fit [rad/sample]
        (0.4, after Yerramilli & Tangirala 2018).
    gain_tolerance : float
        ``|M(0) - 1|`` above this is a gain mismatch.
    tau_index_threshold : float
        ``|tau index|`` above this is a time-constant mismatch.
    max_delay_samples : int
        Delay mismatches searched over ``-max .. +max`` samples (both methods).
    coherence_min : float
        The delay search uses the band from 0 up to where the row's squared
        coherence with the setpoints first falls below this.
    delay_fit_min : float
        An element whose best delay leaves a coherence-weighted mean cosine of
        the residual phase below this is inconclusive (no delay in the range
        explains its phase).
    """

    method: str
    window: str
    segment_length: int
    overlap: float
    tau_band: float
    gain_tolerance: float
    tau_index_threshold: float
    max_delay_samples: int
    coherence_min: float
    delay_fit_min: float

    @property
    def welch(self) -> WelchSettings:
        """The Welch estimator of the classic method."""
        return WelchSettings(self.window, self.segment_length, self.overlap)


def gain_bin(differenced: bool) -> int:
    """The bin a gain is read from: 0, or the lowest nonzero one in a differenced row (``Delta(0) = 0``)."""
    return 1 if differenced else 0


def _low_frequency_value(response: np.ndarray, differenced: bool) -> float:
    """``M(0)``: the zero bin's real part, or in a differenced row the lowest bin's magnitude with its sign.

    A differenced row has nothing at 0; at the lowest nonzero bin a delay
    mismatch turns the response by ``dD w_1`` (0.25 rad for 20 samples at
    ``w_1 = 2 pi / 512``), which the magnitude ignores.
    """
    value = response[gain_bin(differenced)]
    if not differenced:
        return float(value.real)
    return float(np.abs(value) * (1.0 if value.real >= 0 else -1.0))


@dataclass(frozen=True)
class _RowView:
    """What the classic method reads of one row of an estimate."""

    omega: np.ndarray
    coherence: np.ndarray
    differenced: bool
    band: np.ndarray
    delay_band: np.ndarray


def _row_view(estimate: PmrEstimate, i: int, settings: PmrSettings) -> _RowView:
    omega = estimate.omega
    return _RowView(
        omega=omega,
        coherence=estimate.coherence[:, i],
        differenced=bool(estimate.differenced[i]),
        band=(omega > 0) & (omega <= settings.tau_band + 1e-12),
        delay_band=informative_band(omega, estimate.coherence[:, i], settings.coherence_min),
    )


def _element_result(response: np.ndarray, view: _RowView, kind: str, settings: PmrSettings) -> ClassicResult:
    """Table 1 of a modeled element: gain ratio, tau index (FOPTD only), delay."""
    gain_ratio = _low_frequency_value(response, view.differenced)
    tau_index = None
    if kind == "foptd":
        slope = np.polyfit(view.omega[view.band], np.abs(response[view.band]) / abs(gain_ratio), 1)[0]
        tau_index = float(-100.0 * slope)
    limit = settings.max_delay_samples
    delay, cost = hamon_hannan_delay(view.omega, response, view.coherence, limit, view.delay_band)
    reasons = [search_limit_reason(delay, low=-limit, high=limit)]
    if cost.max() < settings.delay_fit_min:
        reasons.append(
            f"no delay within ±{limit} samples explains the phase (fit {cost.max():.2f} < {settings.delay_fit_min:g}): "
            "a delay beyond pmr.max_delay_samples, or an element of another structure"
        )
    return ClassicResult(
        gain_ratio=gain_ratio,
        tau_index=tau_index,
        delay_mismatch_samples=delay,
        gain_mismatch=bool(abs(gain_ratio - 1.0) > settings.gain_tolerance),
        tau_mismatch=bool(tau_index is not None and abs(tau_index) > settings.tau_index_threshold),
        delay_mismatch=delay != 0,
        reasons=tuple(r for r in reasons if r is not None),
    )


def row_refusal(estimate: PmrEstimate, i: int, settings: PmrSettings) -> str | None:
    """Why the classic method cannot read row ``i`` (not identifiable, ill-conditioned), or None."""
    layout = estimate.layouts[i]
    if layout.reasons:
        return layout.reasons[0]
    omega = estimate.omega
    used = (omega > 0) & (omega <= settings.tau_band + 1e-12)
    used[gain_bin(bool(estimate.differenced[i]))] = True
    worst = float(estimate.condition_at(np.flatnonzero(used), i).max())
    if not np.isfinite(worst) or worst > MAX_CONDITION:
        return (
            f"ill-conditioned regression of row {i + 1} (condition number {worst:.3g} > {MAX_CONDITION:g}): "
            "the instruments do not excite its inputs independently"
        )
    return None


def classic_results(
    estimate: PmrEstimate, model: TransferMatrix, settings: PmrSettings
) -> dict[str, ClassicResult | tuple[str, ...]]:
    """Table 1 per modeled element from a PMR estimate: gain ratio, tau index, delay and their flags.

    Parameters
    ----------
    estimate : PmrEstimate
    model : TransferMatrix
        The controller's model (element names and kinds).
    settings : PmrSettings
        Thresholds, tau band and delay search.

    Returns
    -------
    dict
        Element name to :class:`ClassicResult`, row-major; to the reasons
        instead where it gives none (an empty cell, a row that is not
        identifiable or ill-conditioned).
    """
    out: dict[str, ClassicResult | tuple[str, ...]] = {}
    refusals: dict[int, str | None] = {}  # a row's refusal and view serve each of its elements
    views: dict[int, _RowView] = {}
    for name, (i, k, element) in model.element_models().items():
        if i not in refusals:
            refusals[i] = row_refusal(estimate, i, settings)
        refusal = refusals[i] or estimate.layouts[i].missing(k)
        if element.kind == "none":
            out[name] = (NOT_TESTED,)
        elif refusal is not None:
            out[name] = (refusal,)
        else:
            if i not in views:
                views[i] = _row_view(estimate, i, settings)
            out[name] = _element_result(estimate.ratio[:, i, k], views[i], element.kind, settings)
    return out


def classic_estimate(stretches: Sequence[Record], *, model: TransferMatrix, settings: PmrSettings) -> PmrEstimate:
    """The PMR estimate of the classic method, refused when no row can be read.

    Raises
    ------
    InsufficientData
        The record cannot support it (the message says why): every row is
        unidentifiable or ill-conditioned.
    """
    estimate = estimate_pmr(stretches, model=model, welch=settings.welch, test_empty=False)
    return readable(estimate, settings)


def readable(estimate: PmrEstimate, settings: PmrSettings) -> PmrEstimate:
    """``estimate`` if the classic method can read at least one of its rows.

    Raises
    ------
    InsufficientData
        Every row is unidentifiable or ill-conditioned (the first one's reason).
    """
    refusals = [row_refusal(estimate, i, settings) for i in range(estimate.ratio.shape[1])]
    if all(refusals):
        raise InsufficientData(str(refusals[0]))
    return estimate


def diagnose_classic(stretches: Sequence[Record], *, model: TransferMatrix, settings: PmrSettings) -> Diagnosis:
    """Classic (Table 1) diagnosis of every element from closed-loop records.

    Parameters
    ----------
    stretches : sequence of Record
        Unbroken stretches of setpoints, inputs, outputs (and dither), one row per sample.
    model : TransferMatrix
        The controller's model ``Ghat``.
    settings : PmrSettings

    Returns
    -------
    Diagnosis
        ``status`` ``insufficient_data`` (with the reason, no numbers) when the
        data cannot support one; elements the data cannot read are
        inconclusive with the reason.
    """
    samples = total_samples(stretches)
    models = model.element_models()
    try:
        estimate = classic_estimate(stretches, model=model, settings=settings)
    except InsufficientData as exc:
        return Diagnosis.insufficient(method="classic", models=models, reason=str(exc), samples=samples)
    results = classic_results(estimate, model, settings)
    elements = {}
    for name, (i, k, element) in models.items():
        result = results[name]
        if isinstance(result, ClassicResult):
            elements[name] = ElementDiagnosis(name, i, k, element, "classic", classic=result)
        else:
            elements[name] = ElementDiagnosis(name, i, k, element, "classic", reasons=result)
    return Diagnosis("classic", "ok", "", samples, elements, estimate)
