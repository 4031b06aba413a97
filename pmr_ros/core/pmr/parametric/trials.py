"""Fits of one row at other whole-sample delays: the delay profile, one column and pairs of columns at a time.

A row's delays are chosen by the column search (:mod:`.search`) and
polished one column at a time; that cannot see a *joint* shift -- one
element's delay moved one way, a neighbour's the other, their gains and time
constants bending to match -- which in closed loop, where the controller
moves its inputs together, can fit almost as well as the truth.  So the
pairs of columns whose delay estimates are strongly correlated
(:attr:`~.separation.Separation.delay_coupling` at or above
``parametric.joint_delay_correlation``) are searched together over a small
grid around the chosen delays, every other parameter refitted.

Every fit tried is kept (:class:`Trials`): the delay profile of a column is
the best chi-square over *all* delay vectors tried with that column's delay
-- the profile likelihood over the joint alternatives, not one coordinate at
a time -- and the alternatives near the best carry their own gains and time
constants into the intervals (:func:`alternatives`).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from .lsq import RowParameters, RowProblem
from .search import ColumnGrid, conditional_target, move_delay
from .stacked import fit_stacked

__all__ = [
    "ALTERNATIVE_WEIGHT_MIN",
    "JOINT_HALF_WIDTH",
    "PROFILE_HALF_WIDTH",
    "Alternative",
    "Trials",
    "coupled_pairs",
    "joint_profiles",
]

PROFILE_HALF_WIDTH = 2
"""Delay candidates either side of the chosen one that enter its confidence [samples]."""

JOINT_HALF_WIDTH = 2
"""Half width of the joint grid over a coupled pair's delays [samples each]."""

JOINT_CANDIDATES = 8
"""Points of a pair's joint grid fitted jointly (of up to 24), those whose starts fit best."""

NEIGHBOUR_ITERATIONS = 3
"""Joint-fit steps at a neighbouring delay, from the column(s) refitted alone: its chi-square to far below one."""

ALTERNATIVE_WEIGHT_MIN = 1e-3
"""A delay vector whose likelihood weight relative to the best is below this does not enter the intervals."""


@dataclass(frozen=True)
class Alternative:
    """One delay vector of a row, its fit and that fit's likelihood weight relative to the best.

    Attributes
    ----------
    params : RowParameters
    chi_square : float
    weight : float
        ``exp(-(chi_square - best) / (2 scale))``, 1 for the best.
    """

    params: RowParameters
    chi_square: float
    weight: float


def _key(delays: np.ndarray) -> tuple[int, ...]:
    return tuple(int(v) for v in delays)


def _moved_key(fit: tuple[RowParameters, float], moves: Sequence[tuple[int, int]]) -> tuple[int, ...]:
    delays = fit[0].delays.copy()
    for k, delay in moves:
        delays[k] = delay
    return _key(delays)


class Trials:
    """Fits of one row with one weighting, cached by delay vector.

    Parameters
    ----------
    problem : RowProblem
    grids : sequence of ColumnGrid
        The column search grids (:func:`~.search.column_grids`).
    """

    def __init__(self, problem: RowProblem, grids: Sequence[ColumnGrid]) -> None:
        self.problem, self.grids = problem, grids
        self.tried: dict[tuple[int, ...], tuple[RowParameters, float]] = {}
        self._ready: dict[tuple[tuple[int, ...], float], tuple[RowParameters, float]] = {}
        self._ready_for: tuple[RowParameters, float] | None = None
        self._target_of: RowParameters | None = None
        self._targets: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._theta = np.zeros(0)

    def full(self, start: RowParameters) -> tuple[RowParameters, float]:
        """The converged joint fit at ``start``'s delays."""
        fit = self.problem.fit(start)
        self.tried[_key(start.delays)] = fit
        return fit

    def start(self, fit: tuple[RowParameters, float], moves: Sequence[tuple[int, int]]) -> RowParameters:
        """``fit`` with each ``(column, delay)`` of ``moves`` applied: the start of a joint fit there.

        Each moved column's gain and time constant are refitted alone in turn (:func:`~.search.move_delay`).
        """
        start = fit[0]
        for k, delay in moves:
            if start is fit[0]:  # the fit's coefficients and each column's target serve all its neighbours
                theta, target = self._target(start, k)
            else:
                theta, target = self.problem.coefficients(start).theta, None
            system = self.problem.system
            start = move_delay(system, self.grids[k], start, theta=theta, k=k, delay=delay, target=target)
        return start

    def _target(self, params: RowParameters, k: int) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """The coefficients at ``params`` and column ``k``'s conditional target, kept for the last ``params``."""
        if self._target_of is not params:
            self._target_of, self._targets = params, {}
            self._theta = self.problem.coefficients(params).theta
        if k not in self._targets:
            self._targets[k] = conditional_target(self.problem.system, self._theta, k)
        return self._theta, self._targets[k]

    def moved(
        self, fit: tuple[RowParameters, float], moves: Sequence[tuple[int, int]], *, settled_above: float = math.inf
    ) -> tuple[RowParameters, float]:
        """The joint fit with each ``(column, delay)`` of ``moves`` applied: a few steps from :meth:`start`.

        A cost still above ``settled_above`` after the first step ends that fit (:meth:`.RowProblem.fit`).
        """
        key = _moved_key(fit, moves)
        if key not in self.tried:
            ready = self._ready.pop((key, settled_above), None) if self._ready_for is fit else None
            if ready is None:
                start = self.start(fit, moves)
                ready = self.problem.fit(start, iterations=NEIGHBOUR_ITERATIONS, settled_above=settled_above)
            self.tried[key] = ready
        return self.tried[key]

    def prefetch(
        self,
        fit: tuple[RowParameters, float],
        moves: Sequence[Sequence[tuple[int, int]]],
        *,
        settled_above: float = math.inf,
        given: Sequence[RowParameters] | None = None,
    ) -> None:
        """Fit the neighbours ``moves`` of ``fit`` not tried yet together (:func:`~.stacked.fit_stacked`).

        :meth:`moved` with the same ``fit`` (the same object) and ``settled_above`` then takes each one's
        fit from here: the same numbers it would compute alone.  Prefetched fits of another ``fit`` are
        dropped.  ``given``: each move's start (:meth:`start`), when already computed.
        """
        if self._ready_for is not fit:
            self._ready, self._ready_for = {}, fit
        keys, starts = [], []
        for j, each in enumerate(moves):
            key = _moved_key(fit, each)
            if key not in self.tried and (key, settled_above) not in self._ready and key not in keys:
                keys.append(key)
                starts.append(self.start(fit, each) if given is None else given[j])
        fitted = fit_stacked(self.problem, starts, iterations=NEIGHBOUR_ITERATIONS, settled_above=settled_above)
        for key, found in zip(keys, fitted, strict=True):
            self._ready[(key, settled_above)] = found

    def best(self) -> tuple[RowParameters, float]:
        """The best fit tried."""
        return min(self.tried.values(), key=lambda fit: fit[1])


def coupled_pairs(coupling: np.ndarray, threshold: float) -> list[tuple[int, int]]:
    """Pairs ``(k, m)``, ``k < m``, whose delay estimates correlate at or above ``threshold``, strongest first.

    Parameters
    ----------
    coupling : ndarray, shape (n, n)
        ``|corr(D_k, D_m)|`` (:attr:`~.separation.Separation.delay_coupling`).
    threshold : float
        ``parametric.joint_delay_correlation``; above 1: no pair.
    """
    k, m = np.nonzero(np.triu(coupling, 1) >= threshold)
    order = np.argsort(-coupling[k, m], kind="stable")
    return [(int(k[j]), int(m[j])) for j in order]


def _grid(
    trials: Trials, fit: tuple[RowParameters, float], k: int, m: int
) -> list[tuple[float, list[tuple[int, int]], RowParameters]]:
    """The points of pair ``(k, m)``'s joint grid around ``fit`` (within bounds), cheapest start first.

    Each point: its start's cost, its moves and its start (:meth:`Trials.start`).
    """
    columns = trials.problem.columns
    (low_k, high_k), (low_m, high_m) = columns[k].delay_bounds, columns[m].delay_bounds
    dk, dm = int(fit[0].delays[k]), int(fit[0].delays[m])
    grid = []
    for a in range(-JOINT_HALF_WIDTH, JOINT_HALF_WIDTH + 1):
        for b in range(-JOINT_HALF_WIDTH, JOINT_HALF_WIDTH + 1):
            if (a, b) != (0, 0) and low_k <= dk + a <= high_k and low_m <= dm + b <= high_m:
                moves = [(k, dk + a), (m, dm + b)]
                start = trials.start(fit, moves)
                grid.append((trials.problem.system.cost(trials.problem.coefficients(start).theta), moves, start))
    return sorted(grid, key=lambda point: point[0])


def joint_search(trials: Trials, fit: tuple[RowParameters, float], pairs: Sequence[tuple[int, int]]) -> bool:
    """Try every pair's joint grid around ``fit``; whether a delay vector fits better than ``fit``.

    Of each pair's grid, the :data:`JOINT_CANDIDATES` points whose starts (the
    two columns refitted alone, :meth:`Trials.start`) fit best are fitted
    jointly: a start is a poor guide to the fitted cost (measured: the true
    delays' start 870 chi-square units above the fit, their joint fit 3
    below), but its rank is a fair one.
    """
    better = False
    for k, m in pairs:
        chosen = _grid(trials, fit, k, m)[:JOINT_CANDIDATES]
        trials.prefetch(fit, [moves for _, moves, _ in chosen], given=[start for _, _, start in chosen])
        for _, moves, _ in chosen:
            better |= trials.moved(fit, moves)[1] < fit[1]
    return better


def joint_profiles(
    trials: Trials, chosen: RowParameters, *, profiled: Collection[int] | None = None
) -> tuple[dict[int, float], ...]:
    """Per column: ``delay -> best chi-square`` over every delay vector tried with it, within the profile's width.

    Empty for a column not in ``profiled`` (None: every column), whose neighbours were not tried.
    """
    profiles = []
    for k in range(trials.problem.n):
        centre = int(chosen.delays[k])
        profile: dict[int, float] = {}
        if profiled is not None and k not in profiled:
            profiles.append(profile)
            continue
        for key, (_, cost) in trials.tried.items():
            if abs(key[k] - centre) <= PROFILE_HALF_WIDTH:
                profile[key[k]] = min(profile.get(key[k], math.inf), cost)
        profiles.append(dict(sorted(profile.items())))
    return tuple(profiles)


def alternatives(trials: Trials, *, scale: float) -> tuple[Alternative, ...]:
    """The fits tried whose relative likelihood weight is :data:`ALTERNATIVE_WEIGHT_MIN` or more, best first.

    Parameters
    ----------
    scale : float
        The reduced chi-square (>= 1) the likelihood is tempered by.
    """
    best = trials.best()[1]
    out = []
    for params, cost in sorted(trials.tried.values(), key=lambda fit: fit[1]):
        weight = math.exp(-(cost - best) / (2.0 * scale))
        if weight >= ALTERNATIVE_WEIGHT_MIN:
            out.append(Alternative(params, cost, weight))
    return tuple(out)
