"""Calibrated verdicts of one column of a fitted row: intervals, delay confidence, ok/mismatch/inconclusive.

Two rules, each its own function so that each can be hardened alone:

* :func:`parameter_verdict`: a parameter is ``mismatch`` when its whole
  interval lies beyond the practical tolerance, ``ok`` when
  its interval lies within ``parametric.ok_band_factor`` (2) tolerances of
  zero, else ``inconclusive`` (:func:`undecided_reason` says why);
* :func:`trust_reasons`: numbers that cannot be trusted whatever their
  intervals -- a delay at the edge of its search range (the true one may lie
  beyond, and the gain and time constant then bend to mimic it) makes every
  verdict of the element ``inconclusive``; a fit that does not follow the data
  beyond its noise (lack of fit, its own or its row's, :mod:`.shape`: the plant
  differs from the model in shape, or its delay lies beyond the search range) makes the time-constant (dynamics)
  and delay verdicts ``inconclusive`` -- speed and delay bend to mimic a shape
  -- and the gain is judged on the hull of its fitted interval and the
  interval read at the lowest fitted bin alone (:func:`steady_state_interval`,
  where the ratio is the gain ratio whatever the shape);
* an empty cell's interaction: :mod:`pmr_ros.core.pmr.parametric.interaction`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr, ndtri  # norm.cdf and norm.ppf without scipy.stats' argument handling

from ...results import ParametricResult
from ..delay import search_limit_reason
from .fit import RowFit, WeightedFit
from .settings import ParametricSettings
from .shape import ROW_MISFIT_Z, SHAPE_REASON, shape_misfit, shape_reason, steady_state_interval

__all__ = [
    "ROW_MISFIT_Z",
    "SHAPE_REASON",
    "delay_confidence",
    "element_result",
    "mixture_interval",
    "parameter_verdict",
    "separation_reason",
    "shape_misfit",
    "steady_state_interval",
    "trust_reasons",
    "undecided_reason",
    "z_score",
    "chosen_delay",
]


def parameter_verdict(
    interval: tuple[float, float],
    *,
    tolerance: float,
    ok_band_factor: float,
    max_halfwidth: float,
    ok_interval: tuple[float, float] | None = None,
) -> str:
    """The verdict of one parameter.

    ``mismatch`` when the whole interval lies beyond the practical tolerance
    (the change is larger than the tolerance with the interval's confidence);
    ``ok`` when the interval lies within ``+/- ok_band_factor x tolerance`` and
    is no wider than ``+/- max_halfwidth`` (it rules out a change large enough
    to matter); else ``inconclusive``.  Both are confident statements: an
    ``ok`` whose interval still held a change of twice the tolerance, or a
    ``mismatch`` whose interval still held no change (an interval that merely
    excludes zero, two parameters per element, a slight bias), would be
    confidently wrong far more often than the interval's level says.

    Parameters
    ----------
    interval : (float, float)
        The parameter's confidence interval [%].
    tolerance : float
        Practical tolerance [%].
    ok_band_factor : float
        ``ok`` needs the interval within this many tolerances of zero.
    max_halfwidth : float
        [percentage points].
    ok_interval : (float, float), optional
        The interval the ``ok`` rule reads, when it is not ``interval``: an
        empty cell's search over templates widens the interval that tests for a
        mismatch (the best of many candidates), not the one that bounds its size.

    Examples
    --------
    >>> parameter_verdict((-1.0, 9.0), tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0)
    'inconclusive'
    >>> parameter_verdict((-2.0, 4.0), tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0)
    'ok'
    >>> parameter_verdict((3.5, 6.5), tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0)
    'mismatch'
    """
    low, high = interval
    if low > tolerance or high < -tolerance:
        return "mismatch"
    ok_low, ok_high = interval if ok_interval is None else ok_interval
    band = ok_band_factor * tolerance
    if -band <= ok_low and ok_high <= band and (high - low) / 2.0 <= max_halfwidth:
        return "ok"
    return "inconclusive"


def undecided_reason(
    label: str, interval: tuple[float, float], *, tolerance: float, settings: ParametricSettings
) -> str:
    """Why a parameter whose verdict is ``inconclusive`` by :func:`parameter_verdict` is so, in words.

    Parameters
    ----------
    label : str
        The parameter, e.g. ``"gain"``.
    interval : (float, float)
        Its confidence interval [%].
    tolerance : float
        Its practical tolerance [%].
    """
    low, high = interval
    text = f"{label} interval [{low:+.1f}, {high:+.1f}] %"
    if (high - low) / 2.0 > settings.max_interval_pct:
        return f"{text} too wide (> ±{settings.max_interval_pct:g} pp)"
    band = settings.ok_band_factor * tolerance
    return (
        f"{text} lies neither beyond the tolerance ±{tolerance:g} % (mismatch) nor within ±{band:g} % "
        f"({settings.ok_band_factor:g}x the tolerance: ok): more data or excitation to decide"
    )


def delay_confidence(profile: Mapping[int, float], chosen: int, scale: float) -> float:
    """Profile-likelihood weight of the chosen delay among its neighbours, 0..1.

    Parameters
    ----------
    profile : mapping
        ``dD -> chi-square`` of the row fit with that delay.
    chosen : int
        The chosen ``dD``.
    scale : float
        The reduced chi-square (>= 1) the likelihood is tempered by.
    """
    costs = np.array(list(profile.values()))
    weights = np.exp(-(costs - profile[chosen]) / (2.0 * scale))
    return float(1.0 / weights.sum())


def mixture_interval(means: np.ndarray, sds: np.ndarray, weights: np.ndarray, *, level: float) -> tuple[float, float]:
    """The central ``level`` interval of a mixture of normals: a parameter over competing delay vectors.

    Parameters
    ----------
    means, sds : ndarray, shape (J,)
        The parameter's estimate and standard deviation under each delay vector.
    weights : ndarray, shape (J,)
        Their likelihood weights (normalized here).
    level : float
        Confidence level, e.g. 0.95.

    Returns
    -------
    (float, float)
        ``(low, high)``; infinite when a component's deviation is.
    """
    means, sds = np.asarray(means, dtype=float), np.asarray(sds, dtype=float)
    weights = np.asarray(weights, dtype=float) / float(np.sum(weights))
    if not np.all(np.isfinite(sds)) or not np.all(np.isfinite(means)):
        return -math.inf, math.inf
    sds = np.maximum(sds, 1e-300)
    if means.size == 1:
        z = float(ndtri(0.5 + level / 2.0))
        return float(means[0] - z * sds[0]), float(means[0] + z * sds[0])
    # 40 deviations either side, and a little more: components with no spread (a fit pinned at a bound, sd 0)
    # gave a bracket of zero width, whose ends had the same sign, and brentq raised (a live window lost its verdict)
    margin = 40.0 * sds + 1e-9 * (1.0 + np.abs(means))
    low, high = float(np.min(means - margin)), float(np.max(means + margin))

    def quantile(q: float) -> float:
        return float(brentq(lambda x: float(weights @ ndtr((x - means) / sds)) - q, low, high, xtol=1e-12))

    tail = (1.0 - level) / 2.0
    return quantile(tail), quantile(1.0 - tail)


def _edge_reason(fit: RowFit, c: int) -> str | None:
    column = fit.columns[c]
    low, high = column.delay_bounds
    return search_limit_reason(int(fit.delays[c]), low=low, high=high, low_is_limit=column.low_is_limit)


def trust_reasons(fit: RowFit, c: int, settings: ParametricSettings) -> tuple[str, ...]:
    """Why column ``c``'s numbers cannot be trusted: a delay at its search limit, a lack of fit (:data:`SHAPE_REASON`).

    The delay at its limit makes every verdict inconclusive, the lack of fit all but the gain's (:func:`_gain`).
    """
    edge = _edge_reason(fit, c)
    reasons = [] if edge is None else [edge]
    if shape_misfit(fit, c, settings):
        reasons.append(shape_reason(fit, c, settings))
    return tuple(reasons)


def separation_reason(
    fit: RowFit,
    c: int,
    settings: ParametricSettings,
    *,
    labels: Sequence[tuple[str, str]],
    halfwidths: tuple[float, float | None],
) -> str | None:
    """Why column ``c`` cannot be told apart from a neighbour, or None.

    When the other columns account for at least ``parametric.max_collinearity``
    of its gain's information (:attr:`~.separation.Separation.collinearity`)
    *and* its gain or time-constant interval is wider than the practical
    tolerance, the interval is made wide by the neighbour, not by a lack of
    data on the element itself, and any small misfit of one element is passed
    to the other many times over: neither verdict can be trusted.

    Parameters
    ----------
    labels : sequence of (str, str)
        ``(element name, input name)`` per column of the fit.
    halfwidths : (float, float or None)
        Half widths of the gain and time-constant intervals [percentage points].
    """
    separation = fit.separation
    if separation is None or not separation.collinearity[c] >= settings.max_collinearity:
        return None
    gain, tau = halfwidths
    if gain <= settings.gain_tolerance_pct and (tau is None or tau <= settings.tau_tolerance_pct):
        return None
    partner = int(separation.partner[c])
    (element, input_name), (other, other_input) = labels[c], labels[partner]
    shared = 100 * separation.collinearity[c]
    return (
        f"{input_name} and {other_input} move together in the fitted band (coherence "
        f"{separation.partner_coherence[c]:.2f}; {shared:.0f} % of {element}'s information is shared with the row's "
        f"other inputs > parametric.max_collinearity {100 * settings.max_collinearity:g} %): {element} and {other} "
        f"cannot be told apart (gain ±{gain:.1f} %); add MV dither on {input_name} or {other_input} "
        "(excitation.mv_dither_amplitude)"
    )


def z_score(settings: ParametricSettings) -> float:
    """The two-sided normal quantile of ``settings.confidence_level`` (1.96 at 95 %)."""
    return float(ndtri(0.5 + settings.confidence_level / 2.0))


def _halfwidth(interval: tuple[float, float]) -> float:
    return (interval[1] - interval[0]) / 2.0


def _mixture(fit: RowFit, c: int, settings: ParametricSettings, *, tau: bool) -> tuple[float, float]:
    """Interval of column ``c``'s ``rho`` (or ``log tau`` ratio) over its delays the data do not exclude.

    One component per delay of column ``c``: the best-fitting delay vector with that delay and its
    likelihood weight -- the profile likelihood over the other columns' delays, as
    :func:`delay_confidence` weighs the delay itself.  Summing every vector tried instead would
    count a delay once per neighbouring vector the search happened to try with it (an empty
    cell's delay varied over four equivalent values gave the chosen delay of a DV element five
    components and the true one a single one: its tau interval excluded the truth).
    """
    best: dict[int, tuple[float, RowFit | WeightedFit]] = {int(fit.delays[c]): (1.0, fit)}
    for alternative in fit.alternatives:
        delay = int(alternative.delays[c])
        if alternative.weight > best.get(delay, (-1.0, fit))[0]:
            best[delay] = (alternative.weight, alternative)
    fits = [f for _, f in best.values()]
    means = np.array([f.s[c] if tau else f.lin[c] for f in fits])
    sds = np.array([f.sd_s[c] if tau else f.sd_lin[c] for f in fits])
    weights = np.array([w for w, _ in best.values()])
    return mixture_interval(means, sds, weights, level=settings.confidence_level)


def chosen_delay(fit: RowFit, c: int, settings: ParametricSettings) -> tuple[int, float, str]:
    """Column ``c``'s fitted delay [samples], the confidence in it and its verdict."""
    delay = int(fit.delays[c])
    confidence = delay_confidence(fit.delay_profile[c], delay, fit.scale)
    if confidence < settings.delay_confidence_min:
        return delay, confidence, "inconclusive"
    return delay, confidence, "mismatch" if delay != 0 else "ok"


def _gain(fit: RowFit, c: int, settings: ParametricSettings) -> tuple[float, tuple[float, float], str]:
    """``(dK %, interval, verdict)`` of a modeled element's column.

    Under a lack of fit (:func:`shape_misfit`) the interval is the hull of the
    fitted one and :func:`steady_state_interval`; without the latter, inconclusive.
    """
    gain = 100.0 * (float(fit.lin[c]) - 1.0)
    low, high = _mixture(fit, c, settings, tau=False)
    interval = (100.0 * (low - 1.0), 100.0 * (high - 1.0))
    if shape_misfit(fit, c, settings):
        steady = steady_state_interval(fit, c, settings)
        if steady is None:
            return gain, interval, "inconclusive"
        interval = (min(interval[0], steady[0]), max(interval[1], steady[1]))
    verdict = parameter_verdict(
        interval,
        tolerance=settings.gain_tolerance_pct,
        ok_band_factor=settings.ok_band_factor,
        max_halfwidth=settings.max_interval_pct,
    )
    return gain, interval, verdict


def _tau(
    fit: RowFit, c: int, settings: ParametricSettings
) -> tuple[float | None, tuple[float, float] | None, str | None]:
    """``(dtau %, interval, verdict)`` of a column with a time constant, all None without one."""
    if not fit.columns[c].has_tau:
        return None, None, None
    tau = 100.0 * math.expm1(float(fit.s[c]))
    low, high = _mixture(fit, c, settings, tau=True)
    interval = (100.0 * math.expm1(low), 100.0 * math.expm1(high))
    verdict = parameter_verdict(
        interval,
        tolerance=settings.tau_tolerance_pct,
        ok_band_factor=settings.ok_band_factor,
        max_halfwidth=settings.max_interval_pct,
    )
    return tau, interval, verdict


def element_result(
    fit: RowFit,
    c: int,
    *,
    settings: ParametricSettings,
    quality: Mapping[str, float],
    warnings: tuple[str, ...],
    labels: Sequence[tuple[str, str]],
) -> ParametricResult:
    """The estimate, intervals and verdicts of a modeled element, column ``c`` of a fitted row.

    ``labels`` are ``(element name, input name)`` per column of the fit (for :func:`separation_reason`).
    """
    gain, gain_interval, gain_verdict = _gain(fit, c, settings)
    tau, tau_interval, tau_verdict = _tau(fit, c, settings)
    delay, confidence, delay_verdict = chosen_delay(fit, c, settings)
    reasons = [] if delay_verdict != "inconclusive" else [f"delay uncertain (confidence {100 * confidence:.0f} %)"]
    for label, verdict, interval, tolerance in (
        ("gain", gain_verdict, gain_interval, settings.gain_tolerance_pct),
        ("τ", tau_verdict, tau_interval, settings.tau_tolerance_pct),
    ):
        if verdict == "inconclusive" and interval is not None:
            reasons.append(undecided_reason(label, interval, tolerance=tolerance, settings=settings))
    distrust = trust_reasons(fit, c, settings)
    if distrust:
        delay_verdict = "inconclusive"
        tau_verdict = None if tau_verdict is None else "inconclusive"
    if _edge_reason(fit, c) is not None:
        gain_verdict = "inconclusive"
    halfwidths = (_halfwidth(gain_interval), None if tau_interval is None else _halfwidth(tau_interval))
    apart = separation_reason(fit, c, settings, labels=labels, halfwidths=halfwidths)
    if apart is not None:
        reasons.insert(0, apart)
        gain_verdict = "inconclusive"
        tau_verdict = None if tau_verdict is None else "inconclusive"
    return ParametricResult(
        gain_mismatch_pct=gain,
        gain_mismatch_pct_interval=gain_interval,
        tau_mismatch_pct=tau,
        tau_mismatch_pct_interval=tau_interval,
        delay_mismatch_samples=delay,
        delay_confidence=confidence,
        gain_verdict=gain_verdict,
        tau_verdict=tau_verdict,
        delay_verdict=delay_verdict,
        reasons=(*distrust, *reasons),
        warnings=warnings,
        quality={**quality, "lack_of_fit": float(fit.lack_of_fit[c])},
    )
