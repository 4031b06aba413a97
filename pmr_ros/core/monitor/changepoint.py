"""Generalized least squares of step and ramp-then-plateau changes on overlapping window estimates.

Windows of length ``W`` whose ends are ``dt`` apart share ``W - dt`` of their
samples, so their estimation errors correlate as ``rho = max(0, 1 - |dt|/W)``
(the correlation of means of white noise over the two windows).  The error
covariance ``Sigma = D R D`` (``D`` the standard errors) is banded, and its
banded Cholesky factor whitens the estimates and every candidate at once.

A window estimate is the mean of the parameter's path over its window, so a
path that steps at ``t0`` gives window estimates that rise over one window
length, and a path that ramps from ``t0`` to ``t0 + d`` gives a smoother rise:
the candidate shapes are the window means of the path shapes, in closed form.
Each shape enters linearly (``level + size * shape``), so one candidate costs
a few inner products; the statistic of a shape is the drop of the GLS residual
sum of squares from the constant (no change) fit, i.e. twice its log
likelihood ratio with known variances.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import cholesky_banded

__all__ = [
    "FOLLOWS",
    "Fit",
    "Shapes",
    "candidate_shapes",
    "correlation_band",
    "fine_shapes_for",
    "fit_shapes",
    "overlap_correlation",
    "ramp_shapes",
    "shapes_for",
    "whiten",
    "window_means",
    "window_shapes",
]


def correlation_band(ends: np.ndarray, window: float, nugget: float = 0.0) -> np.ndarray:
    """``R`` in lower banded storage (row ``k``: correlation with the window ``k`` places earlier).

    ``nugget`` is the share of each window's error variance taken as its own
    (independent of its neighbours): the off-diagonal correlations shrink by
    ``1 - nugget``.
    """
    n = ends.size
    # ends increase, so the closest pair k places apart only grows with k: the band ends at the first k beyond W
    width = 1
    while width < n and np.min(ends[width:] - ends[:-width]) < window:
        width += 1
    band = np.zeros((width, n))
    for k in range(width):
        band[k, : n - k] = np.maximum(0.0, 1.0 - (ends[k:] - ends[: n - k]) / window)
    band[1:] *= 1.0 - nugget
    return band


def overlap_correlation(*, end_times: np.ndarray, window: float, nugget: float = 0.0) -> np.ndarray:
    """The correlation matrix of window estimates from overlapping windows.

    Parameters
    ----------
    end_times : ndarray of float
        When each window ends, increasing [any time unit].
    window : float
        Window length [the same unit].
    nugget : float
        Share of each window's error that is its own (0..1).

    Returns
    -------
    ndarray, shape (n, n)
        ``(1 - nugget) max(0, 1 - |t_i - t_j| / window)`` off the diagonal, 1
        on it: windows one step ``S`` apart correlate ``1 - S/W``, windows a
        window length or more apart not at all.
    """
    ends = np.asarray(end_times, dtype=float)
    correlation = (1.0 - nugget) * np.maximum(0.0, 1.0 - np.abs(ends[:, None] - ends[None, :]) / window)
    np.fill_diagonal(correlation, 1.0)
    return correlation


def _ramp_integral(t: np.ndarray, onset: np.ndarray, duration: np.ndarray) -> np.ndarray:
    """Integral up to ``t`` of ``clip((s - onset)/duration, 0, 1)`` (``duration`` 0: a unit step)."""
    x = np.maximum(t - onset, 0.0)
    d = np.maximum(duration, 1e-12)
    return np.where(x < duration, x * x / (2 * d), x - duration / 2)


def window_means(*, ends: np.ndarray, window: float, onset: np.ndarray, duration: np.ndarray) -> np.ndarray:
    """Means over each window ``(end - window, end]`` of the ramp-then-plateau path ``clip((t - onset)/duration)``.

    Parameters
    ----------
    ends : ndarray, shape (n,)
        Window end times.
    window : float
        Window length [time unit of ``ends``].
    onset, duration : ndarray, shape (m,)
        Where each path starts to rise and how long it rises (0: a step).

    Returns
    -------
    ndarray, shape (n, m)
        From 0 (window wholly before the onset) to 1 (wholly on the plateau).
    """
    e = ends[:, None]
    upper = _ramp_integral(e, onset[None, :], duration[None, :])
    lower = _ramp_integral(e - window, onset[None, :], duration[None, :])
    return (upper - lower) / window


FOLLOWS = ("mean", "midpoint")
"""How a window's estimate follows a path that changes inside the window: its mean over the window (a gain or
a time constant fitted by least squares; an integer delay is that mean rounded, :data:`.trend.FOLLOW`), or its
value at the window's middle (an estimate that takes the value of most of the window)."""


def window_shapes(
    *, ends: np.ndarray, window: float, onset: np.ndarray, duration: np.ndarray, follow: str = "mean"
) -> np.ndarray:
    """What each window estimates of each ramp-then-plateau path: :func:`window_means`, or the path at its middle.

    Parameters
    ----------
    ends, window, onset, duration
        As for :func:`window_means`.
    follow : str
        One of :data:`FOLLOWS`.

    Returns
    -------
    ndarray, shape (n, m)
    """
    if follow == "mean":
        return window_means(ends=ends, window=window, onset=onset, duration=duration)
    x = (ends[:, None] - window / 2) - onset[None, :]
    d = duration[None, :]
    return np.where(d > 0, np.clip(x / np.where(d > 0, d, 1.0), 0.0, 1.0), (x >= 0).astype(float))


@dataclass(frozen=True)
class Shapes:
    """Candidate changes: onset and rise time of each, and their window-mean shapes.

    Attributes
    ----------
    onset : ndarray, shape (m,)
        When the path starts to move [time unit of the window ends].
    duration : ndarray, shape (m,)
        How long it rises before the plateau (0: a step) [time unit].
    matrix : ndarray, shape (n, m)
        The window means of each path (0 before, 1 on the plateau).
    """

    onset: np.ndarray
    duration: np.ndarray
    matrix: np.ndarray

    def subset(self, *, rows: np.ndarray | None = None, columns: np.ndarray | None = None) -> Shapes:
        """Some windows (boolean ``rows``: the windows kept) and some candidates (boolean ``columns``)."""
        matrix = self.matrix if rows is None or rows.all() else self.matrix[rows]
        if columns is None:
            return Shapes(self.onset, self.duration, matrix)
        return Shapes(self.onset[columns], self.duration[columns], matrix[:, columns])


def candidate_shapes(
    *, ends: np.ndarray, window: float, resolution: float, durations: int = 8, follow: str = "mean"
) -> Shapes:
    """Steps and ramps on a grid: onsets every ``resolution``, rise times geometric from ``2 resolution``.

    Parameters
    ----------
    ends : ndarray, shape (n,)
        Window end times, increasing.
    window : float
        Window length [time unit].
    resolution : float
        Grid spacing of the onsets [time unit] (the step between windows).
    durations : int
        Rise times per onset; the longest outlasts the record (a ramp still
        rising at the last window).
    follow : str
        How a window estimate follows the path (:data:`FOLLOWS`).

    Returns
    -------
    Shapes
        Steps first (duration 0), then ramps.
    """
    # a change before ends[0] - window moves every window alike: no onset to see there
    onsets = np.arange(ends[0] - window + resolution, ends[-1], resolution)
    span = ends[-1] - ends[0] + window
    rise = np.geomspace(2 * resolution, span, durations) if span > 2 * resolution else np.array([span])
    onset = np.concatenate([onsets, np.repeat(onsets, rise.size)])
    duration = np.concatenate([np.zeros(onsets.size), np.tile(rise, onsets.size)])
    matrix = window_shapes(ends=ends, window=window, onset=onset, duration=duration, follow=follow)
    return Shapes(onset, duration, matrix)


def ramp_shapes(
    *, ends: np.ndarray, window: float, onsets: np.ndarray, resolution: float, follow: str = "mean"
) -> Shapes:
    """Ramps from the given onsets with fine rise times: every ``resolution`` up to 40 of them, then geometric.

    The coarse grid of :func:`candidate_shapes` finds where a ramp starts;
    this one fits its rise time closely there, so that a rise time between
    coarse grid points does not pull the onset.

    Parameters
    ----------
    ends : ndarray, shape (n,)
        Window end times, increasing.
    window, resolution : float
        As for :func:`candidate_shapes` [time unit].
    onsets : ndarray
        The onsets to refine.
    follow : str
        How a window estimate follows the path (:data:`FOLLOWS`).

    Returns
    -------
    Shapes
    """
    span = ends[-1] - ends[0] + window
    rise = resolution * np.arange(2, 41)
    rise = np.unique(np.concatenate([rise[rise < span], np.geomspace(min(40 * resolution, span), span, 12)]))
    onset, duration = np.repeat(onsets, rise.size), np.tile(rise, onsets.size)
    matrix = window_shapes(ends=ends, window=window, onset=onset, duration=duration, follow=follow)
    return Shapes(onset, duration, matrix)


@dataclass(frozen=True)
class Fit:
    """The GLS fit of ``level + size * shape`` for every candidate shape.

    Attributes
    ----------
    rss_none : float
        Weighted residual sum of squares of the constant fit [-].
    mean : float
        The constant fit's level (GLS mean) [parameter unit].
    drop : ndarray, shape (m,)
        Its drop under each shape (``2 log LR`` against no change) [-].
    level, size : ndarray, shape (m,)
        The fitted level before the change and the change [parameter unit].
    """

    rss_none: float
    mean: float
    drop: np.ndarray
    level: np.ndarray
    size: np.ndarray


def _band(ends: np.ndarray, errors: np.ndarray, window: float, nugget: float) -> np.ndarray:
    """``Sigma = D R D`` in lower banded storage."""
    band = correlation_band(ends, window, nugget)
    for k in range(band.shape[0]):
        band[k, : ends.size - k] *= errors[k:] * errors[: ends.size - k]
    return band


def whiten(band: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``L^-1 columns`` for the banded Cholesky factor ``L`` of a covariance (``L L^T``), by rows.

    Parameters
    ----------
    band : ndarray, shape (b, n)
        The covariance in lower banded storage (row ``k``: the ``k``-th subdiagonal).
    columns : ndarray, shape (n, m)
        Vectors to whiten.

    Returns
    -------
    ndarray, shape (n, m)
        Whitened: inner products of the result are ``x^T Sigma^-1 y``.
    """
    # one forward substitution across all columns at once: a row costs one (b x m) product,
    # far fewer calls than LAPACK's column-by-column band solve for thousands of columns
    chol = cholesky_banded(band, lower=True)
    width, n = chol.shape
    # each row's factor entries left of its diagonal, L[i, i-b+1 .. i-1], gathered at once rather than a
    # row at a time (before the band starts: clipped indices, never read); the products and divisions
    # below are those of the row-by-row substitution, in the same order: the same bits
    earlier = np.arange(n)[:, None] + np.arange(1 - width, 0)[None, :]
    left = chol[np.clip(-np.arange(1 - width, 0), 0, width - 1)[None, :], np.clip(earlier, 0, None)]
    out = np.empty(columns.shape)
    product = np.empty(columns.shape[1])
    for i in range(n):
        lo = max(0, i - width + 1)
        np.matmul(left[i, width - 1 - (i - lo) :], out[lo:i], out=product)  # into one buffer: no array a row
        np.subtract(columns[i], product, out=out[i])
        out[i] /= chol[0, i]
    return out


def fit_shapes(
    *, estimates: np.ndarray, errors: np.ndarray, ends: np.ndarray, window: float, shapes: Shapes, nugget: float = 0.0
) -> Fit:
    """Each candidate's GLS fit to the window estimates with the overlap covariance.

    Parameters
    ----------
    estimates, errors : ndarray, shape (n,)
        Window estimates and their standard errors [parameter unit], finite.
    ends : ndarray, shape (n,)
        Window end times [time unit].
    window : float
        Window length [time unit].
    shapes : Shapes
        From :func:`candidate_shapes` on the same ``ends``.
    nugget : float
        Share of each window's error that is its own (:func:`correlation_band`).

    Returns
    -------
    Fit
    """
    columns = np.column_stack([estimates, np.ones(ends.size), shapes.matrix])
    white = whiten(_band(ends, errors, window, nugget), columns)
    wy, w1, wg = white[:, 0], white[:, 1], white[:, 2:]
    c11, c1y = w1 @ w1, w1 @ wy
    g1 = wg.T @ w1
    gg = np.einsum("ij,ij->j", wg, wg) - g1**2 / c11
    gy = wg.T @ wy - g1 * c1y / c11
    usable = gg > 1e-9 * np.max(gg, initial=1e-300)
    size = np.where(usable, gy / np.where(usable, gg, 1.0), 0.0)
    return Fit(
        rss_none=float(wy @ wy - c1y**2 / c11),
        mean=float(c1y / c11),
        drop=np.where(usable, size * gy, 0.0),
        level=(c1y - size * g1) / c11,
        size=size,
    )


@lru_cache(maxsize=8)
def shapes_for(ends: tuple[float, ...], window: float, resolution: float, follow: str = "mean") -> Shapes:
    """:func:`candidate_shapes`, cached per window times (every element and parameter shares them)."""
    return candidate_shapes(ends=np.asarray(ends), window=window, resolution=resolution, follow=follow)


def fine_shapes_for(ends: tuple[float, ...], window: float, resolution: float, follow: str, near: np.ndarray) -> Shapes:
    """:func:`ramp_shapes` from the onsets of :func:`shapes_for` that are in ``near`` (those being refined).

    Only those: every onset's (364 in a year, 18,000 shapes) took 0.3 s for the few dozen refined; a shape
    is elementwise in its onset, so a subset's are the same numbers.
    """
    coarse = shapes_for(ends, window, resolution, follow)
    onsets = coarse.onset[coarse.duration == 0]
    onsets = onsets[np.isin(onsets, near)]
    return ramp_shapes(ends=np.asarray(ends), window=window, onsets=onsets, resolution=resolution, follow=follow)
