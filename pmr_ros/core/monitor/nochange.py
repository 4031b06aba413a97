"""The no-change threshold of the onset test: the law of the largest likelihood ratio, simulated.

Under no change the whitened window estimates are standard normal whatever
their level, and each candidate's ``2 log LR`` is the square of one unit
projection of them; the largest over thousands of correlated candidates has
no closed law, so it is drawn once per window grid and set of usable windows
and cached.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .changepoint import correlation_band, shapes_for, whiten

__all__ = ["NULL_SEED", "null_quantile"]


@lru_cache(maxsize=64)
def _null_maxima(
    *, grid: tuple[float, ...], keep: bytes, window: float, resolution: float, draws: int, follow: str, nugget: float
) -> np.ndarray:
    """Largest drop over all shapes in ``draws`` simulated no-change records on the kept windows, sorted."""
    rows = np.frombuffer(keep, dtype=bool) if keep else np.ones(len(grid), dtype=bool)
    times = np.asarray(grid)[rows]
    white = whiten(
        correlation_band(times, window, nugget),
        np.column_stack([np.ones(times.size), shapes_for(grid, window, resolution, follow).subset(rows=rows).matrix]),
    )
    ones, shapes = white[:, 0], white[:, 1:]
    orth = shapes - np.outer(ones, (shapes.T @ ones) / (ones @ ones))
    norm = np.sqrt(np.einsum("ij,ij->j", orth, orth))
    unit = orth[:, norm > 1e-9 * norm.max()] / norm[norm > 1e-9 * norm.max()]
    # whitened no-change noise is standard normal whatever the level: the drop of a shape is (u^T z)^2
    rng = np.random.default_rng(NULL_SEED)
    maxima = np.empty(draws)
    for start in range(0, draws, 200):
        z = rng.standard_normal((times.size, min(200, draws - start)))
        maxima[start : start + z.shape[1]] = np.max((unit.T @ z) ** 2, axis=0)
    return np.sort(maxima)


NULL_SEED = 0
"""Seed of the no-change simulation: the threshold is the same on every run."""


def null_quantile(
    *,
    grid: np.ndarray,
    window: float,
    resolution: float,
    significance: float,
    keep: np.ndarray | None = None,
    draws: int = 2000,
    follow: str = "mean",
    nugget: float = 0.0,
) -> tuple[float, np.ndarray]:
    """The threshold of the largest drop over all candidates under no change, by simulation.

    The largest of many correlated likelihood ratios has no chi-square law,
    so its law is drawn: records of pure overlap-correlated noise on the kept
    windows, fitted with every candidate of :func:`shapes_for` on the grid.
    The standard errors are taken equal across windows here (exact when they
    are; the statistic does not depend on their common scale), so one
    simulation serves every element and parameter with the same usable
    windows (cached; a new set of left-out windows costs a new simulation,
    since leaving windows out changes the law).

    Parameters
    ----------
    grid : ndarray
        End times of every window [time unit].
    window, resolution : float
        As for :func:`candidate_shapes` [time unit].
    significance : float
        False alarm probability of the no-change test (0..1).
    keep : ndarray of bool, optional
        The windows with a usable estimate (default all).
    draws : int
        Simulated records.
    follow : str
        How a window estimate follows the path (:data:`~.changepoint.FOLLOWS`).
    nugget : float
        Share of each window's error that is its own (:func:`~.changepoint.correlation_band`).

    Returns
    -------
    threshold : float
        The ``1 - significance`` quantile of the largest drop [-].
    maxima : ndarray
        The simulated largest drops, sorted (for p-values).
    """
    times = tuple(np.asarray(grid, dtype=float).tolist())
    mask = b"" if keep is None or np.all(keep) else np.asarray(keep, dtype=bool).tobytes()
    maxima = _null_maxima(
        grid=times,
        keep=mask,
        window=float(window),
        resolution=float(resolution),
        draws=draws,
        follow=follow,
        nugget=float(nugget),
    )
    return float(np.quantile(maxima, 1.0 - significance)), maxima
