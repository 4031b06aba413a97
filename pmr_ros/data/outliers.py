"""Gross outliers of a historian tag: cells far beyond what the tag ever moves from sample to sample.

One bad cell an export does not list in ``data.bad_values`` (a sentinel
-99999, a spike 1e6, an overflow 1e308) is no measurement, and left in it
swamps a Welch segment's spectra: the row's coherence with the setpoints
drops and a whole CV row becomes inconclusive for a false reason.  A cell is
a gross outlier when it lies farther from the median of its neighbours
(:data:`WINDOW` samples centred on it) than ``data.outlier_mad`` times the
tag's robust step size -- ``1.4826 x`` the median of its nonzero
sample-to-sample changes, the median absolute deviation of a noisy tag's
differences, and the typical move of a stepping one (a setpoint).  A legal
signal stays within about 15 such steps of its local median (measured on
Wood-Berry under MPC and under PI control: at most 13); a sentinel lies 1e5
and more away.  Runs of up to half the window are caught; longer runs of one
value are frozen (:func:`~pmr_ros.data.clean.frozen`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .clean import CleaningStep

__all__ = ["WINDOW", "gross_outliers", "outlier_step", "step_scale"]

WINDOW = 21
"""Samples of the running median a cell is compared with (odd: centred)."""

MAD_TO_SIGMA = 1.4826
"""The median absolute deviation of a normal variable times this is its standard deviation."""


def step_scale(x: np.ndarray) -> float:
    """The tag's robust step size: ``1.4826 x median |x[k+1] - x[k]|`` over its nonzero valid changes (0: none).

    Examples
    --------
    >>> round(step_scale(np.array([0.0, 1.0, 1.0, 3.0, np.nan, 4.0])), 4)
    2.2239
    """
    steps = np.abs(np.diff(np.asarray(x, dtype=float)))
    steps = steps[np.isfinite(steps) & (steps > 0)]
    return float(MAD_TO_SIGMA * np.median(steps)) if steps.size else 0.0


def gross_outliers(values: np.ndarray, threshold: float) -> np.ndarray:
    """Cells farther than ``threshold`` robust steps from the running median of their tag.

    Parameters
    ----------
    values : ndarray, shape (samples, tags)
        The tags on the sample grid, NaN missing.
    threshold : float
        ``data.outlier_mad``; 0 turns the check off.

    Returns
    -------
    ndarray of bool, shape (samples, tags)

    Examples
    --------
    >>> x = np.sin(np.arange(50.0) / 5.0)[:, None]
    >>> x[17, 0] = -99999.0
    >>> np.flatnonzero(gross_outliers(x, 100.0)).tolist()
    [17]
    """
    import pandas as pd

    values = np.asarray(values, dtype=float)
    out = np.zeros(values.shape, dtype=bool)
    if threshold <= 0:
        return out
    for j in range(values.shape[1]):
        x = values[:, j]
        scale = step_scale(x)
        if scale == 0.0:
            continue
        local = pd.Series(x).rolling(WINDOW, center=True, min_periods=1).median().to_numpy(copy=True)
        with np.errstate(invalid="ignore", over="ignore"):
            out[:, j] = np.abs(x - local) > threshold * scale
    return out


def outlier_step(outliers: np.ndarray, columns: Sequence[str], threshold: float) -> CleaningStep:
    """The cleaning summary's line: gross outliers per column, with the first one's sample.

    Examples
    --------
    >>> mask = np.zeros((5, 2), dtype=bool)
    ... mask[3, 1] = True
    >>> outlier_step(mask, ["y1", "y2"], 100.0).detail
    'y2 1 (first at sample 3)'
    """
    details = []
    for j, column in enumerate(columns):
        where = np.flatnonzero(outliers[:, j])
        if where.size:
            details.append(f"{column} {where.size} (first at sample {int(where[0])})")
    return CleaningStep(
        f"gross outliers (beyond data.outlier_mad {threshold:g} robust steps) -> missing",
        int(outliers.sum()),
        "cells",
        ", ".join(details),
    )
