"""The parametric diagnosis of every element: guard, row fits, calibrated verdicts.

Confidence: the Gauss-Newton covariance of each row's fit, inflated by the bin
correlation of the Welch window (neighbouring bins are not independent) and by
the fit's reduced chi-square when that exceeds one; 95 % intervals are normal
on ``rho`` and on ``log tau``.  The delay's confidence is the profile
likelihood of the chosen ``dD`` against its neighbours, on the same scale.
"""

from __future__ import annotations

import numpy as np

from ..classic import PmrSettings, classic_estimate, classic_results
from ..delay import hamon_hannan_delay, informative_band
from ..foptd import FoptdMatrix
from ..implicit import PmrEstimate, implicit_estimate
from ..record import MIN_SEGMENTS, InsufficientData, check_record
from ..results import ClassicResult, Diagnosis, ElementDiagnosis, ParametricResult
from ..spectra import RecordSpectra, record_spectra
from .fit import fit_row
from .guard import RowQuality, row_quality
from .settings import ParametricSettings
from .verdicts import element_result

__all__ = ["diagnose_parametric", "parametric_results"]


def _delay_start(i: int, *, spectra: RecordSpectra, estimate: PmrEstimate, classic: PmrSettings) -> np.ndarray:
    """The classic Hamon-Hannan delay of each element of row ``i``: where the search starts."""
    coherence = estimate.coherence[:, i]
    band = informative_band(spectra.omega, coherence, classic.coherence_min)
    band &= spectra.omega > 0
    n_in = estimate.ratio.shape[2]
    return np.array(
        [
            hamon_hannan_delay(spectra.omega, estimate.ratio[:, i, k], coherence, classic.max_delay_samples, band)[0]
            for k in range(n_in)
        ]
    )


def _row_results(
    i: int,
    quality: RowQuality,
    *,
    spectra: RecordSpectra,
    estimate: PmrEstimate,
    model: FoptdMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> list[ParametricResult]:
    fit = None
    if not quality.reasons:
        delay_start = _delay_start(i, spectra=spectra, estimate=estimate, classic=classic)
        fit = fit_row(
            spectra,
            model,
            row=i,
            theta_start=estimate.ratio[:, i, :],
            delay_start=delay_start,
            max_delay_samples=classic.max_delay_samples,
            bins=quality.bins,
        )
    out = []
    for k in range(model.n_inputs):
        figures = quality.quality(k, omega=spectra.omega, welch=spectra.settings)
        reasons = quality.element_reasons(k, settings)
        if fit is None or reasons:
            out.append(ParametricResult(reasons=reasons, warnings=quality.warnings, quality=figures))
        else:
            out.append(element_result(fit, k, settings=settings, quality=figures, warnings=quality.warnings))
    return out


def parametric_results(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: FoptdMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> dict[str, ParametricResult]:
    """The parametric result of every element of a record that passed the classic checks.

    Raises
    ------
    InsufficientData
        The parametric Welch segment leaves fewer than :data:`MIN_SEGMENTS` segments.
    """
    welch = settings.welch(model, r.shape[0], classic)
    usable = r.shape[0] - model.settling_samples()
    if welch.segments(usable) < MIN_SEGMENTS:
        raise InsufficientData(
            f"parametric.segment_length {welch.segment_length} leaves {welch.segments(usable)} Welch segments in "
            f"{usable} usable samples, need {MIN_SEGMENTS}: shorten it (0 picks one from the model)"
        )
    spectra = record_spectra(r, u, y, model, welch)
    estimate = implicit_estimate(spectra)
    names = model.element_names()
    out: dict[str, ParametricResult] = {}
    for i in range(model.n_outputs):
        quality = row_quality(i, spectra=spectra, estimate=estimate, model=model, classic=classic, settings=settings)
        results = _row_results(
            i, quality, spectra=spectra, estimate=estimate, model=model, classic=classic, settings=settings
        )
        out.update(zip(names[i * model.n_inputs : (i + 1) * model.n_inputs], results, strict=True))
    return out


def _classic_part(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, classic: PmrSettings
) -> dict[str, ClassicResult | None]:
    """The classic numbers kept beside the parametric ones; None where the classic method cannot give them."""
    try:
        estimate = classic_estimate(r, u, y, model=model, settings=classic)
    except InsufficientData:
        # the classic method refuses an ill-conditioned record as a whole; the parametric guard judges it row by row
        return dict.fromkeys(model.element_names())
    return dict(classic_results(estimate, model, classic))


def diagnose_parametric(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: FoptdMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> Diagnosis:
    """Parametric diagnosis of every element with intervals and calibrated verdicts.

    The record is checked as for every method (:func:`~pmr_ros.core.record.check_record`);
    the classic numbers stay beside the parametric ones (``ElementDiagnosis.classic``)
    for reference where the classic method can give them.

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : FoptdMatrix
        The controller's model ``Ghat``.
    classic : PmrSettings
        Window, overlap, delay range and classic thresholds.
    settings : ParametricSettings

    Returns
    -------
    Diagnosis
        With ``method == "parametric"``; ``insufficient_data`` with the reason
        when the record cannot support a diagnosis.
    """
    r, u, y = (np.asarray(a, dtype=float) for a in (r, u, y))
    samples = int(r.shape[0]) if r.ndim else 0
    models = model.element_models()
    try:
        check_record(r, u, y, model=model, welch=classic.welch)
        results = parametric_results(r, u, y, model=model, classic=classic, settings=settings)
    except InsufficientData as exc:
        return Diagnosis.insufficient(method="parametric", models=models, reason=str(exc), samples=samples)
    classic_part = _classic_part(r, u, y, model=model, classic=classic)
    elements = {
        name: ElementDiagnosis(name, i, k, element, "parametric", classic=classic_part[name], parametric=results[name])
        for name, (i, k, element) in models.items()
    }
    return Diagnosis("parametric", "ok", "", samples, elements)
