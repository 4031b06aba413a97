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

A cell must also lie outside the tag's own range widened three times that range
(beyond ``q1 - 3 w`` or ``q99 + 3 w``, with ``w = q99 - q1``; the quantiles of
the cells the step rule keeps): an MV that only dithers for hours has a tiny
step size, and the controller's or the operator's real moves of it would
otherwise count as outliers and cut the record into pieces (measured on the
routine debutanizer: 19,633 cells of the distillate and vent valves; with one width, a real
transient of the distillate valve to 1.43 against a 1-99 % range of
-0.43..0.48 was still cut).  Gross
outliers are rare: where the step rule would flag more than
:data:`RARE` of a tag's cells, its step size is no scale for them, and the
range of all the tag's cells decides alone.  A sentinel or a spike lies
orders of magnitude beyond any tag's range.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .clean import CleaningStep

__all__ = ["WINDOW", "gross_outliers", "outlier_step", "step_scale"]

WINDOW = 21
"""Samples of the running median a cell is compared with (odd: centred)."""

RARE = 0.05
"""Largest share of a tag's cells the step rule may flag and still be the tag's scale of gross outliers."""
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


def _range(x: np.ndarray) -> tuple[float, float]:
    """The tag's 1 to 99 % range widened by three times its width on both sides: no real value lies outside."""
    valid = x[np.isfinite(x)]
    if valid.size == 0:
        return -np.inf, np.inf
    q1, q99 = np.percentile(valid, [1.0, 99.0])
    width = q99 - q1
    return float(q1 - 3.0 * width), float(q99 + 3.0 * width)


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
            far = np.abs(x - local) > threshold * scale
            rare = far.sum() <= RARE * np.isfinite(x).sum()
            low, high = _range(x[~far] if rare else x)
            out[:, j] = ((x < low) | (x > high)) & (far if rare else True)
    return out


def outlier_step(outliers: np.ndarray, columns: Sequence[str], threshold: float) -> CleaningStep:
    """The cleaning summary's line: gross outliers per column, with the first one's sample.

    Examples
    --------
    >>> mask = np.zeros((5, 2), dtype=bool)
    >>> mask[3, 1] = True
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
