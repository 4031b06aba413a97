"""Settings of the parametric diagnosis (the ``parametric`` block)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from ...records import InstrumentSet, Record, moving_instruments
from ...sim.model import TransferMatrix
from ..checks import segments_needed, welch_segments
from ..classic import PmrSettings
from ..spectra import WelchSettings
from ..timescale import slowest_time_constant

__all__ = ["ParametricSettings"]


@dataclass(frozen=True)
class ParametricSettings:
    """Settings of the parametric diagnosis and of its calibrated verdicts.

    Defaults and ranges: ``config/parameters.yaml``.  The delay search range
    is the classic one, ``pmr.max_delay_samples``.

    Attributes
    ----------
    segment_length : int
        Welch segment [samples]; 0 picks it from the slowest model element so
        the bins resolve its corner: ``resolution x 2 pi tau_max / Ts``
        (tau_max the largest time constant or equivalent, :mod:`~pmr_ros.core.pmr.timescale`),
        rounded up to a power of two, between the classic segment and a
        quarter of the record; shorter when the record is too short for the
        instruments' segments (:meth:`welch`).
    resolution : float
        See ``segment_length``.
    confidence_level : float
        Of the intervals (0.95).
    gain_tolerance_pct, tau_tolerance_pct : float
        Practical tolerance [%]: a mismatch is flagged only when the whole
        interval lies beyond it.
    max_interval_pct : float
        An interval wider than +/- this [percentage points] cannot support a
        verdict: the parameter is inconclusive.
    ok_band_factor : float
        A parameter is ``ok`` only when its interval lies within +/- this
        times its tolerance: an interval that cannot rule out a change of
        (by default) twice the tolerance is inconclusive, not a confident ok.
    delay_confidence_min : float
        The delay verdict needs this confidence; below it, inconclusive.
    coherence_min : float
        A row whose mean squared coherence with the setpoints over the fitted
        band is below this is inconclusive.
    excitation_min : float
        An element whose share of its row's setpoint-driven output is below
        this is inconclusive (it is not seen in the data).
    max_condition : float
        A row whose regression's median condition number exceeds this is inconclusive.
    row_time_constant_ratio_warn : float
        The paper's filtering-effect limit: a row whose model time constants
        differ by more gets a quality warning (not a verdict change).
    lack_of_fit_max : float
        An element whose fitted response lies further from the per-bin free
        estimate than this, in mean squared units of that estimate's noise
        (about 1 when the model fits), is inconclusive: the fit cannot follow
        the data (a delay beyond the search range, another element structure).
    max_collinearity : float
        An element whose gain information the row's other elements account
        for beyond this share (its filtered input moves with theirs) and
        whose interval is wider than the practical tolerance cannot be told
        apart from them: its gain and time constant are inconclusive.
    joint_delay_correlation : float
        Two elements of a row whose delay estimates correlate at least this
        much (one's shift compensated by the other's) have their delays
        searched jointly, and their delay confidence and intervals cover the
        joint alternatives.
    """

    segment_length: int
    resolution: float
    confidence_level: float
    gain_tolerance_pct: float
    tau_tolerance_pct: float
    max_interval_pct: float
    ok_band_factor: float
    delay_confidence_min: float
    coherence_min: float
    excitation_min: float
    max_condition: float
    row_time_constant_ratio_warn: float
    lack_of_fit_max: float
    max_collinearity: float
    joint_delay_correlation: float

    def welch(
        self,
        model: TransferMatrix,
        samples: int,
        classic: PmrSettings,
        *,
        lengths: Sequence[int] = (),
        instruments: int = 0,
    ) -> WelchSettings:
        """The Welch settings for a record whose longest stretch has ``samples`` on ``model``.

        With ``segment_length`` 0 the segment resolves the slowest element
        (see the attribute).  When the stretches of ``lengths`` (default one of
        ``samples``) then give fewer segments than ``instruments`` need
        (:func:`~pmr_ros.core.pmr.checks.segments_needed`), the segment is the
        longest that gives them: a wide unit's short record is read at a
        coarser resolution rather than refused.  It never shortens below the
        bins a row of the model's columns needs (:func:`_bins_for_columns`);
        a record too short even for that is left to the checks to refuse.

        Parameters
        ----------
        model : TransferMatrix
        samples : int
            Samples of the longest stretch.
        classic : PmrSettings
            The window, overlap and least segment.
        lengths : sequence of int, optional
            Samples of every stretch (default ``[samples]``).
        instruments : int
            The external signals that move (0: no shortening).
        """
        length = self.segment_length
        if length > 0:
            return WelchSettings(classic.window, length, classic.overlap)
        wanted = self.resolution * 2.0 * math.pi * max(slowest_time_constant(model), model.sample_time)
        wanted /= model.sample_time
        ceiling = 1 << max(4, int(math.log2(max(16, (samples - model.settling_samples()) // 4))))
        wanted = max(wanted, _bins_for_columns(model.n_inputs))
        length = max(classic.segment_length, min(1 << max(4, math.ceil(math.log2(wanted))), ceiling))
        welch = WelchSettings(classic.window, length, classic.overlap)
        if instruments <= 0:
            return welch
        return _shortened(welch, model, lengths or (samples,), need=segments_needed(instruments))

    def welch_for(
        self,
        model: TransferMatrix,
        stretches: Sequence[Record],
        classic: PmrSettings,
        *,
        moving: InstrumentSet | None = None,
    ) -> WelchSettings:
        """:meth:`welch` of ``stretches``: their lengths and the instruments that move in them.

        ``moving``: the stretches' :func:`~pmr_ros.core.records.moving_instruments`, when at hand.
        """
        lengths = [s.samples for s in stretches]
        if moving is None and stretches:
            moving = moving_instruments(stretches)
        instruments = moving.count if moving is not None else 0
        return self.welch(model, max(lengths, default=0), classic, lengths=lengths, instruments=instruments)


def _shortened(welch: WelchSettings, model: TransferMatrix, lengths: Sequence[int], *, need: int) -> WelchSettings:
    """``welch`` with the longest segment (even, at least the columns' bins) that gives ``need`` segments."""

    def enough(length: int) -> bool:
        return welch_segments(lengths, model=model, welch=replace(welch, segment_length=length)) >= need

    if enough(welch.segment_length):
        return welch
    low = max(16, 2 * math.ceil(_bins_for_columns(model.n_inputs) / 2.0))
    if low >= welch.segment_length or not enough(low):
        return replace(welch, segment_length=min(low, welch.segment_length))
    high = welch.segment_length  # low gives enough segments, high does not: bisect on even lengths
    while high - low > 2:
        middle = low + 2 * ((high - low) // 4)
        low, high = (middle, high) if enough(middle) else (low, middle)
    return replace(welch, segment_length=low)


FIT_BAND = 0.7
"""The band a row's fit can count on [rad/sample]: where the coherence with the default setpoint PRBS ends
(measured on a 32 x 32 unit: 57 bins of 512), just below the PRBS's first null (clock 8: 0.785)."""


def _bins_for_columns(n_columns: int) -> float:
    """The segment [samples] with the guard's least bins for a row of ``n_columns`` (2 n + 2) below :data:`FIT_BAND`.

    Under the default excitation the informative band ends near 0.7 rad/sample, 57 bins of a 512-sample
    segment: a row of 28 or more columns (a 32 x 32 half-empty unit) could never be fitted.  Rows of up to 27
    columns keep the segment they had.  Measured on
    that unit at 65,536 samples: 0 of 512 elements within specification at 512 samples, 407 at 1024.
    """
    return (2 * n_columns + 2) * 2.0 * math.pi / FIT_BAND
