"""One window of a long record: its unbroken stretches, cut from the record without copying it, and its diagnosis.

What a monitor's every worker runs (:mod:`.monitoring`): the record is read and cleaned once
(:class:`WindowJob`), a window is a span of its samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..config import PmrConfig
from ..core.pmr.diagnosis import diagnose_stretches
from ..core.pmr.piecewise import PieceCache
from ..core.records import Record
from ..core.results import Diagnosis
from ..data import PlantData
from .historian import limits_given

__all__ = ["WindowJob", "diagnose_window", "stretch_spans", "window_stretches"]


@dataclass(frozen=True)
class WindowJob:
    """What every worker holds once: the configuration, the whole record and its usable-sample mask.

    Attributes
    ----------
    config : PmrConfig
    data : PlantData
        The whole record, cleaned.
    usable : ndarray of bool, shape (samples,)
        ``data.usable``, computed once.
    """

    config: PmrConfig
    data: PlantData
    usable: np.ndarray


def stretch_spans(job: WindowJob, first: int, last: int) -> list[tuple[int, int]]:
    """The first and last sample (inclusive, in the whole record) of each unbroken usable stretch of ``first..last``."""
    usable = job.usable[first : last + 1]
    edges = np.flatnonzero(np.diff(np.concatenate(([False], usable, [False])).astype(np.int8))) + first
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def window_stretches(
    job: WindowJob, first: int, last: int, *, deviations: bool = True, pieces: PieceCache | None = None
) -> list[Record]:
    """The unbroken usable stretches of samples ``first..last`` (inclusive), each one's means removed if ``deviations``.

    Each stretch is a slice of the record; only the deviations are new arrays, and with ``pieces`` a stretch
    the window before held too is that window's (:meth:`PieceCache.stretch`: the same deviations).
    """
    out = []
    for a, b in stretch_spans(job, first, last):
        if pieces is not None and deviations:
            out.append(pieces.stretch((a, b), partial(_stretch, job, a, b, deviations=True)))
        else:
            out.append(_stretch(job, a, b, deviations=deviations))
    return out


def _stretch(job: WindowJob, a: int, b: int, *, deviations: bool) -> Record:
    """Samples ``a..b`` (inclusive) of the record, their means removed if ``deviations``."""
    part = {key: values[a : b + 1] for key, values in job.data.signals.items()}
    if deviations:
        part = {key: values - values.mean(axis=0) for key, values in part.items()}
    manual = None if job.data.manual is None else job.data.manual[a : b + 1]  # b inclusive, as above
    manual = manual if manual is not None and manual.any() else None
    return Record(part["r"], part["u"], part["y"], part.get("dither"), part.get("dv"), manual)


def diagnose_window(job: WindowJob, span: tuple[int, int], *, pieces: PieceCache | None = None) -> Diagnosis:
    """The diagnosis of one window (one estimate from its unbroken stretches), with its data quality.

    With ``pieces`` the stretches it shares with the windows before it are not filtered and transformed again
    (:mod:`pmr_ros.core.pmr.piecewise`; the same diagnosis).
    """
    first, last = span
    config = job.config
    quality = config.quality if limits_given(config) else config.quality.without_limits()
    stretches = window_stretches(job, first, last, pieces=pieces)

    def diagnosed() -> Diagnosis:
        return diagnose_stretches(
            stretches,
            model=config.model,
            pmr=config.pmr,
            parametric=config.parametric,
            quality=quality,
            as_read=window_stretches(job, first, last, deviations=False),
            disturbance_model=config.disturbance_model,
        )

    if pieces is None:
        return diagnosed()
    with pieces.window(stretches, stretch_spans(job, first, last)):
        return diagnosed()
