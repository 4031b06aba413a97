"""When the diagnostician diagnoses and what: the update schedule and the window's outcome.

Shared, rclpy-free, by the live ``pmr_diagnostician`` node and the offline
diagnosis of a bag (:mod:`pmr_ros.bag.offline`), so both diagnose the same
windows of the same aligned samples with the same code and their verdicts are
equal number for number.  Only the wall-clock silence check (STALE after
``diagnostician.stale_timeout_s`` without messages) is the node's alone: a bag
has no wall time.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..config import PmrConfig
from ..core.diagnosis import diagnose
from ..core.results import Diagnosis
from .alignment import AddResult, SampleAligner

VERDICT, INSUFFICIENT, STALE = "verdict", "insufficient_data", "stale"
"""Kinds of :class:`WindowOutcome`."""


@dataclass(frozen=True)
class Offer:
    """What one r, u or y message did to the schedule.

    Attributes
    ----------
    result : AddResult
        The aligner's answer (warnings, completed samples).
    newly_lagging : str or None
        Why the data just turned stale (a signal fell behind), else None.
    update_due : bool
        Whether the diagnostician's periodic update falls on this message.
    """

    result: AddResult
    newly_lagging: str | None
    update_due: bool


def offer_signal(
    aligner: SampleAligner,
    signal: str,
    *,
    stamp_s: float,
    names: Sequence[str],
    values: Sequence[float],
    update_period_samples: int,
) -> Offer:
    """Add one message to ``aligner`` and say whether diagnostics are due.

    An update is due when a sample ``k`` with ``(k + 1) % period == 0`` became
    complete, or, while a signal lags, when the message's own sample is one.
    Turning stale is reported separately (the node publishes at once).
    """
    was_lagging = aligner.lagging()
    result = aligner.add(signal, stamp_s, names, values)
    lagging = aligner.lagging()
    newly = lagging if lagging and not was_lagging else None
    period = update_period_samples
    due = any((k + 1) % period == 0 for k in result.completed)
    if not due and lagging and result.accepted:
        due = (aligner.newest[signal] + 1) % period == 0
    return Offer(result, newly, due)


def window_info(
    aligner: SampleAligner, window_samples: int, samples: int | None = None, first: int | None = None
) -> dict:
    """``window_samples``, ``first_sample``, ``last_sample`` of the current window [samples]."""
    if aligner.stretch_last is None:
        return {"window_samples": 0}
    if samples is None:
        samples = min(aligner.stretch_length, window_samples)
        first = aligner.stretch_last - samples + 1
    return {"window_samples": samples, "first_sample": first, "last_sample": aligner.stretch_last}


@dataclass(frozen=True)
class WindowOutcome:
    """The diagnosis of the current window, or why there is none.

    Attributes
    ----------
    kind : str
        ``verdict``, ``insufficient_data`` or ``stale``.
    diagnosis : Diagnosis
        With ``status == "ok"`` for a verdict; without numbers (every element
        inconclusive for ``reason``) otherwise.
    reason : str
        Why there is no verdict ("" for a verdict).
    window : dict
        See :func:`window_info`.
    stamp_s : float
        Sample time of the newest sample in the window [s].
    """

    kind: str
    diagnosis: Diagnosis
    reason: str
    window: dict
    stamp_s: float


def evaluate_window(aligner: SampleAligner, config: PmrConfig) -> WindowOutcome:
    """Diagnose the newest ``diagnostician.window_samples`` of the unbroken stretch, as the diagnostician does.

    Parameters
    ----------
    aligner : SampleAligner
    config : PmrConfig
        The model Ghat, the PMR settings and the diagnostician's window
        (``window_samples``, and ``min_samples``: the fewest unbroken samples
        for a verdict).
    """
    window_samples, min_samples = config.diagnostician.window_samples, config.diagnostician.min_samples
    stamp = (aligner.stretch_last if aligner.stretch_last is not None else 0) * aligner.sample_time_s
    window = window_info(aligner, window_samples)

    def without_verdict(kind: str, reason: str) -> WindowOutcome:
        models = config.model.element_models()
        samples = int(window.get("window_samples", 0))
        return WindowOutcome(
            kind,
            Diagnosis.insufficient(method=config.pmr.method, models=models, reason=reason, samples=samples),
            reason,
            window,
            stamp,
        )

    stale = aligner.lagging()
    if stale:
        return without_verdict(STALE, stale)
    if aligner.stretch_length < min_samples:
        reason = f"{aligner.stretch_length} unbroken samples, need {min_samples}"
        if aligner.gaps:
            reason += f" (the window restarted after a gap {aligner.gaps} time(s))"
        return without_verdict(INSUFFICIENT, reason)
    r, u, y, first = aligner.window(window_samples)
    diagnosis = diagnose(r, u, y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    window = window_info(aligner, window_samples, r.shape[0], first)
    if diagnosis.status != "ok":
        return WindowOutcome(INSUFFICIENT, diagnosis, diagnosis.reason, window, stamp)
    return WindowOutcome(VERDICT, diagnosis, "", window, stamp)
