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
from dataclasses import dataclass, replace

import numpy as np

from ..config import ConfigError, PmrConfig
from ..core.pmr.diagnosis import diagnose_stretches, shortest_useful_stretch
from ..core.records import Record
from ..core.results import Diagnosis
from ..core.sim.excitation import dither_generator
from ..core.sim.memory import available_bytes, diagnosis_bytes, format_bytes, window_bytes
from .alignment import MANUAL, AlignedStretch, SampleAligner, manual_marks
from .samples import AddResult

__all__ = [
    "Offer",
    "UsefulData",
    "WindowOutcome",
    "check_window_memory",
    "evaluate_window",
    "offer_signal",
    "useful_data",
    "window_dither",
    "window_info",
    "window_stretches",
    "without_verdict",
]

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
    values: Sequence[float] | np.ndarray,
    update_period_samples: int,
    effort: Sequence[float] | np.ndarray = (),
) -> Offer:
    """Add one message to ``aligner`` and say whether diagnostics are due.

    An update is due when a sample ``k`` with ``(k + 1) % period == 0`` became
    complete, or, while a signal lags, when the message's own sample is one.
    Turning stale is reported separately (the node publishes at once).  A u
    message's ``effort`` (its mode marks; empty: every controller on) goes to
    the aligner with it when the aligner aligns the modes.
    """
    was_lagging = aligner.lagging()
    result = aligner.add(signal, stamp_s, names, values)
    if signal == "u" and MANUAL in aligner.signals and result.accepted:
        modes = aligner.add(MANUAL, stamp_s, names, manual_marks(effort, len(values)))
        result.warnings.extend(modes.warnings)
        result.completed.extend(modes.completed)
    lagging = aligner.lagging()
    newly = lagging if lagging and not was_lagging else None
    period = update_period_samples
    due = any((k + 1) % period == 0 for k in result.completed)
    if not due and lagging and result.accepted:
        newest = aligner.newest[signal]  # an accepted message set it
        due = newest is not None and (newest + 1) % period == 0
    return Offer(result, newly, due)


def window_info(
    aligner: SampleAligner,
    window_samples: int,
    samples: int | None = None,
    first: int | None = None,
    *,
    since: int = 0,
) -> dict:
    """``window_samples``, ``first_sample``, ``last_sample`` of the current window [samples].

    Without ``samples`` and ``first``: the complete samples the window holds
    (the newest ``window_samples`` from sample ``since`` on, in one or more
    stretches); the last sample is always the newest complete one.
    """
    if aligner.stretch_last is None:
        return {"window_samples": 0}
    if samples is None or first is None:
        pieces = window_stretches(aligner, window_samples, since=since)
        if not pieces:
            return {"window_samples": 0}
        samples, first = sum(p.samples for p in pieces), pieces[0].first
    return {"window_samples": samples, "first_sample": first, "last_sample": aligner.stretch_last}


@dataclass(frozen=True)
class WindowOutcome:
    """The diagnosis of the current window, or why there is none.

    Attributes
    ----------
    kind : str
        ``verdict``, ``insufficient_data`` or ``stale``; the live node's own also ``conflict`` or ``failed``.
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


def check_window_memory(config: PmrConfig, source: str) -> None:
    """Refuse a window (``diagnostician.window_samples``) that cannot fit in the memory available now.

    The window fills one sample at a time; its diagnosis needs the most
    (:mod:`pmr_ros.core.sim.memory`).

    Raises
    ------
    ConfigError
        Naming ``diagnostician.window_samples`` and the figures.
    """
    model, samples = config.model, config.diagnostician.window_samples
    held = window_bytes(model, samples)
    diagnosis = diagnosis_bytes(model, samples, dither=config.excitation.active)
    have = available_bytes()
    if have is not None and held + diagnosis > have:
        raise ConfigError(
            source,
            "diagnostician.window_samples",
            samples,
            f"a full window needs about {format_bytes(held + diagnosis)} of memory (samples {format_bytes(held)}, "
            f"diagnosis {format_bytes(diagnosis)}); {format_bytes(have)} available",
        )


def window_dither(config: PmrConfig, first: int, samples: int) -> np.ndarray | None:
    """The MV dither over samples ``first ..`` of the run, or None without dither.

    The dither of the node set is a pure function of the sample and the run's
    seed, so the diagnostician computes it as the controller did.
    """
    if not config.excitation.active:
        return None
    generator = dither_generator(config.excitation, config.prbs, config.run.seed)
    return generator.values(first + np.arange(samples))


@dataclass(frozen=True)
class UsefulData:
    """The stretches of the window that add to a diagnosis, and what was left out.

    Attributes
    ----------
    pieces : list of AlignedStretch
        The useful stretches as aligned (sample indices).
    stretches : list of Record
        The same with their MV dither, for the core.
    held, held_stretches : int
        Complete samples and stretches the window holds.
    shortest : int
        Fewest samples with which a stretch adds a Welch segment.
    all_stretches : list of Record
        Every stretch of the window, useful or not.
    """

    pieces: list[AlignedStretch]
    stretches: list[Record]
    held: int
    held_stretches: int
    shortest: int
    all_stretches: list[Record]

    @property
    def samples(self) -> int:
        """Samples that count towards ``diagnostician.min_samples``.

        Those of the useful stretches; in a window of one stretch, all of it
        (a stretch too short for a Welch segment is then the core's to explain).
        """
        if self.held_stretches <= 1:
            return self.held
        return sum(s.samples for s in self.stretches)

    def shortfall(self, min_samples: int) -> str:
        """Why there are too few: ``N unbroken samples, need M`` and how the window is broken up."""
        reason = f"{self.samples} unbroken samples, need {min_samples}"
        if self.held_stretches > 1:
            left_out = self.held_stretches - len(self.stretches)
            reason += f" (the window holds {self.held} samples in {self.held_stretches} stretches"
            reason += f"; {left_out} shorter than {self.shortest} samples add nothing)" if left_out else ")"
        return reason


def _from(record: Record, cut: int) -> Record:
    """The record from row ``cut`` on (its DVs and modes too)."""
    dv = None if record.dv is None else record.dv[cut:]
    manual = None if record.manual is None or not record.manual[cut:].any() else record.manual[cut:]
    return Record(record.r[cut:], record.u[cut:], record.y[cut:], dv=dv, manual=manual)


def _with_dither(piece: AlignedStretch, config: PmrConfig) -> Record:
    """The stretch with the controller's MV dither, none where an MV's controller was off (as the batch core)."""
    dither = window_dither(config, piece.first, piece.samples)
    if dither is not None and piece.record.manual is not None:
        dither = np.where(piece.record.manual, 0.0, dither)
    return replace(piece.record, dither=dither)


def window_stretches(aligner: SampleAligner, window_samples: int, *, since: int = 0) -> list[AlignedStretch]:
    """The window's stretches (the newest ``window_samples`` complete samples), cut to samples ``since`` on.

    ``since``: the first sample of the controller's current model (data before
    a model switch are diagnosed against the model they ran with, not this one).
    """
    out = []
    for piece in aligner.stretches(window_samples):
        if piece.last < since:
            continue
        cut = max(since - piece.first, 0)
        out.append(piece if cut == 0 else AlignedStretch(since, _from(piece.record, cut)))
    return out


def useful_data(aligner: SampleAligner, config: PmrConfig, *, since: int = 0) -> UsefulData:
    """The stretches of the window (``diagnostician.window_samples``) long enough to add to a diagnosis.

    A stretch shorter than the model's settling plus one Welch segment adds
    nothing to the spectra; it is left out, not an error.  Only samples from
    ``since`` on count (see :func:`window_stretches`).
    """
    pieces = window_stretches(aligner, config.diagnostician.window_samples, since=since)
    data = [_with_dither(p, config) for p in pieces]
    shortest = shortest_useful_stretch(data, model=config.model, pmr=config.pmr, parametric=config.parametric)
    keep = [j for j, d in enumerate(data) if d.samples >= shortest]
    held = sum(p.samples for p in pieces)
    return UsefulData([pieces[j] for j in keep], [data[j] for j in keep], held, len(pieces), shortest, data)


def _newest_stamp(aligner: SampleAligner) -> float:
    """The sample time of the newest complete sample (0 before the first) [s]: the statuses' stamp."""
    return (aligner.stretch_last if aligner.stretch_last is not None else 0) * aligner.sample_time_s


def without_verdict(
    kind: str, reason: str, aligner: SampleAligner, config: PmrConfig, *, since: int = 0
) -> WindowOutcome:
    """The outcome of the current window without a verdict: every element of ``config.model`` inconclusive.

    Also the live node's own no-verdict statuses (a silence, a conflict, a failed diagnosis) are built here.

    Parameters
    ----------
    kind : str
        The outcome's kind, the statuses' ``status`` (``stale``, ``insufficient_data``, ``conflict``, ``failed``).
    reason : str
        Why there is no verdict (one line).
    aligner : SampleAligner
        Its window (:func:`window_info`) and newest sample (the stamp) describe the statuses.
    config : PmrConfig
        The elements and the method; ``diagnostician.window_samples``.
    since : int
        The first sample the controller ran on ``config.model`` (:func:`evaluate_window`).
    """
    window = window_info(aligner, config.diagnostician.window_samples, since=since)
    diagnosis = Diagnosis.insufficient(
        method=config.pmr.method,
        models=config.model.element_models(),
        reason=reason,
        samples=int(window.get("window_samples", 0)),
    )
    return WindowOutcome(kind, diagnosis, reason, window, _newest_stamp(aligner))


def evaluate_window(aligner: SampleAligner, config: PmrConfig, *, since: int = 0) -> WindowOutcome:
    """Diagnose the window's unbroken stretches together, as the diagnostician does.

    Parameters
    ----------
    aligner : SampleAligner
    config : PmrConfig
        The model Ghat, the PMR settings and the diagnostician's window
        (``window_samples``: the newest complete samples diagnosed, in one or
        more stretches; ``min_samples``: the fewest samples, in stretches that
        add to the diagnosis, for a verdict).
    since : int
        The first sample the controller ran on ``config.model`` (after a model
        switch): earlier samples are left out.
    """
    window_samples, min_samples = config.diagnostician.window_samples, config.diagnostician.min_samples
    stale = aligner.lagging()
    if stale:
        return without_verdict(STALE, stale, aligner, config, since=since)
    data = useful_data(aligner, config, since=since)
    if data.samples < min_samples:
        reason = data.shortfall(min_samples) + (f" since the model switch at sample {since}" if since else "")
        return without_verdict(INSUFFICIENT, reason, aligner, config, since=since)
    stamp = _newest_stamp(aligner)
    if not data.stretches:  # one stretch, too short for a Welch segment: the core says why
        diagnosis = diagnose_stretches(
            data.all_stretches,
            model=config.model,
            pmr=config.pmr,
            parametric=config.parametric,
            disturbance_model=config.disturbance_model,
        )
        window = window_info(aligner, window_samples, since=since)
        return WindowOutcome(INSUFFICIENT, diagnosis, diagnosis.reason, window, stamp)
    diagnosis = diagnose_stretches(
        data.stretches,
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        quality=config.quality,
        disturbance_model=config.disturbance_model,
    )
    window = window_info(aligner, window_samples, data.samples, data.pieces[0].first)
    if diagnosis.status != "ok":
        return WindowOutcome(INSUFFICIENT, diagnosis, diagnosis.reason, window, stamp)
    return WindowOutcome(VERDICT, diagnosis, "", window, stamp)
