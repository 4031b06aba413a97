"""The verdict on an unmodelled interaction: an empty cell of the model that the plant may fill.

An empty cell's interaction is judged by the share of the row's
instrument-driven output it carries, against the gain tolerance, with its
interval widened for the search over its delay and time constant (the best of
many candidates is larger than one chosen in advance: a Bonferroni bound over
:func:`~.parameterization.search_candidates`).
"""

from __future__ import annotations

from collections.abc import Mapping

from ...results import ParametricResult
from .fit import RowFit
from .parameterization import bonferroni_z, search_candidates
from .settings import ParametricSettings
from .verdicts import chosen_delay, parameter_verdict, trust_reasons, z_score

__all__ = ["interaction_result", "interaction_verdict"]


def interaction_verdict(share_pct: float, sd_pct: float, *, candidates: int, settings: ParametricSettings) -> str:
    """The verdict on an interaction of ``share_pct`` % of the row's instrument-driven output.

    The share's interval is widened to the Bonferroni level of ``candidates``
    searched templates; then :func:`parameter_verdict` with the gain tolerance.
    """
    z = bonferroni_z(candidates=candidates, confidence_level=settings.confidence_level)
    interval = (share_pct - z * sd_pct, share_pct + z * sd_pct)
    z_one = z_score(settings)
    return parameter_verdict(
        interval,
        tolerance=settings.gain_tolerance_pct,
        ok_band_factor=settings.ok_band_factor,
        max_halfwidth=settings.max_interval_pct,
        ok_interval=(share_pct - z_one * sd_pct, share_pct + z_one * sd_pct),
    )


def interaction_result(
    fit: RowFit,
    c: int,
    *,
    share_per_gain: float,
    settings: ParametricSettings,
    quality: Mapping[str, float],
    warnings: tuple[str, ...],
) -> ParametricResult:
    """An empty cell, column ``c`` of a fitted row: the interaction's gain, interval, delay and verdict.

    Parameters
    ----------
    share_per_gain : float
        Root-mean-square share of the row's instrument-driven output that a
        unit gain of the fitted template would carry.
    """
    z = z_score(settings)
    gamma, sd = float(fit.lin[c]), float(fit.sd_lin[c])
    share, sd_share = 100.0 * gamma * share_per_gain, 100.0 * sd * share_per_gain
    verdict = interaction_verdict(share, sd_share, candidates=search_candidates(fit.columns[c]), settings=settings)
    delay, confidence = int(fit.delays[c]), None  # no profile: an absent interaction's (profile.absent)
    if fit.delay_profile[c]:
        delay, confidence, _ = chosen_delay(fit, c, settings)
    reasons = list(trust_reasons(fit, c, settings)) if verdict == "mismatch" else []
    if reasons:
        verdict = "inconclusive"
    elif verdict == "inconclusive":
        band = settings.ok_band_factor * settings.gain_tolerance_pct
        reasons.append(
            f"interaction of {share:+.1f} % ± {z * sd_share:.1f} of the row's driven output: cannot rule out one "
            f"beyond ±{band:g} % ({settings.ok_band_factor:g}x the gain tolerance)"
        )
    if verdict == "mismatch":
        if confidence is None:  # its gain was within the search's chance level when the delays were profiled
            warnings = (*warnings, "interaction delay not profiled")
        elif confidence < settings.delay_confidence_min:
            warnings = (*warnings, f"interaction delay uncertain (confidence {100 * confidence:.0f} %)")
    return ParametricResult(
        delay_confidence=confidence,
        gain_verdict=None,
        tau_verdict=None,
        delay_verdict=None,
        unmodeled_gain=gamma,
        unmodeled_gain_interval=(gamma - z * sd, gamma + z * sd),
        unmodeled_delay_samples=delay,
        unmodeled_verdict=verdict,
        reasons=tuple(reasons),
        warnings=warnings,
        quality={**quality, "unmodeled_share_pct": share, "lack_of_fit": float(fit.lack_of_fit[c])},
    )
