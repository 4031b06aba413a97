"""Random strictly convex QPs with box rows, and OSQP's solution of one: shared by the QP tests."""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sp


def random_qp(rng: np.random.Generator, n: int = 12, m: int = 20) -> tuple[np.ndarray, ...]:
    """``(H, A, q, lower, upper)`` of a feasible QP: H positive definite, some rows one-sided."""
    M = rng.normal(size=(n, n))
    H = M @ M.T + 0.1 * np.eye(n)
    A = rng.normal(size=(m, n))
    centre = A @ rng.normal(scale=0.2, size=n)  # a feasible point inside every box
    lower, upper = centre - rng.uniform(0.05, 1.0, m), centre + rng.uniform(0.05, 1.0, m)
    lower[rng.random(m) < 0.2] = -np.inf  # some one-sided rows
    return H, A, rng.normal(scale=5.0, size=n), lower, upper


def osqp_solution(H, A, q, lower, upper) -> np.ndarray:
    """OSQP's minimizer from scratch, to tight tolerances (an independent reference)."""
    solver = osqp.OSQP()
    solver.setup(
        sp.triu(sp.csc_matrix(H), format="csc"),
        q,
        sp.csc_matrix(A),
        lower,
        upper,
        verbose=False,
        eps_abs=1e-11,
        eps_rel=1e-11,
        max_iter=200000,
        polishing=True,
    )
    return solver.solve(raise_error=False).x


def degenerate_qp(rng: np.random.Generator, n: int = 10) -> tuple[np.ndarray, ...]:
    """``(H, A, q, lower, upper)`` of a feasible QP with degenerate constraints, from the MPC's kind of rows.

    Box rows (as the MPC's move limits) some with zero width (equalities), the rows of a running sum (its
    input limits), a repeated row and an opposite one (dependent normals), and a linear term far outside
    the boxes, so that many bounds are active at the minimizer, often as many as there are variables.
    """
    M = rng.normal(size=(n, n))
    H = M @ M.T + 0.1 * np.eye(n)
    A = np.vstack([np.eye(n), np.tril(np.ones((n, n))), rng.normal(size=(2, n))])
    A = np.vstack([A, A[n + 2], -A[-1]])  # a repeated row and an opposite one
    m = A.shape[0]
    centre = A @ rng.normal(scale=0.2, size=n)
    width = rng.uniform(0.0, 0.5, m)
    width[rng.random(m) < 0.15] = 0.0  # equality rows
    lower, upper = centre - width, centre + width
    lower[rng.random(m) < 0.1] = -np.inf
    return H, A, rng.normal(scale=50.0, size=n), lower, upper
