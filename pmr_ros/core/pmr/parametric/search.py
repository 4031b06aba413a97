"""The delay search of one row: every column's delay and time constant over a grid, one column at a time.

A row's cost is a sum over bins of ``|b - A theta|^2``.  Holding every
coefficient but column k's, it is a weighted fit of column k alone,

    sum_w M_kk(w) |t_k(w) - lin shape(w; s) z^-d|^2 + const,
    t_k = (v_k - sum_{m != k} M_km theta_m) / M_kk,

whose linear parameter has a closed form at every ``(s, d)``.  So each
column is searched *globally*: every whole-sample delay of its range and a
grid of time constants, the cost of all of them from one matrix product
(:func:`column_search`), ``s`` interpolated between its grid neighbours.
Sweeping the columns in turn (Gauss-Seidel, :func:`sweep_columns`) from the
per-bin free estimate moves every delay straight to where the data put it;
the costs of the old coordinate search -- a full row fit for every one-sample
step of every element -- are gone, and no delay stops at a local minimum on
the way.  The row's joint fit (:mod:`.fit`) then polishes what this finds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..products import real_product
from .lsq import RowParameters
from .ratio import GAIN_RATIO_BOUND, ColumnModel, RowSystem

__all__ = [
    "GRID_POINTS",
    "ColumnGrid",
    "column_grids",
    "column_search",
    "conditional_target",
    "move_delay",
    "sweep_columns",
]

GRID_POINTS = 41
"""Time constants tried per column, evenly spaced in ``log tau`` over its bounds."""

SWEEPS = 4
"""Most Gauss-Seidel sweeps over a row's columns."""


@dataclass(frozen=True)
class ColumnGrid:
    """The search grid of one column over the fitted bins.

    Attributes
    ----------
    column : ColumnModel
    s : ndarray, shape (G,)
        Log time constants tried (one 0 without a time constant).
    shapes : ndarray of complex, shape (G, F')
        The shape at each, without delay.
    delays : ndarray of int, shape (n_d,)
        Delays tried.
    turns : ndarray of complex, shape (F', n_d)
        ``exp(+j w d)``: a delay's conjugate phase.
    z_inv : ndarray of complex, shape (F',)
        ``exp(-j w)`` at the fitted bins.
    """

    column: ColumnModel
    s: np.ndarray
    shapes: np.ndarray
    delays: np.ndarray
    turns: np.ndarray
    z_inv: np.ndarray

    @cached_property
    def conjugate_shapes(self) -> np.ndarray:
        """``conj(shapes)``, computed once per grid (every search of the column reads it)."""
        return np.conj(self.shapes)

    @cached_property
    def power(self) -> np.ndarray:
        """``|shapes|^2``, shape (G, F'), computed once per grid."""
        return np.abs(self.shapes) ** 2

    @cached_property
    def numerator(self) -> np.ndarray:
        """:meth:`~.ratio.ColumnModel.numerator` at ``z_inv``, once per grid (each refined ``s`` reads it)."""
        return self.column.numerator(self.z_inv)


def column_grids(columns: Sequence[ColumnModel], z_inv: np.ndarray) -> list[ColumnGrid]:
    """The search grid of every column of a row."""
    omega = -np.angle(z_inv)
    out = []
    for column in columns:
        s = np.linspace(*column.s_bounds, GRID_POINTS) if column.has_tau else np.zeros(1)
        shapes = column.shape(z_inv, s)  # the derivative no search reads left out
        delays = np.arange(column.delay_bounds[0], column.delay_bounds[1] + 1)
        out.append(ColumnGrid(column, s, shapes, delays, np.exp(1j * np.outer(omega, delays)), z_inv))
    return out


def _best_linear(numerator: np.ndarray, denominator: np.ndarray, column: ColumnModel) -> tuple[np.ndarray, np.ndarray]:
    """The linear parameter and the cost reduction ``2 lin N - lin^2 D`` it achieves, bounds applied."""
    lin = numerator / np.maximum(denominator, 1e-300)
    if not column.interaction:  # np.clip's arithmetic without its wrapper's cost
        lin = np.minimum(np.maximum(lin, -GAIN_RATIO_BOUND), GAIN_RATIO_BOUND)
    return lin, 2.0 * lin * numerator - lin**2 * denominator


def _refine(grid: ColumnGrid, gains: np.ndarray, g: int) -> float:
    """``s`` at the vertex of the parabola through the cost reductions at grid points ``g - 1, g, g + 1``.

    Enough for a start: the joint fit polishes every time constant it holds free.
    """
    if grid.s.size == 1 or g == 0 or g == grid.s.size - 1:
        return float(grid.s[g])
    left, middle, right = gains[g - 1], gains[g], gains[g + 1]
    curvature = left - 2.0 * middle + right
    offset = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
    # np.clip's arithmetic without its wrapper's cost on a scalar (a NaN stays NaN either way)
    return float(grid.s[g] + min(max(offset, -0.5), 0.5) * (grid.s[1] - grid.s[0]))


def _linear_at(grid: ColumnGrid, target: np.ndarray, weight: np.ndarray, s: float, d: int) -> tuple[float, np.ndarray]:
    """The closed-form linear parameter of the column at ``s`` and delay index ``d``, and the shape at ``s``."""
    shape = grid.column.shape(grid.z_inv, np.array([s]), numerator=grid.numerator)
    # the sums' methods: np.sum's arithmetic without its wrappers' cost (a sweep refines thousands of columns)
    numerator = (weight * np.conj(shape[0]) * target * grid.turns[:, d]).sum().real
    lin, _ = _best_linear(numerator, (weight * np.abs(shape[0]) ** 2).sum(), grid.column)
    return float(lin), shape[0]


def column_search(
    grid: ColumnGrid, target: np.ndarray, weight: np.ndarray, *, delay: int | None = None
) -> tuple[float, float, int]:
    """Best ``(lin, s, delay)`` of one column for ``sum_w weight |target - lin shape z^-d|^2``.

    Parameters
    ----------
    grid : ColumnGrid
    target : ndarray of complex, shape (F',)
    weight : ndarray, shape (F',)
    delay : int, optional
        Search only this delay (one of ``grid.delays``).
    """
    lin, s, found, _ = _searched(grid, target, weight, delay=delay)
    return lin, s, found


def _searched(
    grid: ColumnGrid, target: np.ndarray, weight: np.ndarray, *, delay: int | None = None
) -> tuple[float, float, int, np.ndarray]:
    """:func:`column_search`'s ``(lin, s, delay)`` and the column's shape (without delay) at that ``s``."""
    candidates = np.arange(grid.delays.size) if delay is None else np.array([delay - int(grid.delays[0])])
    turns = grid.turns if delay is None else grid.turns[:, candidates]
    numerator = real_product(grid.conjugate_shapes * (weight * target), turns)  # (G, n_d)
    denominator = grid.power @ weight  # (G,)
    _, gain = _best_linear(numerator, denominator[:, None], grid.column)
    g, d = divmod(int(gain.argmax()), gain.shape[1])  # np.unravel_index's answer without its wrappers' cost
    s = _refine(grid, gain[:, d], g)
    lin, shape = _linear_at(grid, target, weight, s, int(candidates[d]))
    return lin, s, int(grid.delays[candidates[d]]), shape


def conditional_target(system: RowSystem, theta: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Column ``k``'s target and weight given the other columns' coefficients ``theta`` (module docstring)."""
    weight = np.maximum(system.M[:, k, k].real, 1e-300)
    others = np.einsum("fm,fm->f", system.M[:, k, :], theta) - system.M[:, k, k] * theta[:, k]
    return (system.v[:, k] - others) / weight, weight


def move_delay(
    system: RowSystem,
    grid: ColumnGrid,
    params: RowParameters,
    *,
    theta: np.ndarray,
    k: int,
    delay: int,
    target: tuple[np.ndarray, np.ndarray] | None = None,
) -> RowParameters:
    """``params`` with column ``k`` moved to ``delay`` and its gain and time constant refitted, the others held.

    The start of a joint fit at a neighbouring delay: the column's own
    parameters are the ones a new delay moves most.  ``target``: column ``k``'s
    :func:`conditional_target` given ``theta``, when already computed (every delay of the column shares it).
    """
    wanted, weight = conditional_target(system, theta, k) if target is None else target
    lin, s, _ = column_search(grid, wanted, weight, delay=delay)
    moved = params.with_delay(k, delay)
    moved.lin[k], moved.s[k] = lin, s
    return moved


def sweep_columns(system: RowSystem, grids: Sequence[ColumnGrid]) -> RowParameters:
    """Search every column in turn until the delays settle: the start of the row's joint fit.

    The first sweep fits each column to its per-bin free estimate, weighted
    by that estimate's inverse variance; the later ones to its conditional
    target given the others (module docstring).
    """
    n = len(grids)
    z_inv = system.z_inv
    free, variance = system.free_estimate()
    params = RowParameters(np.zeros(n), np.zeros(n), np.array([int(g.delays[0]) for g in grids]))
    theta = np.zeros_like(free)
    for sweep in range(SWEEPS + 1):
        before = params.delays.copy()
        for k, grid in enumerate(grids):
            if sweep == 0:
                target, weight = free[:, k], 1.0 / variance[:, k]
            else:
                target, weight = conditional_target(system, theta, k)
            lin, s, delay, shape = _searched(grid, target, weight)
            params.lin[k], params.s[k], params.delays[k] = lin, s, delay
            theta[:, k] = lin * shape * z_inv**delay
        if sweep > 0 and np.array_equal(before, params.delays):
            break
    return params
