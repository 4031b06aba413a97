"""The delay search of one output row: each column's neighbour profile and the coupled pairs' joint grids.

:func:`search_delays` is step 3 of :func:`~.fit.fit_row`: from the joint fit at
the searched delays, each column's delay neighbours are fitted with the others
at their best (a better one is taken), then the pairs of columns whose delay
estimates are coupled are searched on joint grids, until neither improves.  An
empty cell's interaction that is absent (:func:`absent`) is not profiled.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .lsq import RowParameters, RowProblem
from .separation import delay_coupling
from .trials import PROFILE_HALF_WIDTH, Trials, coupled_pairs, joint_search

__all__ = [
    "JOINT_ROUNDS",
    "PROFILE_PASSES",
    "PROFILE_PRUNE",
    "SETTLED",
    "DelaySearch",
    "absent",
    "profile",
    "search_delays",
    "uncertainty",
]

PROFILE_PRUNE = 60.0
"""A neighbour this many (reduced) chi-square units worse ends its side of the profile."""

SETTLED = 200.0
"""A neighbour this many (reduced) chi-square units worse after its first joint-fit step is not fitted further.

Its likelihood weight (below ``exp(-100)``) changes no delay confidence and no interval, and it ends its side
of the profile (:data:`PROFILE_PRUNE`) either way.  Measured on 2,069 neighbour fits of 16 windows of the
year benchmark (``benchmarks/bench_monitor.py``): the two further steps never took such a neighbour below
0.94 of its excess after one (none below 207 units).  About a third of the neighbours end so."""

PROFILE_PASSES = 4
"""Most passes of the delay profile over a row's columns: one that moved a modelled element's delay is followed
by another.

A column's best delay depends on the others' (one pass tries each against the delays of the columns
before it as they were then).  Measured on run 575 of the benchmark (the 4x8, 8,192 samples, white noise):
after one pass three of the integrating row's four delays were a sample off, each with confidence 1 and the
row 416 chi-square units above its true delays; the second pass found the true delays.  A pass that moved
only empty cells' interaction delays is not repeated: with no interaction there (gamma near 0) their
likelihood is flat, and in the year benchmark's windows they moved pass after pass by 0-15 reduced chi-square
units (passes for those alone cost 47 % more CPU a window and changed no verdict)."""

JOINT_ROUNDS = 3
"""Most rounds of neighbour profile and joint pair search (a better delay vector found starts another)."""


def absent(problem: RowProblem, params: RowParameters, *, z: Sequence[float], inflation: float) -> np.ndarray:
    """Per column: an interaction whose gain lies within ``z`` (:func:`.absence_z`) of its deviations of zero.

    Its delay is not profiled: with no interaction there the delay's likelihood is flat, and the profile walked
    every neighbour.  In the year benchmark's windows (a 4x8 with 19 empty cells in its fitted rows) those
    neighbours took 22 % of a window's CPU time; skipping them moved the elements' estimates by at most 0.5 pp
    (a third of their intervals' half-widths) and changed no verdict in 20 windows.
    """
    interaction = np.array([column.interaction for column in problem.columns], dtype=bool)
    if not interaction.any():
        return interaction
    sd_lin, _ = uncertainty(problem, params, inflation)
    out = interaction.copy()
    # only the interactions: a modelled column's z may be 0 beside an infinite deviation (a singular information)
    out[interaction] = np.abs(params.lin[interaction]) < np.asarray(z, dtype=float)[interaction] * sd_lin[interaction]
    return out


@dataclass
class DelaySearch:
    """How :func:`search_delays` searches (and skips absent interactions, :func:`absent`); what it profiled.

    Attributes
    ----------
    joint_correlation : float
        Pairs of columns whose delay estimates correlate at least this much are searched jointly
        (``parametric.joint_delay_correlation``).
    z : sequence of float
        Per column :func:`~.parameterization.absence_z` (of ``parametric.confidence_level``): an interaction
        within it of zero is absent.
    bin_correlation : float
        The Welch window's bin correlation, by which the deviations are inflated (as the fit's).
    profiled : set of int
        Filled by :func:`profile`: the columns whose delay neighbours were tried.
    """

    joint_correlation: float
    z: Sequence[float]
    bin_correlation: float
    profiled: set[int] = field(default_factory=set)


def profile(
    trials: Trials, fit: tuple[RowParameters, float], *, scale: float, search: DelaySearch
) -> tuple[RowParameters, float]:
    """Each column's delay neighbours, the others at their best; a better neighbour is taken (and fitted in full).

    Passes over the columns repeat while one moves a modelled element's delay (at most :data:`PROFILE_PASSES`).
    An interaction that is absent at the pass's start (:func:`absent`) is not profiled in that pass;
    ``search.profiled`` collects the columns that were.

    Outwards from the chosen delay, a side stops once a neighbour's chi-square
    exceeds the chosen one's by :data:`PROFILE_PRUNE` times ``scale`` (the
    reduced chi-square): its likelihood weight, below ``exp(-PROFILE_PRUNE/2)``,
    changes no confidence, and the one beyond it would weigh less still.  A
    neighbour :data:`SETTLED` times ``scale`` worse after one step is fitted no further.
    """
    for _ in range(PROFILE_PASSES):
        moved = False
        skipped = absent(trials.problem, fit[0], z=search.z, inflation=search.bin_correlation * scale)
        for k, column in enumerate(trials.problem.columns):
            if skipped[k]:
                continue
            search.profiled.add(k)
            low, high = column.delay_bounds
            chosen = int(fit[0].delays[k])
            costs = {chosen: fit[1]}
            for direction in (-1, 1):
                for step in range(1, PROFILE_HALF_WIDTH + 1):
                    d = chosen + direction * step
                    if not low <= d <= high:
                        break
                    costs[d] = trials.moved(fit, [(k, d)], settled_above=fit[1] + SETTLED * scale)[1]
                    if costs[d] - fit[1] > PROFILE_PRUNE * scale:
                        break
            best = min(costs, key=costs.__getitem__)
            if best != chosen:
                fit = trials.full(trials.moved(fit, [(k, best)])[0])
                moved |= not column.interaction
        if not moved:
            break
    return fit


def search_delays(
    trials: Trials, fit: tuple[RowParameters, float], *, dof: int, search: DelaySearch
) -> tuple[RowParameters, float]:
    """The best delays: each column's neighbours, then the coupled pairs' joint grids, until neither improves."""
    for _ in range(JOINT_ROUNDS):
        scale = max(1.0, fit[1] / dof)
        fit = profile(trials, fit, scale=scale, search=search)
        pairs = coupled_pairs(delay_coupling(trials.problem, fit[0]), search.joint_correlation)
        if not joint_search(trials, fit, pairs[: trials.problem.n]):
            break
        fit = trials.full(trials.best()[0])
    return fit


def uncertainty(problem: RowProblem, params: RowParameters, inflation: float) -> tuple[np.ndarray, np.ndarray]:
    """Standard deviations of ``lin`` and of the fitted ``s`` (an interaction's time constant is held)."""
    n = problem.n
    info = problem.information(problem.coefficients(params))
    packed = np.full(info.shape[0], np.inf)
    try:
        packed = np.sqrt(np.maximum(np.diag(np.linalg.inv(info)) * inflation, 0.0))
    except np.linalg.LinAlgError:
        pass
    sd_s = np.full(n, np.nan)
    sd_s[problem.free_tau] = packed[n:]
    return packed[:n], sd_s
