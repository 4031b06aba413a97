"""When a parameter began to move, and whether it stepped (a valve change) or drifted (fouling).

The input is one parameter of one element (``dK`` %, ``dtau`` % or ``dD``)
over the rolling windows: each window's estimate, its standard error and the
time the window ends.  Three explanations are fitted by generalized least
squares with the overlap covariance of :mod:`.changepoint`: no change (a
constant), a step at ``t0``, and a ramp from ``t0`` that may level off (a
plateau from ``t0 + d``).  A change is declared when the largest likelihood
ratio over all candidate onsets and rise times beats its simulated no-change
quantile (the false alarm rate is ``significance``); step or drift is then decided by BIC.
The onset interval: the ``t0`` whose profile likelihood ratio to the best stays below chi-square(1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from scipy.stats import chi2, norm

from .changepoint import FOLLOWS, Fit, Shapes, fine_shapes_for, fit_shapes, shapes_for
from .nochange import null_quantile

__all__ = ["KINDS", "Onset", "OnsetSettings", "detect_onset", "first_lasting_mismatch", "standard_errors"]

KINDS = ("none", "step", "drift", "insufficient")
"""What :func:`detect_onset` can find: no change, a step, a drift (ramp, maybe levelling off), too few windows."""


@dataclass(frozen=True)
class OnsetSettings:
    """How :func:`detect_onset` decides.

    Attributes
    ----------
    significance : float
        False alarm probability of declaring a change where there is none (0..1).
    confidence : float
        Level of the onset interval (0..1).
    resolution : float or None
        Spacing of the candidate onsets [unit of the end times]; None: the
        median spacing of the end times (the step).
    min_windows : int
        Fewer usable windows give kind ``insufficient``.
    scale_errors : bool
        Scale the standard errors up by the scatter about the best fit when
        the windows scatter more than their intervals say (never down): a
        guard against intervals that are too narrow, at some loss of power.
    follow : str
        How a window's estimate follows a change inside the window
        (:data:`~.changepoint.FOLLOWS`): ``mean`` (least squares average
        the window: dK, dtau, and dD rounded to its integer,
        :data:`~.trend.FOLLOW`) or ``midpoint`` (an estimate that takes the
        value of most of the window jumps half a window after the change).
    nugget : float
        Share of each window's error variance that is its own, independent of
        the overlapping windows (0..1).  The overlap correlation alone makes
        neighbouring windows nearly collinear, and a lone outlier (an integer
        delay one sample off in one window) then weighs like a change; a
        little independent error keeps the fit robust to it.
    """

    significance: float = 0.01
    confidence: float = 0.95
    resolution: float | None = None
    min_windows: int = 8
    scale_errors: bool = False
    follow: str = "mean"
    nugget: float = 0.02


@dataclass(frozen=True)
class Onset:
    """The change found in one parameter's window estimates.

    Times are in the unit of the window end times given (seconds, days ...).

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    time : float or None
        When the parameter began to move (step or start of the ramp).
    interval : (float, float) or None
        Onset times not rejected by the profile likelihood ratio at the
        confidence level (the hull of that set).
    end : float or None
        Drift only: when the ramp levelled off; None while it may still rise
        at the last window (a ramp rising to the end fits within the
        confidence level), and for steps.
    size : float or None
        How far the parameter has moved by the last window's end: the step,
        or the ramp's rise up to its plateau or to then [parameter unit].
    rate : float or None
        Drift only: its slope while it rises [parameter unit per time unit].
    level : float or None
        The level before the change (of the whole record when none)
        [parameter unit].
    statistic : float
        Largest ``2 log LR`` of a change against none [-].
    threshold : float
        Its simulated no-change quantile at ``1 - significance`` [-].
    p_value : float or None
        Share of simulated no-change records with a statistic at least as large.
    windows : int
        Windows used (finite estimate and standard error).
    error_scale : float or None
        Scatter of the windows about the best fit over what their standard
        errors say (about 1 when the intervals are right) [-].
    """

    kind: str
    time: float | None
    interval: tuple[float, float] | None
    end: float | None
    size: float | None
    level: float | None
    statistic: float
    threshold: float
    p_value: float | None
    windows: int
    error_scale: float | None = None
    rate: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (the interval as a list)."""
        out = asdict(self)
        out["interval"] = None if self.interval is None else list(self.interval)
        return out


def standard_errors(*, low: np.ndarray, high: np.ndarray, level: float = 0.95) -> np.ndarray:
    """Standard errors from two-sided normal intervals ``(low, high)`` at ``level``.

    Parameters
    ----------
    low, high : array_like
        Interval bounds [parameter unit]; NaN where a window has none.
    level : float
        Their confidence level (0..1).

    Returns
    -------
    ndarray
        ``(high - low) / (2 z)`` with ``z`` the normal ``(1 + level)/2`` quantile.
    """
    z = norm.ppf(0.5 + level / 2)
    return (np.asarray(high, dtype=float) - np.asarray(low, dtype=float)) / (2 * z)


@dataclass(frozen=True)
class _Record:
    """One parameter's windows: the usable ones (``keep``) and the grid they sit on (every window)."""

    estimates: np.ndarray
    errors: np.ndarray
    ends: np.ndarray
    keep: np.ndarray
    grid: tuple[float, ...]
    window: float
    resolution: float
    follow: str
    nugget: float


def _checked(estimates: Any, errors: Any, end_times: Any, window: float, settings: OnsetSettings) -> _Record:
    """The usable windows (finite estimate, positive finite error) and the window grid, checked."""
    y, s, t = (np.asarray(a, dtype=float) for a in (estimates, errors, end_times))
    if not y.shape == s.shape == t.shape or y.ndim != 1:
        raise ValueError(f"estimates, errors, end_times: shapes {y.shape}, {s.shape}, {t.shape} differ")
    if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise ValueError("end_times: the window end times must be finite and increasing")
    if not window > 0:
        raise ValueError(f"window: {window!r} must be positive")
    resolution = settings.resolution
    if resolution is not None and not resolution > 0:
        raise ValueError(f"resolution: {resolution!r} must be positive")
    if settings.follow not in FOLLOWS:
        raise ValueError(f"follow: {settings.follow!r} is not one of {FOLLOWS}")
    keep = np.isfinite(y) & np.isfinite(s) & (s > 0)
    step = float(resolution) if resolution is not None else float(np.median(np.diff(t))) if t.size > 1 else 1.0
    if not 0 <= settings.nugget < 1:
        raise ValueError(f"nugget: {settings.nugget!r} must be in [0, 1)")
    grid = tuple(t.tolist())
    return _Record(y[keep], s[keep], t[keep], keep, grid, float(window), step, settings.follow, settings.nugget)


def _family_best(fit: Fit, members: np.ndarray) -> int:
    """Index of the candidate of a family (a boolean mask) with the largest drop."""
    return int(np.flatnonzero(members)[np.argmax(fit.drop[members])])


def _profile(onsets: np.ndarray, drops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The onset grid and, per onset, the largest drop over the other shape parameters."""
    grid = np.unique(onsets)
    profile = np.full(grid.size, -np.inf)
    np.maximum.at(profile, np.searchsorted(grid, onsets), drops)
    return grid, profile


def _profile_interval(onsets: np.ndarray, drops: np.ndarray, confidence: float) -> tuple[float, float]:
    """Hull of the onsets whose profile ``2 log LR`` to the best is below the chi2(1) quantile."""
    grid, profile = _profile(onsets, drops)
    kept = grid[profile >= profile.max() - chi2.ppf(confidence, 1)]
    # the onset lies anywhere between grid points: half a grid step either side of the kept ones
    half = float(np.min(np.diff(grid))) / 2 if grid.size > 1 else 0.0
    return float(kept.min()) - half, float(kept.max()) + half


def _refined(fit: Fit, shapes: Shapes, record: _Record) -> tuple[Fit, Shapes]:
    """The coarse candidates plus ramps with fine rise times from every onset near the coarse best ramp."""
    ramps = shapes.duration > 0
    grid, profile = _profile(shapes.onset[ramps], fit.drop[ramps])
    best = grid[np.argmax(profile)]
    near = grid[(profile >= profile.max() - _REFINE_MARGIN) | (np.abs(grid - best) <= record.window)]
    fine = fine_shapes_for(record.grid, record.window, record.resolution, record.follow, near).subset(rows=record.keep)
    more = fit_shapes(
        estimates=record.estimates,
        errors=record.errors,
        ends=record.ends,
        window=record.window,
        shapes=fine,
        nugget=record.nugget,
    )
    merged = Fit(
        rss_none=fit.rss_none,
        mean=fit.mean,
        drop=np.concatenate([fit.drop, more.drop]),
        level=np.concatenate([fit.level, more.level]),
        size=np.concatenate([fit.size, more.size]),
    )
    onset, duration = np.concatenate([shapes.onset, fine.onset]), np.concatenate([shapes.duration, fine.duration])
    return merged, Shapes(onset, duration, np.empty((record.ends.size, 0)))


NULL_DRAWS = 2000
"""Simulated no-change records behind the threshold (once per set of window times, cached)."""

_REFINE_MARGIN = 25.0
"""Onsets whose coarse ramp profile is within this ``2 log LR`` of the best get fine rise times (and those
within a window length of the best)."""


def _levelled_off(fit: Fit, shapes: Shapes, best: int, last: float, confidence: float) -> bool:
    """Whether the best ramp's plateau is seen: a ramp still rising at ``last`` fits clearly worse."""
    rising = (shapes.duration > 0) & (shapes.onset + shapes.duration >= last)
    if shapes.onset[best] + shapes.duration[best] >= last:
        return False
    return not rising.any() or fit.drop[best] - np.max(fit.drop[rising]) >= chi2.ppf(confidence, 1)


def _change(fit: Fit, shapes: Shapes, ends: np.ndarray, confidence: float) -> dict[str, Any]:
    """Step or drift by BIC, with its onset, interval, end, size and level."""
    steps = shapes.duration == 0
    best_step, best_ramp = _family_best(fit, steps), _family_best(fit, ~steps)
    # -2 log L + k ln n: a step has level, size, onset; a ramp also its rise time
    bic_step = -fit.drop[best_step] + 3 * np.log(ends.size)
    bic_ramp = -fit.drop[best_ramp] + 4 * np.log(ends.size)
    drift = bool(bic_ramp < bic_step)
    best, members = (best_ramp, ~steps) if drift else (best_step, steps)
    onset, duration, size = float(shapes.onset[best]), float(shapes.duration[best]), float(fit.size[best])
    reached = min(1.0, float(ends[-1] - onset) / duration) if drift else 1.0
    return {
        "kind": "drift" if drift else "step",
        "time": onset,
        "interval": _profile_interval(shapes.onset[members], fit.drop[members], confidence),
        "end": onset + duration if drift and _levelled_off(fit, shapes, best, ends[-1], confidence) else None,
        "size": size * reached,
        "rate": size / duration if drift else None,
        "level": float(fit.level[best]),
    }


def _error_scale(fit: Fit, n: int) -> float:
    """Scatter about the best candidate over what the standard errors say (a ramp has four parameters)."""
    return float(np.sqrt(max(fit.rss_none - float(np.max(fit.drop)), 0.0) / max(n - 4, 1)))


def _fit_and_null(record: Any, settings: OnsetSettings) -> tuple[Any, Any, float, np.ndarray]:
    """The candidates on the whole window grid (shared), their fit and threshold on the usable windows."""
    shapes = shapes_for(record.grid, record.window, record.resolution, record.follow).subset(rows=record.keep)
    fit = fit_shapes(
        estimates=record.estimates,
        errors=record.errors,
        ends=record.ends,
        window=record.window,
        shapes=shapes,
        nugget=record.nugget,
    )
    threshold, maxima = null_quantile(
        grid=np.asarray(record.grid),
        window=record.window,
        resolution=record.resolution,
        significance=settings.significance,
        keep=record.keep,
        draws=NULL_DRAWS,
        follow=record.follow,
        nugget=record.nugget,
    )
    return shapes, fit, threshold, maxima


def detect_onset(
    *,
    estimates: Sequence[float] | np.ndarray,
    errors: Sequence[float] | np.ndarray,
    end_times: Sequence[float] | np.ndarray,
    window: float,
    settings: OnsetSettings | None = None,
) -> Onset:
    """When one parameter began to move over rolling windows, and as a step or a drift.

    Parameters
    ----------
    estimates : array_like, shape (n,)
        The parameter per window (``dK`` [%], ``dtau`` [%] or ``dD``
        [samples]); NaN for a window without one (inconclusive): it is left out.
    errors : array_like, shape (n,)
        Their standard errors [same unit] (:func:`standard_errors` from 95 %
        intervals); a NaN or non-positive one leaves the window out.
    end_times : array_like, shape (n,)
        When each window ends, increasing [any time unit: s, days ...].
    window : float
        Window length [the unit of ``end_times``]; sets the overlap correlation.
    settings : OnsetSettings, optional
        Significance, interval level, onset grid, ... (default :class:`OnsetSettings`).

    Returns
    -------
    Onset

    Raises
    ------
    ValueError
        Arrays of different shapes, end times not increasing, a window or
        resolution of zero or less.

    Notes
    -----
    The no-change threshold is simulated with equal errors once per window grid and set of
    usable windows, shared by every element and parameter with the same ones: exact when the
    errors are equal.  Each new set of left-out windows costs one simulation (about 1 s a year).
    """
    settings = settings or OnsetSettings()
    record = _checked(estimates, errors, end_times, window, settings)
    n = record.ends.size
    if n < max(settings.min_windows, 3):
        return Onset("insufficient", None, None, None, None, None, 0.0, np.inf, None, n)
    shapes, fit, threshold, maxima = _fit_and_null(record, settings)
    scale = _error_scale(fit, n)
    # intervals narrower than the scatter: every likelihood ratio shrinks by the squared scale (never grows)
    factor = scale**2 if settings.scale_errors and scale > 1.0 else 1.0
    statistic = float(np.max(fit.drop)) / factor
    p_value = float((np.sum(maxima >= statistic) + 1) / (maxima.size + 1))
    common: dict[str, Any] = {"statistic": statistic, "threshold": threshold, "p_value": p_value, "windows": n}
    common |= {"error_scale": scale}
    if statistic < threshold:
        return Onset(kind="none", time=None, interval=None, end=None, size=None, level=fit.mean, **common)
    fit, shapes = _refined(fit, shapes, record)
    fit = replace(fit, drop=fit.drop / factor)
    return Onset(**_change(fit, shapes, record.ends, settings.confidence), **common)


def first_lasting_mismatch(
    verdicts: Sequence[str | None], *, ignore: Sequence[str | None] = ("inconclusive",)
) -> int | None:
    """The first window from which the verdict stays ``mismatch`` to the last window.

    Parameters
    ----------
    verdicts : sequence of str or None
        One verdict per window, in time order.
    ignore : sequence of str or None
        Verdicts that neither break nor start the run (a window the data could
        not decide).

    Returns
    -------
    int or None
        Index of the run's first ``mismatch`` window; None when the last
        decided verdict is not ``mismatch``.

    Examples
    --------
    >>> first_lasting_mismatch(["ok", "mismatch", "ok", "mismatch", "inconclusive", "mismatch"])
    3
    """
    first = None
    for index in range(len(verdicts) - 1, -1, -1):
        verdict = verdicts[index]
        if verdict in ignore:
            continue
        if verdict != "mismatch":
            break
        first = index
    return first
