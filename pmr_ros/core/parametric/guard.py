"""The data-quality guard of the parametric method: which rows and elements the data can diagnose at all.

Per output row: the informative band (where the row's coherence with the
setpoints holds), the mean coherence over it, the median condition number of
the row's regression and the spread of its model time constants; per element,
its share of the row's setpoint-driven output.  A row or element that fails
a check is ``inconclusive`` with the reason -- never a number that cannot be trusted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..classic import PmrSettings
from ..delay import informative_band
from ..foptd import FoptdMatrix
from ..implicit import PmrEstimate
from ..spectra import RecordSpectra, WelchSettings
from .settings import ParametricSettings

__all__ = ["RowQuality", "row_quality"]


@dataclass(frozen=True)
class RowQuality:
    """What the data say about one output row.

    Attributes
    ----------
    bins : ndarray of int
        The fitted frequency bins: 0 and the informative band.
    coherence : float
        Mean squared coherence of the row with the setpoints over ``bins``.
    condition : float
        Median condition number of the row's regression over ``bins``.
    time_constant_ratio : float
        Largest over smallest model time constant of the row.
    excitation : ndarray, shape (n_in,)
        Each element's share of the row's setpoint-driven output.
    reasons : tuple of str
        Why the row cannot be diagnosed (empty: it can).
    warnings : tuple of str
        Remarks that do not stop a verdict.
    """

    bins: np.ndarray
    coherence: float
    condition: float
    time_constant_ratio: float
    excitation: np.ndarray
    reasons: tuple[str, ...]
    warnings: tuple[str, ...]

    def quality(self, k: int, *, omega: np.ndarray, welch: WelchSettings) -> dict[str, float]:
        """The quality figures reported with element ``k``."""
        return {
            "coherence": self.coherence,
            "excitation": float(self.excitation[k]),
            "condition": self.condition,
            "row_time_constant_ratio": self.time_constant_ratio,
            "band_rad_per_sample": float(omega[self.bins].max()),
            "segment_length": int(welch.segment_length),
        }

    def element_reasons(self, k: int, settings: ParametricSettings) -> tuple[str, ...]:
        """The row's reasons plus the element's own (barely excited)."""
        share = float(self.excitation[k])
        if share < settings.excitation_min:
            return (*self.reasons, f"element barely excited ({100 * share:.1f} % of the row's setpoint-driven output)")
        return self.reasons


def row_quality(
    i: int,
    *,
    spectra: RecordSpectra,
    estimate: PmrEstimate,
    model: FoptdMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> RowQuality:
    """Judge output row ``i`` of a record before it is fitted."""
    n_in = model.n_inputs
    coherence = estimate.coherence[:, i]
    band = informative_band(spectra.omega, coherence, classic.coherence_min)
    band[0] = True
    bins = np.flatnonzero(band)
    ratio = float(model.time_constant[i].max() / model.time_constant[i].min())
    row_coherence = float(coherence[bins].mean())
    condition = float(np.median(estimate.condition[bins, i]))
    reasons = []
    if bins.size < 2 * n_in + 2:
        reasons.append(
            f"informative band too narrow: {bins.size} bins before the coherence with the setpoints drops below "
            f"{classic.coherence_min:g}"
        )
    if row_coherence < settings.coherence_min:
        reasons.append(f"coherence with the setpoints too low ({row_coherence:.2f} < {settings.coherence_min:g})")
    if not np.isfinite(condition) or condition > settings.max_condition:
        reasons.append(f"ill-conditioned row regression (condition {condition:.3g} > {settings.max_condition:g})")
    warnings = []
    if ratio > settings.row_time_constant_ratio_warn:
        warnings.append(
            f"row {i + 1} mixes time constants {ratio:.1f}x apart "
            f"(> {settings.row_time_constant_ratio_warn:g}: the classic PMR's filtering effect)"
        )
    # each element's share of the row's setpoint-driven output: can it be seen at all?
    driven = np.abs(spectra.ryhat[bins][:, :, i, :]) ** 2  # (F', n_r, n_in)
    share = driven.sum(axis=(0, 1)) / max(driven.sum(), 1e-300)
    return RowQuality(bins, row_coherence, condition, ratio, share, tuple(reasons), tuple(warnings))
