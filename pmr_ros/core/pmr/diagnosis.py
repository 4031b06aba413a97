"""One entry point for every diagnosis method, and the data-quality figures every method's result carries."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ..records import Record
from ..results import DataQuality, Diagnosis
from ..sim.augment import missing_disturbances, with_disturbances
from ..sim.model import TransferMatrix
from .classic import PmrSettings, diagnose_classic
from .data_quality import QualitySettings, RecordQuality, assess, element_warnings
from .parametric import ParametricSettings, diagnose_parametric
from .spectra import WelchSettings

__all__ = [
    "METHODS",
    "diagnose",
    "diagnose_stretches",
    "method_welch",
    "stretches_welch",
    "shortest_useful_stretch",
    "useful_stretches",
    "with_data_quality",
    "with_filtering_warnings",
]


def _classic(
    stretches: Sequence[Record], *, model: TransferMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_classic(stretches, model=model, settings=pmr)


def with_filtering_warnings(diagnosis: Diagnosis, model: TransferMatrix, *, limit: float) -> Diagnosis:
    """A classic diagnosis with a warning on each modeled element of a row whose time constants lie > ``limit``x apart.

    The classic PMR reads M(w) of a row through its elements' combined
    response: time constants far apart blur one element's tau index with the
    others' (the paper's filtering effect).  The parametric fit does not suffer
    from it and does not warn.  The warning joins the element's data-quality
    warnings (figures unknown where none were assessed).
    """
    elements = dict(diagnosis.elements)
    for i in range(model.n_outputs):
        taus = model.time_constant[i][model.element_type[i] == "foptd"]
        ratio = float(taus.max() / taus.min()) if taus.size else 1.0
        if ratio <= limit:
            continue
        text = f"row {i + 1} mixes time constants {ratio:.1f}x apart (> {limit:g}: the classic PMR's filtering effect)"
        for name, e in diagnosis.elements.items():
            if e.row == i and e.model.kind != "none":
                known = e.data_quality or DataQuality(None, None, None)
                elements[name] = replace(e, data_quality=replace(known, warnings=(*known.warnings, text)))
    return replace(diagnosis, elements=elements)


def _parametric(
    stretches: Sequence[Record], *, model: TransferMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_parametric(stretches, model=model, classic=pmr, settings=parametric)


METHODS: dict[str, Callable[..., Diagnosis]] = {"classic": _classic, "parametric": _parametric}
"""Diagnosis methods by name: the paper's Table 1, or the FOPTD-ratio fit of :mod:`pmr_ros.core.pmr.parametric`."""


def method_welch(
    longest: int,
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
    instruments: int = 0,
) -> WelchSettings:
    """The Welch segments ``method`` averages when the longest stretch has ``longest`` samples.

    The parametric method sizes its segment from the slowest element and the
    longest stretch, shorter when the stretches are too few segments for the
    instruments (:meth:`ParametricSettings.welch`); the classic one uses ``pmr.welch``.

    Parameters
    ----------
    longest : int
        Samples of the longest stretch.
    model : TransferMatrix
    pmr : PmrSettings
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS` (default ``pmr.method``).
    instruments : int
        The external signals that move (0: the segment is not shortened for them).
    """
    if (method or pmr.method) == "parametric":
        return parametric.welch(model, int(longest), pmr, instruments=instruments)
    return pmr.welch


def stretches_welch(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> WelchSettings:
    """:func:`method_welch` of ``stretches``: their lengths and the instruments that move in them."""
    if (method or pmr.method) == "parametric":
        return parametric.welch_for(model, stretches, pmr)
    return pmr.welch


def shortest_useful_stretch(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> int:
    """Fewest samples with which a stretch adds a Welch segment: the model's settling plus one segment [samples].

    Parameters
    ----------
    stretches : sequence of Record
        The data (the parametric method sizes its segment from the longest stretch).
    model : TransferMatrix
        The controller's model ``Ghat`` (its settling is dropped from every stretch).
    pmr : PmrSettings
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS` (default ``pmr.method``).
    """
    welch = stretches_welch(stretches, model=model, pmr=pmr, parametric=parametric, method=method)
    return model.settling_samples() + welch.segment_length


def useful_stretches(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> list[Record]:
    """The stretches that add at least one Welch segment to a diagnosis with ``method``; shorter ones add nothing.

    Parameters
    ----------
    stretches : sequence of Record
    model : TransferMatrix
    pmr : PmrSettings
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS` (default ``pmr.method``).
    """
    shortest = shortest_useful_stretch(stretches, model=model, pmr=pmr, parametric=parametric, method=method)
    return [s for s in stretches if s.samples >= shortest]


def _known(value: float) -> float | None:
    """A figure, or None where it could not be computed (NaN)."""
    return float(value) if np.isfinite(value) else None


def with_data_quality(
    diagnosis: Diagnosis, quality: RecordQuality, *, model: TransferMatrix, settings: QualitySettings
) -> Diagnosis:
    """``diagnosis`` with every element's :class:`~pmr_ros.core.results.DataQuality` (verdicts unchanged).

    Parameters
    ----------
    diagnosis : Diagnosis
    quality : RecordQuality
        The record's figures (:func:`~pmr_ros.core.pmr.data_quality.assess`).
    model : TransferMatrix
        The controller's model (channel names).
    settings : QualitySettings
        The warning thresholds.
    """
    elements = {}
    for name, e in diagnosis.elements.items():
        figures = DataQuality(
            saturated_share=_known(quality.saturated[e.column]),
            outside_share=_known(quality.outside[e.column]),
            low_frequency_ratio=_known(quality.low_frequency[e.row]),
            warnings=element_warnings(quality, e.row, e.column, model=model, settings=settings),
        )
        elements[name] = replace(e, data_quality=figures)
    return replace(diagnosis, elements=elements)


def diagnose_stretches(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
    quality: QualitySettings | None = None,
    as_read: Sequence[Record] | None = None,
    disturbance_model: TransferMatrix | None = None,
) -> Diagnosis:
    """Diagnose unbroken stretches of data (one estimate from all of them) with ``method`` (default ``pmr.method``).

    Parameters
    ----------
    stretches : sequence of Record
        Setpoints, inputs, outputs and (if any) MV dither of each stretch.
    model : TransferMatrix
        The controller's model ``Ghat``.
    pmr : PmrSettings
        Spectral settings and the classic thresholds.
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS`.
    quality : QualitySettings, optional
        Input limits and warning thresholds: a diagnosis with verdicts then
        carries each element's data-quality figures and warnings
        (:func:`with_data_quality`; residual spectra with ``pmr.welch``, whose
        lowest bin the classic M(0) is read from).
    as_read : sequence of Record, optional
        The data as read, where ``stretches`` are deviations from their means
        (a historian export): the inputs' limits are judged on these, in the
        limits' own units.  Default: ``stretches``.
    disturbance_model : TransferMatrix, optional
        ``Gd``: with data that carry the DVs (``Record.dv``) the D elements are diagnosed too
        (:func:`~pmr_ros.core.sim.augment.with_disturbances`); without, ``G`` alone with one warning.

    Raises
    ------
    ValueError
        For an unknown method.
    """
    method = method or pmr.method
    if method not in METHODS:
        raise ValueError(f"unknown diagnosis method {method!r}; choose one of {', '.join(METHODS)}")
    stretches = list(stretches)
    note = missing_disturbances(stretches, disturbance_model)
    if note is None and disturbance_model is not None:
        stretches, model, quality, as_read = _augmented(stretches, model, quality, as_read, disturbance_model)
    diagnosis = METHODS[method](stretches, model=model, pmr=pmr, parametric=parametric)
    if note is not None:
        diagnosis = _with_warning(diagnosis, f"D elements not diagnosed: {note}")
    if quality is not None and diagnosis.status == "ok":
        used = useful_stretches(stretches, model=model, pmr=pmr, parametric=parametric, method="classic")
        if used:  # a diagnosis with verdicts had a stretch long enough for its own, longer, segments
            figures = assess(used, model=model, welch=pmr.welch, settings=quality, as_read=as_read)
            diagnosis = with_data_quality(diagnosis, figures, model=model, settings=quality)
    if method == "classic" and diagnosis.status == "ok":
        diagnosis = with_filtering_warnings(diagnosis, model, limit=parametric.row_time_constant_ratio_warn)
    return diagnosis


def _augmented(
    stretches: Sequence[Record],
    model: TransferMatrix,
    quality: QualitySettings | None,
    as_read: Sequence[Record] | None,
    disturbance_model: TransferMatrix,
) -> tuple[list[Record], TransferMatrix, QualitySettings | None, list[Record] | None]:
    """The data, model, quality settings and data as read with the DVs as inputs (:mod:`~..sim.augment`)."""
    if as_read is not None and not missing_disturbances(as_read, disturbance_model):
        read = with_disturbances(as_read, model, disturbance_model)[0]
    else:
        read = None
    stretches, model = with_disturbances(stretches, model, disturbance_model)
    quality = None if quality is None else _without_dv_limits(quality, model.n_disturbances)
    return stretches, model, quality, read


def _without_dv_limits(quality: QualitySettings, n_disturbances: int) -> QualitySettings:
    """``quality`` for an augmented model: the DV columns have no limits (their saturation is not judged)."""
    none = np.full(n_disturbances, np.inf)
    return replace(
        quality,
        u_min=np.concatenate([np.asarray(quality.u_min, dtype=float), -none]),
        u_max=np.concatenate([np.asarray(quality.u_max, dtype=float), none]),
    )


def _with_warning(diagnosis: Diagnosis, warning: str) -> Diagnosis:
    """``diagnosis`` with ``warning`` on every parametric result (verdicts unchanged)."""
    elements = {
        name: e
        if e.parametric is None
        else replace(e, parametric=replace(e.parametric, warnings=(*e.parametric.warnings, warning)))
        for name, e in diagnosis.elements.items()
    }
    return replace(diagnosis, elements=elements)


def diagnose(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
    dither: np.ndarray | None = None,
) -> Diagnosis:
    """Diagnose one gap-free record with ``method`` (default ``pmr.method``); no data-quality figures.

    :func:`diagnose_stretches` of ``[Record(r, u, y, dither)]`` with ``quality`` adds them.

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : TransferMatrix
        The controller's model ``Ghat``.
    pmr : PmrSettings
        Spectral settings and the classic thresholds.
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS`.
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs; its moving columns
        join the setpoints as instruments.

    Raises
    ------
    ValueError
        For an unknown method.
    """
    stretch = Record(np.asarray(r), np.asarray(u), np.asarray(y), None if dither is None else np.asarray(dither))
    return diagnose_stretches([stretch], model=model, pmr=pmr, parametric=parametric, method=method)
