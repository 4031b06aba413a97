"""The parametric diagnosis of every element: guard, row fits, calibrated verdicts.

Confidence: the Gauss-Newton covariance of each row's fit, inflated by the bin
correlation of the Welch window (neighbouring bins are not independent) and by
the fit's reduced chi-square when that exceeds one; 95 % intervals are normal
on ``rho`` and on ``log tau``.  The delay's confidence is the profile
likelihood of the chosen ``dD`` against its neighbours, on the same scale.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ...records import InstrumentSet, Record, moving_instruments, total_samples
from ...results import ClassicResult, Diagnosis, ElementDiagnosis, ParametricResult
from ...sim.model import TransferMatrix
from ..checks import InsufficientData, check_stretches
from ..classic import PmrSettings, classic_estimate, classic_results, readable
from ..implicit import (
    EstimateBuilder,
    PmrEstimate,
    RowEstimate,
    RowLayout,
    row_estimate,
    row_layout,
    spectra_factor,
)
from ..spectra import RecordSpectra, RowSpectra, WelchSettings, record_spectra
from .attribution import instrument_shares, with_attribution
from .fit import RowData, RowFit, column_models, fit_row
from .guard import RowQuality, row_quality
from .interaction import interaction_result
from .settings import ParametricSettings
from .verdicts import element_result

__all__ = ["diagnose_parametric", "parametric_results"]


def _without_numbers(kind: str, reasons: tuple[str, ...], warnings: tuple[str, ...], figures: dict) -> ParametricResult:
    """An inconclusive result of an element of ``kind``; the verdicts that do not apply are None."""
    if kind == "none":
        return ParametricResult(
            gain_verdict=None,
            tau_verdict=None,
            delay_verdict=None,
            unmodeled_verdict="inconclusive",
            reasons=reasons,
            warnings=warnings,
            quality=figures,
        )
    tau = "inconclusive" if kind == "foptd" else None
    return ParametricResult(tau_verdict=tau, reasons=reasons, warnings=warnings, quality=figures)


@dataclass(frozen=True)
class _FittedRow:
    """One output row judged and (when the guard lets it) fitted."""

    layout: RowLayout
    estimate: RowEstimate
    quality: RowQuality
    fit: RowFit | None
    fitted: np.ndarray
    """The layout's columns (input indices) the fit has: all but those whose model gain is ~0."""
    shares: np.ndarray
    """Each instrument's share of each layout column's instrument-driven power, shape (n_z, n_columns)."""

    def fit_column(self, k: int) -> int:
        """The fit's column of input ``k``."""
        return int(np.flatnonzero(self.fitted == k)[0])


def _fit(
    i: int,
    row: RowSpectra,
    *,
    spectra: RecordSpectra,
    factor: np.ndarray,
    model: TransferMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> _FittedRow:
    """Row ``i``'s layout, implicit estimate (from its spectra ``row``), guard and, when the guard passes it, fit."""
    layout = row_layout(model, i, **spectra.layout_inputs)
    estimate = row_estimate(spectra, i, layout.columns, row=row)
    quality = row_quality(layout, estimate, omega=spectra.omega, model=model, classic=classic, settings=settings)
    shares = instrument_shares(row.zx[:, :, layout.columns], spectra.rr, quality.bins)
    if quality.reasons:
        return _FittedRow(layout, estimate, quality, None, layout.columns, shares)
    kept = ~quality.negligible
    fitted = RowLayout(i, layout.columns[kept])
    data = RowData(
        spectra=row,
        factor=factor,
        columns=fitted.columns,
        bins=quality.bins,
        omega=spectra.omega,
        equivalent_segments=spectra.equivalent_segments,
        bin_correlation=spectra.settings.bin_correlation,
        record=spectra,
        row=i,
        unbiased=True,
    )
    columns = column_models(model, fitted, max_delay_samples=classic.max_delay_samples)
    start = estimate.ratio[:, kept]
    search = {"joint_correlation": settings.joint_delay_correlation, "confidence_level": settings.confidence_level}
    fit = fit_row(data, columns, theta_start=start, **search)
    if not np.all(fit.lack_of_fit <= settings.lack_of_fit_max):
        # the bias correction takes what lies outside the instruments for noise; where the corrected fit leaves the
        # data, that part held more (the segments' leakage of strongly excited inputs, whose instruments are strong
        # and whose bias is small): the equations as they are
        fit = fit_row(replace(data, unbiased=False), columns, theta_start=start, **search)
    return _FittedRow(layout, estimate, quality, fit, fitted.columns, shares)


def _share_per_gain(row: _FittedRow, c: int, f: int, omega: np.ndarray) -> float:
    """RMS share of the row's instrument-driven output that a unit gain of the fitted template carries.

    ``c`` is the column in the row's layout, ``f`` in its fit.
    """
    assert row.fit is not None
    bins = row.quality.bins
    shape, _ = row.fit.columns[f].shapes(np.exp(-1j * omega[bins]), np.array([row.fit.s[f]]))
    driven = np.sum(np.abs(shape[0]) ** 2 * row.estimate.power[bins, c])
    return float(np.sqrt(driven / max(float(row.estimate.explained[bins].sum()), 1e-300)))


def _element(
    row: _FittedRow, k: int, kind: str, *, spectra: RecordSpectra, settings: ParametricSettings
) -> ParametricResult:
    """The result of input ``k`` of a fitted row, with the instruments that carried it (:mod:`.attribution`)."""
    result = _judged(row, k, kind, spectra=spectra, settings=settings)
    position = np.flatnonzero(row.layout.columns == k)
    if not position.size or not row.quality.bins.size:
        return result
    model = spectra.model
    labels = spectra.moving.labels(model.output_names, model.input_names, n_disturbances=model.n_disturbances)
    shares = {label: float(row.shares[j, position[0]]) for j, label in enumerate(labels)}
    return with_attribution(result, shares, samples=spectra.samples, sample_time=model.sample_time, settings=settings)


def _judged(
    row: _FittedRow, k: int, kind: str, *, spectra: RecordSpectra, settings: ParametricSettings
) -> ParametricResult:
    """The result of input ``k`` of a fitted row."""
    quality = row.quality
    position = np.flatnonzero(row.layout.columns == k)
    c = int(position[0]) if position.size else -1
    figures = quality.quality(c, omega=spectra.omega, welch=spectra.settings)
    still = row.layout.missing(k)
    if c < 0:
        why = (still,) if still else quality.reasons or (row.layout.untested,)
        return _without_numbers(kind, why, quality.warnings, figures)
    names = spectra.model.element_names()[row.layout.row * spectra.model.n_inputs :]  # built once: both read it
    reasons = quality.element_reasons(
        c, settings, modeled=kind != "none", input_name=spectra.model.input_names[k], element_name=names[k]
    )
    if row.fit is None or reasons:
        return _without_numbers(kind, reasons, quality.warnings, figures)
    f = row.fit_column(k)
    if kind == "none":
        share = _share_per_gain(row, c, f, spectra.omega)
        return interaction_result(
            row.fit, f, share_per_gain=share, settings=settings, quality=figures, warnings=quality.warnings
        )
    labels = [(names[m], spectra.model.input_names[m]) for m in row.fitted]
    return element_result(row.fit, f, settings=settings, quality=figures, warnings=quality.warnings, labels=labels)


def _checked_welch(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
    moving: InstrumentSet,
) -> WelchSettings:
    """The parametric Welch segments of ``stretches``, once the stretches pass the checks with them.

    Raises
    ------
    InsufficientData
        As :func:`~pmr_ros.core.pmr.checks.check_stretches` with these segments; with a
        ``parametric.segment_length`` set by hand, the reason says to shorten it.
    """
    welch = settings.welch_for(model, stretches, classic, moving=moving)
    try:
        check_stretches(stretches, model=model, welch=welch, moving=moving)
    except InsufficientData as exc:
        if settings.segment_length > 0 and "window too short" in str(exc):
            hint = "shorten parametric.segment_length (0 sizes it from the model and the record)"
            raise InsufficientData(f"{exc}: {hint}") from None
        raise
    return welch


def _results(
    stretches: Sequence[Record], *, model: TransferMatrix, classic: PmrSettings, settings: ParametricSettings
) -> tuple[dict[str, ParametricResult], PmrEstimate | None]:
    """The parametric results, and the classic estimate when both methods' segments agree (one transform per row)."""
    # the instruments once: the segment length, the checks and the spectra all need them (~6 ms a call on a 4x8
    # window of two weeks)
    moving = moving_instruments(stretches)
    welch = _checked_welch(stretches, model=model, classic=classic, settings=settings, moving=moving)
    spectra = record_spectra(stretches, model, welch, moving=moving)
    factor = spectra_factor(spectra)
    shared = EstimateBuilder(spectra) if welch == classic.welch else None
    names = model.element_names()
    out: dict[str, ParametricResult] = {}
    for i in range(model.n_outputs):
        row_spectra = spectra.row(i)
        if shared is not None:
            layout = row_layout(model, i, **spectra.layout_inputs, test_empty=False)
            shared.add(layout, row_estimate(spectra, i, layout.columns, row=row_spectra))
        row = _fit(i, row_spectra, spectra=spectra, factor=factor, model=model, classic=classic, settings=settings)
        kinds = [str(kind) for kind in model.element_type[i]]
        results = [_element(row, k, kind, spectra=spectra, settings=settings) for k, kind in enumerate(kinds)]
        out.update(zip(names[i * model.n_inputs : (i + 1) * model.n_inputs], results, strict=True))
    return out, None if shared is None else shared.build()


def parametric_results(
    stretches: Sequence[Record], *, model: TransferMatrix, classic: PmrSettings, settings: ParametricSettings
) -> dict[str, ParametricResult]:
    """The parametric result of every element of data that passed the record checks.

    Raises
    ------
    InsufficientData
        The stretches fail the checks with the parametric segments (:func:`_checked_welch`).
    """
    return _results(stretches, model=model, classic=classic, settings=settings)[0]


def _classic_part(
    stretches: Sequence[Record], *, model: TransferMatrix, classic: PmrSettings, estimate: PmrEstimate | None
) -> dict[str, ClassicResult | None]:
    """The classic numbers kept beside the parametric ones; None where the classic method cannot give them."""
    try:
        if estimate is None:
            estimate = classic_estimate(stretches, model=model, settings=classic)
        estimate = readable(estimate, classic)
    except InsufficientData:
        # the classic method refuses an ill-conditioned record as a whole; the parametric guard judges it row by row
        return dict.fromkeys(model.element_names())
    results = classic_results(estimate, model, classic)
    return {name: r if isinstance(r, ClassicResult) else None for name, r in results.items()}


def diagnose_parametric(
    stretches: Sequence[Record], *, model: TransferMatrix, classic: PmrSettings, settings: ParametricSettings
) -> Diagnosis:
    """Parametric diagnosis of every element with intervals and calibrated verdicts.

    The data are checked as for every method (:func:`~pmr_ros.core.pmr.checks.check_stretches`);
    the classic numbers stay beside the parametric ones (``ElementDiagnosis.classic``)
    for reference where the classic method can give them.

    Parameters
    ----------
    stretches : sequence of Record
        Unbroken stretches of setpoints, inputs, outputs (and dither), one row per sample.
    model : TransferMatrix
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
    samples = total_samples(stretches)
    models = model.element_models()
    try:
        results, estimate = _results(stretches, model=model, classic=classic, settings=settings)
    except InsufficientData as exc:
        return Diagnosis.insufficient(method="parametric", models=models, reason=str(exc), samples=samples)
    classic_part = _classic_part(stretches, model=model, classic=classic, estimate=estimate)
    elements = {
        name: ElementDiagnosis(name, i, k, element, "parametric", classic=classic_part[name], parametric=results[name])
        for name, (i, k, element) in models.items()
    }
    return Diagnosis("parametric", "ok", "", samples, elements)
