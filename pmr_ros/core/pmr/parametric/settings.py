"""Settings of the parametric diagnosis (the ``parametric`` block)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...sim.model import TransferMatrix
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
        quarter of the record.
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

    def welch(self, model: TransferMatrix, samples: int, classic: PmrSettings) -> WelchSettings:
        """The Welch settings for a record of ``samples`` on ``model``."""
        length = self.segment_length
        if length <= 0:
            wanted = (
                self.resolution
                * 2.0
                * math.pi
                * max(slowest_time_constant(model), model.sample_time)
                / model.sample_time
            )
            ceiling = 1 << max(4, int(math.log2(max(16, (samples - model.settling_samples()) // 4))))
            wanted = max(wanted, _bins_for_columns(model.n_inputs))
            length = max(classic.segment_length, min(1 << max(4, math.ceil(math.log2(wanted))), ceiling))
        return WelchSettings(classic.window, length, classic.overlap)


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
