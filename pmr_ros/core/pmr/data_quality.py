"""Data-quality figures of either method: inputs at their limits, slow unmeasured disturbances.

Neither changes a verdict; both say how far the data can be trusted, per
element (:class:`~pmr_ros.core.results.DataQuality`).

**Saturation.**  A sample where an input sits at one of its limits
(``mpc.u_min``, ``mpc.u_max``) carries no excitation of that input from the
controller: whatever the setpoints ask, the input stays put.  The instruments
stay valid -- setpoints and dither are still exogenous, the plant is still
linear in the input it gets -- so the estimates stay unbiased; but the input's
share of the instrument-driven output drops, and with it the information about
its elements: their intervals widen, and the excitation guard makes them
``inconclusive`` when too little is left.  :func:`saturation` counts the share
of saturated samples per input, and of samples beyond the limits (then the
configured limits do not describe the data, and saturation cannot be judged).

**Low-frequency disturbances.**  A slow unmeasured disturbance (a feed
composition drifting, ambient temperature) puts most of its power in the
lowest frequency bins -- exactly where the classic method reads its gain ratio
M(0).  :func:`low_frequency_ratio` compares each output row's residual spectrum
(``y_i`` less the per-bin implicit estimate's prediction, i.e. the disturbance
and noise the regression cannot explain) at its lowest bins with its median
over all bins: about 1 for white noise, hundreds under the drift of
``noise.disturbance_pole`` 0.97.  The parametric method's weights already
follow that spectrum (its intervals widen where the noise is); the classic
thresholds do not, so the warning tells a classic user not to trust M(0).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..records import Record
from ..sim.model import TransferMatrix
from .implicit import row_estimate, row_layout
from .spectra import RowSpectra, WelchSettings, record_spectra

__all__ = [
    "QualitySettings",
    "RecordQuality",
    "assess",
    "element_warnings",
    "low_frequency_ratio",
    "residual_spectra",
    "saturation",
]


@dataclass(frozen=True)
class QualitySettings:
    """The ``quality`` block with the configured input limits.  Defaults and ranges: ``config/parameters.yaml``.

    Attributes
    ----------
    u_min, u_max : ndarray, shape (n_inputs,)
        The input limits (``mpc.u_min``, ``mpc.u_max``) [input unit]; both infinite: not
        known (plant data whose params file gives none), saturation not judged.
    limit_tolerance : float
        An input within this fraction of ``u_max - u_min`` of a limit sits at it [-].
    saturation_warn : float
        An input at a limit (or beyond the limits) in more than this share of the samples warns [-].
    low_frequency_warn : float
        A row's residual spectrum at its lowest bins above this many times its median warns [-].
    low_frequency_bins : int
        How many of the lowest bins (the lowest nonzero ones in a differenced row) are averaged.
    """

    u_min: np.ndarray
    u_max: np.ndarray
    limit_tolerance: float
    saturation_warn: float
    low_frequency_warn: float
    low_frequency_bins: int

    def without_limits(self) -> QualitySettings:
        """These settings with the input limits unknown (both infinite): saturation is not judged."""
        return replace(self, u_min=np.full(np.shape(self.u_min), -np.inf), u_max=np.full(np.shape(self.u_max), np.inf))


@dataclass(frozen=True)
class RecordQuality:
    """The data-quality figures of a record.

    Attributes
    ----------
    saturated : ndarray, shape (n_inputs,)
        Share of the samples where each input sits at a limit [-]; NaN where its limits are not known.
    outside : ndarray, shape (n_inputs,)
        Share of the samples where it lies beyond them [-]; likewise.
    low_frequency : ndarray, shape (n_outputs,)
        Each row's residual spectrum at its lowest bins over its median [-]; NaN
        where the row has no regression (not identifiable).
    band : float
        The highest frequency among the lowest bins averaged [rad/sample].
    """

    saturated: np.ndarray
    outside: np.ndarray
    low_frequency: np.ndarray
    band: float


def saturation(
    stretches: Sequence[Record], *, u_min: np.ndarray, u_max: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Share of samples at a limit and beyond the limits, per input, over every stretch.

    Parameters
    ----------
    stretches : sequence of Record
    u_min, u_max : ndarray, shape (n_inputs,)
        The input limits [input unit].
    tolerance : float
        Within this fraction of ``u_max - u_min`` of a limit counts as at it [-].

    Returns
    -------
    at_limit, beyond : ndarray, shape (n_inputs,)
        Shares of the samples [-] (0 without samples); NaN for an input whose
        limits are both infinite (not known: not judged).

    Examples
    --------
    >>> u = np.array([[2.0], [1.0], [-2.0], [3.0]])
    >>> saturation([Record(u, u, u)], u_min=np.array([-2.0]), u_max=np.array([2.0]), tolerance=1e-6)
    (array([0.5]), array([0.25]))
    """
    u_min, u_max = np.asarray(u_min, dtype=float), np.asarray(u_max, dtype=float)
    span = u_max - u_min
    slack = tolerance * np.where(np.isfinite(span), span, 0.0)
    at = np.zeros(u_min.shape)
    beyond = np.zeros(u_min.shape)
    samples = 0
    for stretch in stretches:
        u = np.asarray(stretch.u, dtype=float)
        at += np.sum((np.abs(u - u_min) <= slack) | (np.abs(u - u_max) <= slack), axis=0)
        beyond += np.sum((u < u_min - slack) | (u > u_max + slack), axis=0)
        samples += u.shape[0]
    unknown = np.isinf(u_min) & np.isinf(u_max)
    return np.where(unknown, np.nan, at / max(samples, 1)), np.where(unknown, np.nan, beyond / max(samples, 1))


def _residual(row: RowSpectra, columns: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Spectrum of ``y_i - sum_k theta_k x_ik`` per bin for coefficients ``theta`` (F, n_columns)."""
    xy = row.xy[:, columns]
    xx = row.xx[:, columns][:, :, columns]
    cross = np.einsum("fk,fk->f", theta.conj(), xy).real
    quad = np.einsum("fk,fkm,fm->f", theta.conj(), xx, theta).real
    return np.maximum(row.yy - 2.0 * cross + quad, 0.0)


def residual_spectra(
    stretches: Sequence[Record], *, model: TransferMatrix, welch: WelchSettings
) -> tuple[np.ndarray, np.ndarray]:
    """Each output row's residual spectrum after the per-bin implicit estimate (eq. 13).

    A differenced row (integrating output) has the differencing filter's
    ``|1 - e^-jw|^2`` divided out, so its spectrum is that of the disturbance
    itself, and nothing at ``w = 0`` (NaN).

    Parameters
    ----------
    stretches : sequence of Record
        Data that passed :func:`~pmr_ros.core.pmr.checks.check_stretches`.
    model : TransferMatrix
    welch : WelchSettings

    Returns
    -------
    omega : ndarray, shape (F,)
        [rad/sample].
    residual : ndarray, shape (F, n_outputs)
        [output unit^2 per rad/sample]; NaN for a row without regressors.
    """
    spectra = record_spectra(stretches, model, welch)
    omega = spectra.omega
    out = np.full((omega.size, model.n_outputs), np.nan)
    for i in range(model.n_outputs):
        layout = row_layout(model, i, **spectra.layout_inputs)
        if layout.columns.size == 0:
            continue
        row = spectra.row(i)
        estimate = row_estimate(spectra, i, layout.columns, row=row)
        out[:, i] = _residual(row, layout.columns, estimate.ratio)
        if row.differenced:
            with np.errstate(divide="ignore", invalid="ignore"):
                out[:, i] = np.where(omega > 0, out[:, i] / (2.0 - 2.0 * np.cos(omega)), np.nan)
    return omega, out


def low_frequency_ratio(residual: np.ndarray, *, bins: int) -> np.ndarray:
    """Mean of each column's lowest ``bins`` finite values over its median, shape (n_outputs,).

    Parameters
    ----------
    residual : ndarray, shape (F, n_outputs)
        Residual spectra from :func:`residual_spectra` (NaN where not defined).
    bins : int
        How many of the lowest defined bins are averaged.

    Examples
    --------
    >>> low_frequency_ratio(np.array([[9.0], [7.0], [1.0], [1.0], [1.0]]), bins=2)
    array([8.])
    """
    out = np.full(residual.shape[1], np.nan)
    for i in range(residual.shape[1]):
        values = residual[np.isfinite(residual[:, i]), i]
        median = float(np.median(values)) if values.size > bins else 0.0
        if median > 0:
            out[i] = float(values[:bins].mean()) / median
    return out


def assess(
    stretches: Sequence[Record],
    *,
    model: TransferMatrix,
    welch: WelchSettings,
    settings: QualitySettings,
    as_read: Sequence[Record] | None = None,
) -> RecordQuality:
    """The data-quality figures of data that passed the record checks.

    Parameters
    ----------
    stretches : sequence of Record
    model : TransferMatrix
        The controller's model ``Ghat``.
    welch : WelchSettings
        Of the residual spectra (the classic method's: its M(0) is read at their lowest bin).
    settings : QualitySettings
    as_read : sequence of Record, optional
        Where the inputs' limits are judged (the data as read, when ``stretches``
        are deviations from their means); default ``stretches``.
    """
    limited = stretches if as_read is None else as_read
    at, beyond = saturation(limited, u_min=settings.u_min, u_max=settings.u_max, tolerance=settings.limit_tolerance)
    omega, residual = residual_spectra(stretches, model=model, welch=welch)
    ratio = low_frequency_ratio(residual, bins=settings.low_frequency_bins)
    band = float(omega[min(settings.low_frequency_bins, omega.size - 1)])
    return RecordQuality(at, beyond, ratio, band)


def element_warnings(
    quality: RecordQuality, i: int, k: int, *, model: TransferMatrix, settings: QualitySettings
) -> tuple[str, ...]:
    """The warnings of element ``(i, k)``: its input at a limit or beyond, its row under a slow disturbance."""
    name_u, name_y = model.input_names[k], model.output_names[i]
    warnings = []
    if quality.saturated[k] > settings.saturation_warn:
        warnings.append(
            f"{name_u} at a limit in {100 * quality.saturated[k]:.0f} % of the samples (> quality.saturation_warn "
            f"{100 * settings.saturation_warn:g} %): those carry no excitation of {name_u}, so its elements are "
            "less well seen (wider intervals); move the operating point or the limit away for the test"
        )
    if quality.outside[k] > settings.saturation_warn:
        warnings.append(
            f"{name_u} beyond mpc.u_min .. mpc.u_max in {100 * quality.outside[k]:.0f} % of the samples: "
            "the configured limits do not describe the data, saturation is not judged"
        )
    ratio = quality.low_frequency[i]
    if np.isfinite(ratio) and ratio > settings.low_frequency_warn:
        warnings.append(
            f"low-frequency disturbance on {name_y}: its residual spectrum up to {quality.band:.3f} rad/sample is "
            f"{ratio:.0f} times its median (> quality.low_frequency_warn {settings.low_frequency_warn:g}): "
            "do not trust the classic gain ratio M(0); the parametric intervals account for it"
        )
    return tuple(warnings)
