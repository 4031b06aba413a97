"""Joint fits of one row at several delay vectors at once: :meth:`~.lsq.RowProblem.fit`'s steps on stacked arrays.

The delay profile (:mod:`.fit`) fits a row at each column's neighbouring
delays, every fit a few Levenberg-Marquardt steps of the same problem from
its own start.  A row's fitted bins are few (61 bins x 8 columns in the year
benchmark), so each numpy call of a fit costs more than its arithmetic.
:func:`fit_stacked` runs the fits of many starts together, their arrays
stacked along a first axis, each member with its own damping and its own
stop: every member takes the steps :meth:`~.lsq.RowProblem.fit` takes from
its start, through the same element-wise arithmetic and the same per-member
reductions and solves (test_parametric_stacked.py checks they agree).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .lsq import COST_TOLERANCE, MAX_ITERATIONS, Coefficients, RowParameters, RowProblem

__all__ = ["fit_stacked", "stacked_coefficients"]


def stacked_coefficients(problem: RowProblem, lin: np.ndarray, s: np.ndarray, delays: np.ndarray) -> Coefficients:
    """:meth:`~.lsq.RowProblem.coefficients` on the fitted bins for B parameter sets at once.

    Parameters
    ----------
    problem : RowProblem
    lin, s : ndarray, shape (B, n)
        Each set's linear parameters and log time constants.
    delays : ndarray of int, shape (B, n)

    Returns
    -------
    Coefficients
        ``theta``, ``d_lin``, ``d_s`` of shape (B, F', n).
    """
    z_inv = problem.system.z_inv[:, None]
    delay = np.transpose(problem._turns[:, delays - problem._lowest], (1, 0, 2))
    has_tau = problem.has_tau
    tau = problem.tau_reference * np.exp(np.where(has_tau, s, 0.0))
    a = np.where(has_tau, np.exp(-1.0 / tau), 0.0)[:, None, :]
    denominator = 1 - a * z_inv
    shape = (1 - a) * problem._numerator / denominator
    d_shape = problem._numerator_dz / denominator**2 * (a / tau[:, None, :])
    if not problem._all_tau:
        shape, d_shape = np.where(has_tau, shape, 1.0), np.where(has_tau, d_shape, 0.0)
    for c in problem.scaled_index:  # a tf/step_response element: its own shape, one set at a time as the fit's
        for b in range(s.shape[0]):
            scaled, d_scaled = problem.columns[c].shapes(z_inv[:, 0], s[b, c : c + 1])
            shape[b, :, c], d_shape[b, :, c] = scaled[0], d_scaled[0]
    d_lin = shape * delay
    lin = lin[:, None, :]
    return Coefficients(lin * d_lin, d_lin, lin * d_shape * delay)


def _cost_and_product(problem: RowProblem, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`~.ratio.RowSystem.cost_and_product` of B coefficient sets ``theta`` (B, F', n): (B,) and ``M theta``."""
    system = problem.system
    Mt = np.einsum("fkm,bfm->bfk", system.M, theta)
    quad = np.einsum("bfk,bfk->b", theta.conj(), Mt).real
    return system._beta_total - 2.0 * np.einsum("bfk,fk->b", theta.conj(), system.v).real + quad, Mt


def _subset(coefficients: Coefficients, members: np.ndarray) -> Coefficients:
    return Coefficients(coefficients.theta[members], coefficients.d_lin[members], coefficients.d_s[members])


def _steps(problem: RowProblem, coefficients: Coefficients, product: np.ndarray) -> tuple[np.ndarray, ...]:
    """Each member's Gauss-Newton matrix (B, p, p), gradient (B, p) and damping diagonal (B, p), as the fit's."""
    owner = problem._owner
    derivatives = np.concatenate([coefficients.d_lin, coefficients.d_s[:, :, problem.free_tau]], axis=2)
    H = np.einsum("bfp,fpq,bfq->bpq", derivatives.conj(), problem._m_owner, derivatives).real
    misfit = product - problem.system.v
    g = 2.0 * np.einsum("bfp,bfp->bp", derivatives.conj(), misfit[:, :, owner]).real
    diagonal = np.diagonal(H, axis1=1, axis2=2)
    floor = 1e-12 * np.maximum(1.0, np.abs(diagonal).max(axis=1))
    return H, g, np.maximum(diagonal, floor[:, None])


class _Stack:
    """The members' current points, coefficients, costs and dampings."""

    def __init__(self, problem: RowProblem, starts: Sequence[RowParameters]) -> None:
        self.problem = problem
        self.lower, self.upper = problem._bounds()
        self.x = np.minimum(np.maximum(np.stack([problem._pack(start) for start in starts]), self.lower), self.upper)
        self.s = np.stack([start.s for start in starts]).astype(float)
        self.delays = np.stack([start.delays for start in starts])
        self.coefficients = self.at(self.x, np.arange(len(starts)))
        self.cost, self.product = _cost_and_product(problem, self.coefficients.theta)
        self.damping = np.full(len(starts), 1e-3)

    def at(self, x: np.ndarray, members: np.ndarray) -> Coefficients:
        """The coefficients of ``members`` at packed parameters ``x`` (their rows)."""
        n = self.problem.n
        s = self.s[members].copy()
        s[:, self.problem.free_tau] = x[:, n:]
        return stacked_coefficients(self.problem, x[:, :n], s, self.delays[members])

    def accept(self, members: np.ndarray, x: np.ndarray, coefficients: Coefficients, found: tuple) -> None:
        self.x[members] = x
        self.cost[members], self.product[members] = found
        for name in ("theta", "d_lin", "d_s"):
            getattr(self.coefficients, name)[members] = getattr(coefficients, name)

    def result(self, start: RowParameters, b: int) -> tuple[RowParameters, float]:
        return self.problem._unpack(self.x[b], start), float(self.cost[b])


def _iteration(stack: _Stack, active: np.ndarray, settled_above: float) -> np.ndarray:
    """One step of every ``active`` member (its damping raised until the cost does not rise); those going on."""
    H, g, diagonal = _steps(stack.problem, _subset(stack.coefficients, active), stack.product[active])
    going = np.zeros(stack.x.shape[0], dtype=bool)
    pending = np.arange(active.size)  # positions in ``active``
    while pending.size:
        pending = pending[stack.damping[active[pending]] < 1e12]  # the others end where they are
        if not pending.size:
            break
        members = active[pending]
        damping = stack.damping[members][:, None, None]
        system = H[pending] + damping * (diagonal[pending][:, :, None] * np.eye(diagonal.shape[1]))
        step = np.linalg.solve(system, (-0.5 * g[pending])[:, :, None])[:, :, 0]
        trial = np.minimum(np.maximum(stack.x[members] + step, stack.lower), stack.upper)
        coefficients = stack.at(trial, members)
        cost, product = _cost_and_product(stack.problem, coefficients.theta)
        better = cost <= stack.cost[members]
        done = members[better]
        decrease = stack.cost[done] - cost[better]
        stack.accept(done, trial[better], _subset(coefficients, better), (cost[better], product[better]))
        stack.damping[done] = np.maximum(stack.damping[done] / 10.0, 1e-9)
        going[done] = (decrease > COST_TOLERANCE) & (cost[better] <= settled_above)
        stack.damping[members[~better]] *= 10.0
        pending = pending[~better]
    return active[going[active]]


def fit_stacked(
    problem: RowProblem,
    starts: Sequence[RowParameters],
    *,
    iterations: int = MAX_ITERATIONS,
    settled_above: float = np.inf,
) -> list[tuple[RowParameters, float]]:
    """``[problem.fit(start, iterations=..., settled_above=...) for start in starts]``, the fits run together.

    Parameters
    ----------
    problem : RowProblem
    starts : sequence of RowParameters
        Each fit's start (its delays held).
    iterations : int
        Most steps of each fit.
    settled_above : float
        A fit whose cost is still above this after a step ends there (:meth:`~.lsq.RowProblem.fit`).

    Returns
    -------
    list of (RowParameters, float)
        Each start's fitted parameters and cost, in order.

    Examples
    --------
    >>> fits = fit_stacked(problem, [start_a, start_b], iterations=3)  # doctest: +SKIP
    """
    if not starts:
        return []
    stack = _Stack(problem, starts)
    active = np.arange(len(starts))
    for _ in range(iterations):
        if not active.size:
            break
        active = _iteration(stack, active, settled_above)
    return [stack.result(start, b) for b, start in enumerate(starts)]
