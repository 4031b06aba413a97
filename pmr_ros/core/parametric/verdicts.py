"""Calibrated verdicts of one element from its row's fit: intervals, delay confidence, ok/mismatch/inconclusive."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy.stats import norm

from ..results import ParametricResult
from .fit import RowFit
from .settings import ParametricSettings

__all__ = ["delay_confidence", "element_result", "parameter_verdict"]


def parameter_verdict(value: float, interval: tuple[float, float], *, tolerance: float, max_halfwidth: float) -> str:
    """The verdict of one parameter.

    ``mismatch`` when the interval excludes zero *and* the estimate exceeds the
    practical tolerance; else ``inconclusive`` when the interval is wider than
    ``+/- max_halfwidth``; else ``ok``.

    Parameters
    ----------
    value : float
        The estimate [%].
    interval : (float, float)
        Its confidence interval [%].
    tolerance, max_halfwidth : float
        [%] and [percentage points].
    """
    low, high = interval
    if (low > 0 or high < 0) and abs(value) > tolerance:
        return "mismatch"
    if (high - low) / 2.0 > max_halfwidth:
        return "inconclusive"
    return "ok"


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


def element_result(
    fit: RowFit,
    k: int,
    *,
    settings: ParametricSettings,
    quality: Mapping[str, float],
    warnings: tuple[str, ...],
) -> ParametricResult:
    """The estimate, intervals and verdicts of element ``k`` of a fitted row."""
    n = fit.gain_ratio.size
    z = float(norm.ppf(0.5 + settings.confidence_level / 2.0))
    rho, s = float(fit.gain_ratio[k]), float(fit.log_tau_ratio[k])
    sd_rho = math.sqrt(max(fit.covariance[k, k], 0.0))
    sd_s = math.sqrt(max(fit.covariance[n + k, n + k], 0.0))
    gain = 100.0 * (rho - 1.0)
    gain_interval = (100.0 * (rho - z * sd_rho - 1.0), 100.0 * (rho + z * sd_rho - 1.0))
    tau = 100.0 * math.expm1(s)
    tau_interval = (100.0 * math.expm1(s - z * sd_s), 100.0 * math.expm1(s + z * sd_s))
    delay = int(fit.delay_samples[k])
    confidence = delay_confidence(fit.delay_profile[k], delay, max(1.0, fit.chi_square / fit.dof))
    gain_verdict = parameter_verdict(
        gain, gain_interval, tolerance=settings.gain_tolerance_pct, max_halfwidth=settings.max_interval_pct
    )
    tau_verdict = parameter_verdict(
        tau, tau_interval, tolerance=settings.tau_tolerance_pct, max_halfwidth=settings.max_interval_pct
    )
    reasons = []
    if confidence < settings.delay_confidence_min:
        delay_verdict = "inconclusive"
        reasons.append(f"delay uncertain (confidence {100 * confidence:.0f} %)")
    else:
        delay_verdict = "mismatch" if delay != 0 else "ok"
    for label, verdict, interval in (("gain", gain_verdict, gain_interval), ("τ", tau_verdict, tau_interval)):
        if verdict == "inconclusive":
            reasons.append(f"{label} interval [{interval[0]:+.1f}, {interval[1]:+.1f}] % too wide")
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
        reasons=tuple(reasons),
        warnings=warnings,
        quality=dict(quality),
    )
