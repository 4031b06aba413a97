"""The data-quality guard of the parametric method: which rows and elements the data can diagnose at all.

Per output row: whether it is identifiable at all (as many instruments as
regressors, :func:`~pmr_ros.core.pmr.implicit.row_layout`), the informative band
(where the row's coherence with the instruments holds), the mean coherence
over it, the median condition number of the row's regression and the spread
of its model time constants; per modeled element, its share of the row's
instrument-driven output.  A row or element that fails a check is
``inconclusive`` with the reason -- never a number that cannot be trusted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...sim.model import TransferMatrix
from ..classic import PmrSettings
from ..implicit import RowEstimate, RowLayout
from ..spectra import WelchSettings
from ..timescale import row_time_constants
from .rank import collinear_inputs_reason
from .settings import ParametricSettings

__all__ = [
    "FAIR_SHARE_ELEMENTS",
    "NEGLIGIBLE_GAIN_RATIO",
    "RowQuality",
    "fitted_bins",
    "negligible_gains",
    "row_quality",
]

NEGLIGIBLE_GAIN_RATIO = 1e-4
"""A model gain below this fraction of the row's largest is taken as ~0: the element is an empty cell in effect.

Its filtered input then carries no information whatever the input does (its
share of the row's output is below 1e-8 of the largest element's for inputs
moved alike), so the element is left out of the row's fit and called what it
is -- a property of the model, not of the excitation."""

FAIR_SHARE_ELEMENTS = 4
"""Rows of up to this many modeled elements hold each to ``parametric.excitation_min``; a row of n more to
``excitation_min * FAIR_SHARE_ELEMENTS / n``.

The share of the row's instrument-driven output an element carries falls as its row has more elements
(a fair share is 1/n).  Measured on a 32x32 half-empty unit at 65,536 samples (rows of 12-21 elements):
105 of its 512 elements carried 0.4-2.0 % and were held back by the 2 % set on 2x2 rows, although all 105
came out within specification once decided (97 mismatch, 8 ok; dK error at most 2.5 pp)."""


@dataclass(frozen=True)
class RowQuality:
    """What the data say about one output row.

    Attributes
    ----------
    layout : RowLayout
        The regressors the row's data carry.
    bins : ndarray of int
        The fitted frequency bins: the informative band, and 0 unless the row is differenced.
    coherence : float
        Mean squared coherence of the row with the instruments over ``bins``.
    condition : float
        Median condition number of the row's regression over ``bins``.
    time_constant_ratio : float
        Largest over smallest model time constant (or equivalent, :mod:`~pmr_ros.core.pmr.timescale`) of the row.
    excitation : ndarray, shape (n_columns,)
        Each modeled element's share of the row's instrument-driven output (0 for an empty cell).
    reasons : tuple of str
        Why the row cannot be diagnosed (empty: it can).
    warnings : tuple of str
        Remarks that do not stop a verdict.
    negligible : ndarray of bool, shape (n_columns,)
        Modeled elements whose model gain is ~0 (:data:`NEGLIGIBLE_GAIN_RATIO`): left out of the fit.
    gains : ndarray, shape (n_columns,)
        The model gains of the layout's columns (0 for an empty cell).
    """

    layout: RowLayout
    bins: np.ndarray
    coherence: float
    condition: float
    time_constant_ratio: float
    excitation: np.ndarray
    reasons: tuple[str, ...]
    warnings: tuple[str, ...]
    negligible: np.ndarray
    gains: np.ndarray

    def quality(self, c: int, *, omega: np.ndarray, welch: WelchSettings) -> dict[str, float]:
        """The quality figures reported with column ``c`` of the layout (any row figures when ``c`` < 0)."""
        figures = {
            "coherence": self.coherence,
            "condition": self.condition,
            "row_time_constant_ratio": self.time_constant_ratio,
            "band_rad_per_sample": float(omega[self.bins].max()) if self.bins.size else 0.0,
            "segment_length": int(welch.segment_length),
        }
        if c >= 0:
            figures["excitation"] = float(self.excitation[c])
        return figures

    def element_reasons(
        self, c: int, settings: ParametricSettings, *, modeled: bool, input_name: str, element_name: str
    ) -> tuple[str, ...]:
        """The row's reasons plus column ``c``'s own: a model gain ~0, or a modeled element barely excited."""
        share = float(self.excitation[c])
        if modeled and self.negligible[c]:
            return (
                *self.reasons,
                f"{element_name}'s model gain {self.gains[c]:.3g} is ~0 (below {NEGLIGIBLE_GAIN_RATIO:g} of the row's "
                "largest): its filtered input carries no information; treat it as an empty cell (element_type none)",
            )
        least, elements = self.excitation_least(settings)
        if modeled and share < least:
            scaled = f" x {FAIR_SHARE_ELEMENTS}/{elements} elements" if least < settings.excitation_min else ""
            return (
                *self.reasons,
                f"element barely excited ({100 * share:.1f} % of the row's instrument-driven output < "
                f"parametric.excitation_min {100 * settings.excitation_min:g} %{scaled}): move {input_name} more "
                "(MV dither)",
            )
        return self.reasons

    def excitation_least(self, settings: ParametricSettings) -> tuple[float, int]:
        """The least share a modeled element of this row must carry, and the row's modeled elements.

        ``parametric.excitation_min``, scaled by ``FAIR_SHARE_ELEMENTS / n`` in a row of n more elements.
        """
        elements = int(np.count_nonzero(self.gains))
        return settings.excitation_min * min(1.0, FAIR_SHARE_ELEMENTS / max(elements, 1)), elements


def fitted_bins(omega: np.ndarray, coherence: np.ndarray, *, differenced: bool, coherence_min: float) -> np.ndarray:
    """The bins a row's fit uses: 0 (unless differenced) and the informative band.

    The band is the paper's (:func:`~pmr_ros.core.pmr.delay.informative_band`),
    except that it may start above the lowest bins: slow disturbances or
    saturated inputs can leave the lowest bins with little coherence with the
    instruments, and they would end the band before it began.  The fit's
    weighting already gives such bins little say where they are noisy.
    """
    good = (omega > 0) & (coherence >= coherence_min)
    band = np.zeros(omega.size, dtype=bool)
    usable = np.flatnonzero(good)
    if usable.size:
        start = int(usable[0])
        drops = np.flatnonzero(~good[start:])
        band[start : start + int(drops[0]) if drops.size else omega.size] = True
    band[0] = not differenced  # a differenced row has nothing at 0
    return np.flatnonzero(band)


def _reasons(
    layout: RowLayout,
    bins: np.ndarray,
    coherence: float,
    condition: float,
    *,
    settings: ParametricSettings,
    min_bins: int,
    coherence_min: float,
    inputs: list[str],
) -> list[str]:
    reasons = list(layout.reasons)
    if reasons:
        return reasons
    if bins.size < min_bins:
        reasons.append(
            f"informative band too narrow: {bins.size} bins before the coherence with the instruments drops below "
            f"{coherence_min:g}"
        )
    if coherence < settings.coherence_min:
        reasons.append(f"coherence with the instruments too low ({coherence:.2f} < {settings.coherence_min:g})")
    if not np.isfinite(condition) or condition > settings.max_condition:
        reasons.append(collinear_inputs_reason(condition, max_condition=settings.max_condition, inputs=inputs))
    return reasons


def _warnings(layout: RowLayout, *, bins: np.ndarray, omega: np.ndarray) -> tuple[str, ...]:
    """Remarks on a row that do not stop its verdicts.

    (A row mixing time constants troubles the classic PMR, not this fit: the classic method warns of it.)
    """
    warnings = []
    band = bins[bins > 0]
    skipped = int(band[0]) - 1 if band.size else 0
    if skipped > 0:
        warnings.append(
            f"{f'the lowest {skipped} bins' if skipped > 1 else 'the lowest bin'} (below {omega[skipped + 1]:.3f} "
            "rad/sample) lack coherence with the instruments and are not fitted (slow disturbances, saturated inputs?)"
        )
    if layout.untested:
        warnings.append(f"assumes no unmodeled interaction where the model is empty ({layout.untested})")
    return tuple(warnings)


def negligible_gains(model: TransferMatrix, i: int, columns: np.ndarray) -> np.ndarray:
    """Which of row ``i``'s ``columns`` are modeled elements with a model gain ~0 (:data:`NEGLIGIBLE_GAIN_RATIO`)."""
    modeled = model.present[i]
    gains = np.abs(np.where(modeled, model.gain[i], 0.0))
    largest = float(gains.max()) if gains.size else 0.0
    return (modeled & (gains < NEGLIGIBLE_GAIN_RATIO * largest))[columns]


def row_quality(
    layout: RowLayout,
    estimate: RowEstimate,
    *,
    omega: np.ndarray,
    model: TransferMatrix,
    classic: PmrSettings,
    settings: ParametricSettings,
) -> RowQuality:
    """Judge one output row (its layout and implicit estimate) before it is fitted."""
    i = layout.row
    differenced = bool(model.integrating_outputs[i])
    bins = fitted_bins(omega, estimate.coherence, differenced=differenced, coherence_min=classic.coherence_min)
    taus = row_time_constants(model, i)
    ratio = float(taus.max() / taus.min()) if taus.size else 1.0
    coherence = float(estimate.coherence[bins].mean()) if bins.size else 0.0
    condition = float(np.median(estimate.condition_at(bins))) if bins.size and layout.columns.size else np.inf
    reasons = _reasons(
        layout,
        bins,
        coherence,
        condition,
        settings=settings,
        min_bins=2 * layout.columns.size + 2,
        coherence_min=classic.coherence_min,
        inputs=[model.input_names[k] for k in layout.columns],
    )
    warnings = _warnings(layout, bins=bins, omega=omega)
    # each modeled element's share of the row's instrument-driven output: can it be seen at all?
    modeled = model.present[i, layout.columns]
    driven = np.where(modeled, estimate.power[bins].sum(axis=0), 0.0) if bins.size else np.zeros(modeled.size)
    share = driven / max(float(driven.sum()), 1e-300)
    negligible = negligible_gains(model, i, layout.columns)
    gains = np.where(modeled, model.gain[i, layout.columns], 0.0)
    return RowQuality(layout, bins, coherence, condition, ratio, share, tuple(reasons), warnings, negligible, gains)
