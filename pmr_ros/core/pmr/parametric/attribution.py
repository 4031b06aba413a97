"""What drove each element's verdict and what is missing: the instruments' shares, and how much more data would decide.

* :func:`instrument_shares`: each instrument's share of the instrument-driven
  power of an element's regressor ``x_ik`` over the row's fitted band -- which
  external signals (setpoint changes, dither, manual moves, measured
  disturbances) carried the element's information;
* :func:`more_data_factor`: for an inconclusive gain or time constant, how many
  times today's data (at today's excitation) would shrink its interval enough
  for a verdict, assuming the interval's half-width shrinks as ``1/sqrt(N)``
  (the Welch average's segments are independent, so the estimate's variance
  falls as ``1/N``) and its centre stays where it is.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from ...results import ParametricResult
from .settings import ParametricSettings

__all__ = ["instrument_shares", "more_data_factor", "more_data_reason", "needed_halfwidth", "with_attribution"]


def instrument_shares(zx: np.ndarray, rr: np.ndarray, bins: np.ndarray) -> np.ndarray:
    """Each instrument's share of each regressor's instrument-driven power over ``bins``, shape (n_z, n_c).

    ``sum_bins |S_{z_l x_c}|^2 / S_{z_l z_l}`` is the power of ``x_c`` that
    instrument ``l`` alone explains; for instruments that do not move together
    (separate PRBS, dither and operator moves) these add up to the power all of
    them explain, so their normalized values are each instrument's part of it.
    Instruments that do move together share what they explain by their own
    coherence.  A column no instrument moves has all shares 0.

    Parameters
    ----------
    zx : ndarray, shape (F, n_z, n_c)
        Cross-spectra of the instruments with the regressors.
    rr : ndarray, shape (F, n_z, n_z)
        The instrument spectra.
    bins : ndarray of int
        The fitted band.

    Returns
    -------
    ndarray, shape (n_z, n_c)
        Columns sum to 1 (or are all 0).

    Examples
    --------
    >>> zx = np.ones((3, 2, 1), dtype=complex) * np.array([[[1.0], [2.0]]])
    >>> rr = np.tile(np.eye(2), (3, 1, 1)).astype(complex)
    >>> instrument_shares(zx, rr, np.arange(3))[:, 0].round(2).tolist()
    [0.2, 0.8]
    """
    own = np.maximum(np.einsum("fll->fl", rr[bins]).real, 1e-300)
    explained = (np.abs(zx[bins]) ** 2 / own[:, :, None]).sum(axis=0)
    total = explained.sum(axis=0)
    return np.where(total > 0, explained / np.where(total > 0, total, 1.0), 0.0)


def needed_halfwidth(center: float, *, tolerance: float, ok_band_factor: float, max_halfwidth: float) -> float:
    """The largest interval half-width at which a parameter estimated at ``center`` [%] gets a verdict.

    ``mismatch`` needs ``|center| - h > tolerance``; ``ok`` needs the interval
    within ``+/- ok_band_factor x tolerance`` and ``h <= max_halfwidth``
    (:func:`~.verdicts.parameter_verdict`).  0 when no half-width decides (the
    centre sits on the tolerance).

    Examples
    --------
    >>> needed_halfwidth(1.0, tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0)
    5.0
    >>> needed_halfwidth(10.0, tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0)
    7.0
    """
    size = abs(center)
    mismatch = size - tolerance
    ok = min(ok_band_factor * tolerance - size, max_halfwidth)
    return max(mismatch, ok, 0.0)


def more_data_factor(interval: tuple[float, float], *, tolerance: float, settings: ParametricSettings) -> float:
    """How many times today's data would decide a parameter whose interval is ``interval`` [%].

    ``(h / h_needed)^2`` with ``h`` the half-width and ``h_needed``
    :func:`needed_halfwidth` at the interval's centre: the half-width shrinks as
    ``1/sqrt(N)``.  ``inf`` when no amount decides at that centre.
    """
    low, high = interval
    halfwidth = (high - low) / 2.0
    needed = needed_halfwidth(
        (low + high) / 2.0,
        tolerance=tolerance,
        ok_band_factor=settings.ok_band_factor,
        max_halfwidth=settings.max_interval_pct,
    )
    if not math.isfinite(halfwidth) or needed <= 0.0:
        return math.inf
    return max((halfwidth / needed) ** 2, 1.0)


def more_data_reason(factor: float, *, samples: int, sample_time: float) -> str:
    """The words of :func:`more_data_factor`: ``~3.2x more data (about 26000 more samples, ...) ...``."""
    if not math.isfinite(factor):
        return (
            "more data at today's excitation would not decide while the estimate sits on the tolerance: "
            "more excitation (larger dither or setpoint changes) would"
        )
    extra = (factor - 1.0) * samples
    span = extra * sample_time
    return (
        f"~{factor:.1f}x the data ({extra:.0f} more samples, {span:.0f} time units) at today's excitation would "
        "decide, assuming the interval shrinks as 1/sqrt(N)"
    )


def _factor(result: ParametricResult, settings: ParametricSettings) -> float | None:
    """The largest factor among the element's inconclusive gain and time constant; None when neither has one."""
    factors = [
        more_data_factor(interval, tolerance=tolerance, settings=settings)
        for verdict, interval, tolerance in (
            (result.gain_verdict, result.gain_mismatch_pct_interval, settings.gain_tolerance_pct),
            (result.tau_verdict, result.tau_mismatch_pct_interval, settings.tau_tolerance_pct),
        )
        if verdict == "inconclusive" and interval is not None
    ]
    return max(factors) if factors else None


def with_attribution(
    result: ParametricResult,
    shares: Mapping[str, float],
    *,
    samples: int,
    sample_time: float,
    settings: ParametricSettings,
) -> ParametricResult:
    """``result`` with its instruments' shares and, when inconclusive for want of data, the more-data estimate.

    The estimate is given only where the interval is what keeps the verdict
    open (an element whose numbers cannot be trusted, or cannot be told apart
    from another, needs other data, not more of the same).

    Parameters
    ----------
    shares : mapping
        Instrument label to its share (:func:`instrument_shares`).
    samples : int
        Samples diagnosed.
    sample_time : float
        [time unit].
    """
    factor = _factor(result, settings) if not _other_trouble(result.reasons) else None
    reasons: Sequence[str] = result.reasons
    if factor is not None:
        reasons = (*result.reasons, more_data_reason(factor, samples=samples, sample_time=sample_time))
    return replace(result, instrument_shares=dict(shares), more_data_factor=factor, reasons=tuple(reasons))


_NOT_DATA = ("cannot be told apart", "does not follow the data", "search limit", "search range", "not identifiable")
"""Words of reasons that more of the same data would not cure."""


def _other_trouble(reasons: Sequence[str]) -> bool:
    return any(word in reason for reason in reasons for word in _NOT_DATA)
