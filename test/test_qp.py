"""The dense dual active-set QP solver against the optimality conditions and against OSQP."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize
from qp_cases import degenerate_qp, osqp_solution, random_qp

from pmr_ros.config import config_dir, load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.mpc.qp import DenseQp


def _kkt_residual(H, A, q, lower, upper, x, tol=1e-9):
    """Largest violation of the KKT conditions at x, for equality and dependent rows too (multipliers >= 0 by NNLS).

    Each row at its lower bound may push with ``+a``, each at its upper with ``-a`` (an equality row both ways).
    """
    ax = A @ x
    normals = np.vstack([A[np.abs(ax - lower) < tol], -A[np.abs(ax - upper) < tol]])
    gradient = H @ x + q
    stationarity = scipy.optimize.nnls(normals.T, gradient)[1] if normals.size else np.linalg.norm(gradient)
    return max(stationarity, np.max(lower - ax), np.max(ax - upper), 0.0)


@pytest.mark.parametrize("seed", range(20))
def test_random_qps_meet_the_optimality_conditions_and_equalosqp_solution(seed):
    rng = np.random.default_rng(seed)
    H, A, q, lower, upper = random_qp(rng)
    solution = DenseQp(H, A).solve(q, lower=lower, upper=upper)
    assert solution.solved
    assert _kkt_residual(H, A, q, lower, upper, solution.x) < 1e-8
    np.testing.assert_allclose(solution.x, osqp_solution(H, A, q, lower, upper), atol=1e-6)
    active = {abs(s) - 1 for s in solution.active}
    ax = A @ solution.x
    assert all(min(abs(ax[i] - lower[i]), abs(ax[i] - upper[i])) < 1e-9 for i in active)


@pytest.mark.parametrize("seed", range(20))
def test_degenerate_qps_are_solved_exactly_cold_and_warm(seed):
    """Equality rows, repeated and opposite rows, many bounds active: the optimality conditions and OSQP."""
    rng = np.random.default_rng(seed)
    H, A, q, lower, upper = degenerate_qp(rng)
    qp = DenseQp(H, A)
    cold = qp.solve(q, lower=lower, upper=upper)
    assert cold.solved and len(cold.active) >= 3
    assert _kkt_residual(H, A, q, lower, upper, cold.x) < 1e-8 * (1.0 + np.abs(q).max())
    np.testing.assert_allclose(cold.x, osqp_solution(H, A, q, lower, upper), atol=1e-6)
    nearby = q + rng.normal(scale=5.0, size=q.size)  # a step later: the active set moved a little
    warm = qp.solve(nearby, lower=lower, upper=upper, guess=cold.active)
    again = DenseQp(H, A).solve(nearby, lower=lower, upper=upper)
    assert warm.solved and again.solved
    np.testing.assert_allclose(warm.x, again.x, rtol=0.0, atol=1e-9 * max(np.abs(again.x).max(), 1.0))
    np.testing.assert_allclose(warm.x, osqp_solution(H, A, nearby, lower, upper), atol=1e-6)


def test_unconstrained_optimum_is_returned_when_nothing_binds():
    H = np.diag([2.0, 4.0])
    solution = DenseQp(H, np.eye(2)).solve(np.array([-2.0, 4.0]), lower=np.full(2, -5.0), upper=np.full(2, 5.0))
    np.testing.assert_allclose(solution.x, [1.0, -1.0])
    assert solution.solved and solution.active == () and solution.iterations == 0


def test_a_constraint_added_early_is_dropped_when_another_makes_it_slack():
    # min (x1 - 2)^2 + (x2 - 2)^2: the most violated row, 2 x1 + x2 <= 1.6, is added first; once x1 + x2 <= 1
    # binds too, it goes slack again at the optimum (0.5, 0.5) and must be dropped.
    H, q = 2 * np.eye(2), np.array([-4.0, -4.0])
    A = np.array([[1.0, 0.0], [1.0, 1.0], [2.0, 1.0]])
    solution = DenseQp(H, A).solve(q, lower=np.full(3, -np.inf), upper=np.array([0.9, 1.0, 1.6]))
    np.testing.assert_allclose(solution.x, [0.5, 0.5], atol=1e-12)
    assert solution.solved and {abs(s) - 1 for s in solution.active} == {1}
    assert solution.iterations == 3  # add, add, drop


def test_an_iteration_limit_is_reported_not_hidden():
    rng = np.random.default_rng(3)
    H, A, q, lower, upper = random_qp(rng)
    full = DenseQp(H, A).solve(q, lower=lower, upper=upper)
    assert full.iterations >= 2
    cut = DenseQp(H, A, max_iterations=1).solve(q, lower=lower, upper=upper)
    assert not cut.solved


def test_the_mpc_falls_back_to_osqp_when_the_active_set_method_fails(wood_berry):
    r = np.tile([3.0, -3.0], (60, 1))  # far beyond the limits: every step binds
    exact = LinearMpc(wood_berry.model, wood_berry.mpc)
    forced = LinearMpc(wood_berry.model, wood_berry.mpc)
    solver = forced._solver
    solver.qp = DenseQp(solver.hessian, solver.constraints, max_iterations=1)  # breaks down on purpose
    y = np.zeros(2)
    for setpoint in r:
        np.testing.assert_allclose(forced.step(y, setpoint), exact.step(y, setpoint), atol=1e-6)
    assert exact.statistics.fallbacks == 0 and exact.statistics.solves > 0
    assert forced.statistics.fallbacks > 0 and forced.statistics.failures == 0


def test_industrial_mpc_problems_are_solved_exactly():
    config = load_config(config_dir() / "industrial_column.yaml")
    mpc = LinearMpc(config.model, config.mpc, always_solve_qp=True)
    rng = np.random.default_rng(0)
    for _ in range(30):
        mpc.step(rng.normal(scale=[0.5, 0.5, 3.0, 2.0]), rng.normal(scale=[0.5, 0.5, 3.0, 2.0]))
    assert mpc.statistics.solves == 30 and mpc.statistics.fallbacks == 0
