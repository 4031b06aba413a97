"""One MPC QP with fixed Hessian and constraint matrix, solved exactly, OSQP standing by, the input held last.

The dual active-set method (:class:`~pmr_ros.core.mpc.qp.DenseQp`) solves it
exactly, warm-started from the last solve's active set; should it break down,
OSQP (set up on first need, warm-started after);
should that fail too, the caller holds the input (a zero move), the safe
fallback of industrial MPC.  :class:`~pmr_ros.core.mpc.spec.MpcStatistics`
counts the solves, fallbacks and failures.
"""

from __future__ import annotations

import time

import numpy as np
import osqp
import scipy.sparse as sp

from .qp import DenseQp
from .spec import MpcStatistics

__all__ = ["WARM_START_MIN_ACTIVE", "QpSolver"]

WARM_START_MIN_ACTIVE = 4
"""The fewest active constraints of the previous step from which the next solve starts (smaller sets: cold)."""


class QpSolver:
    """``min x' H x / 2 + q' x  s.t.  lower <= A x <= upper`` for changing ``q`` and bounds.

    Parameters
    ----------
    hessian : ndarray, shape (n, n)
        Symmetric positive definite.
    constraints : ndarray, shape (m, n)
    statistics : MpcStatistics
        Counters updated by each solve.

    Attributes
    ----------
    qp : DenseQp
        The exact solver (replaceable, e.g. by one with an iteration limit in a test).
    """

    def __init__(self, hessian: np.ndarray, constraints: np.ndarray, statistics: MpcStatistics) -> None:
        self.hessian, self.constraints, self.statistics = hessian, constraints, statistics
        self.qp = DenseQp(hessian, constraints)
        self._fallback: osqp.OSQP | None = None  # set up on first need
        self._active: tuple[int, ...] = ()  # the last solve's active set: MPC steps in a row share most of it
        self._solved_at = -1  # statistics.steps at the last solve

    def _setup_fallback(self, lower: np.ndarray, upper: np.ndarray) -> osqp.OSQP:
        """OSQP with the fixed Hessian and constraint matrix: the fallback should the active-set solver fail."""
        solver = osqp.OSQP()
        solver.setup(
            sp.triu(sp.csc_matrix(self.hessian), format="csc"),
            np.zeros(self.hessian.shape[0]),
            sp.csc_matrix(self.constraints),
            lower,
            upper,
            verbose=False,
            warm_starting=True,
            eps_abs=1e-9,
            eps_rel=1e-9,
            max_iter=100000,
            polishing=True,
        )
        return solver

    def solve(self, q: np.ndarray, *, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
        """The minimizer, or None when both solvers fail; counts the solve (and its time when kept)."""
        t0 = time.perf_counter()
        stats = self.statistics
        # the last solve's active set is a guess when it was the previous step's (not one before shortcuts) and
        # large enough for a warm start to pay: a few constraints the cold start adds as fast as it checks them
        recent = self._solved_at >= stats.steps - 1 and len(self._active) >= WARM_START_MIN_ACTIVE
        guess = self._active if recent else ()
        solution = self.qp.solve(q, lower=lower, upper=upper, guess=guess)
        self._active, self._solved_at = (solution.active if solution.solved else ()), stats.steps
        x = solution.x if solution.solved else self._solve_fallback(q, lower, upper)
        stats.solves += 1
        if stats.solve_time_s is not None:
            stats.solve_time_s.append(time.perf_counter() - t0)
        if x is None:
            stats.failures += 1
        return x

    def _solve_fallback(self, q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
        """OSQP's solution, or None when it fails too."""
        self.statistics.fallbacks += 1
        if self._fallback is None:
            self._fallback = self._setup_fallback(lower, upper)
        self._fallback.update(q=q, l=lower, u=upper)
        result = self._fallback.solve(raise_error=False)
        if result.info.status_val in (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE):
            return np.asarray(result.x)
        return None
