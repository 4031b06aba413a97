"""The stacked row fits (:mod:`pmr_ros.core.pmr.parametric.stacked`) against the one-at-a-time fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmr_ros.core.pmr.parametric.lsq import RowParameters, RowProblem
from pmr_ros.core.pmr.parametric.ratio import ColumnModel, RowSystem
from pmr_ros.core.pmr.parametric.search import column_grids
from pmr_ros.core.pmr.parametric.stacked import fit_stacked, stacked_coefficients
from pmr_ros.core.pmr.parametric.trials import JOINT_CANDIDATES, Trials, _grid, joint_search
from pmr_ros.core.pmr.products import hermitian_product


def _columns() -> list[ColumnModel]:
    ratio = ColumnModel("ratio", math.exp(-1 / 12), 12.0, (-1.5, 1.5), (-3, 4), True)
    lag = ColumnModel("lag", 0.0, 5.0, (-2.0, 2.0), (0, 8), False)
    delay = ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-3, 3), True)
    return [ratio, lag, delay, ratio]


TRUTH = RowParameters(np.array([1.15, 0.4, 0.9, 0.8]), np.array([0.25, -0.6, 0.0, -0.4]), np.array([2, 3, -1, 0]))


def _problem(noise: float = 0.05, seed: int = 3, F: int = 61, n_z: int = 6) -> RowProblem:
    """A row's equations from a random design and known parameters (TRUTH), with complex noise."""
    rng = np.random.default_rng(seed)
    columns = _columns()
    n = len(columns)
    z_inv = np.exp(-1j * np.linspace(0.0, 0.9, F))
    empty = RowSystem(np.zeros((F, n, n), complex), np.zeros((F, n), complex), np.zeros(F), z_inv, 2 * F * n_z)
    theta = RowProblem(empty, columns).coefficients(TRUTH).theta
    A = rng.standard_normal((F, n_z, n)) + 1j * rng.standard_normal((F, n_z, n))
    A[0] = A[0].real
    b = np.einsum("fzk,fk->fz", A, theta) + noise * (rng.standard_normal((F, n_z)) + 1j * rng.standard_normal((F, n_z)))
    AH = np.conj(np.transpose(A, (0, 2, 1)))
    system = RowSystem(AH @ A, (AH @ b[:, :, None])[:, :, 0], np.sum(np.abs(b) ** 2, axis=1), z_inv, 2 * b.size)
    return RowProblem(system, columns)


def _starts(problem: RowProblem) -> list[RowParameters]:
    """Starts at every single-column delay neighbour of the truth, from its refitted column (the profile's)."""
    trials = Trials(problem, column_grids(problem.columns, problem.system.z_inv))
    best = trials.full(TRUTH)
    out = []
    for k, column in enumerate(problem.columns):
        for d in range(column.delay_bounds[0], column.delay_bounds[1] + 1):
            if d != TRUTH.delays[k]:
                out.append(trials.start(best, [(k, d)]))
    return out


def test_stacked_coefficients_are_the_rows_coefficients_of_each_set():
    problem = _problem()
    starts = _starts(problem)[:7]
    stacked = stacked_coefficients(
        problem,
        np.stack([p.lin for p in starts]),
        np.stack([p.s for p in starts]),
        np.stack([p.delays for p in starts]),
    )
    for b, start in enumerate(starts):
        alone = problem.coefficients(start)
        np.testing.assert_allclose(stacked.theta[b], alone.theta, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(stacked.d_lin[b], alone.d_lin, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(stacked.d_s[b], alone.d_s, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize(("iterations", "settled"), [(3, math.inf), (60, math.inf), (3, 0.0)])
def test_a_stacked_fit_equals_the_one_at_a_time_fit_of_each_start(iterations, settled):
    """Each member takes the steps the fit takes alone: the same parameters and cost (to rounding)."""
    problem = _problem()
    starts = _starts(problem)
    truth_cost = problem.fit(TRUTH)[1]
    settled_above = truth_cost + 200.0 if settled == 0.0 else settled
    stacked = fit_stacked(problem, starts, iterations=iterations, settled_above=settled_above)
    assert len(stacked) == len(starts) > 20
    for start, (params, cost) in zip(starts, stacked, strict=True):
        alone, alone_cost = problem.fit(start, iterations=iterations, settled_above=settled_above)
        np.testing.assert_allclose(params.lin, alone.lin, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(params.s, alone.s, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(params.delays, start.delays)
        assert cost == pytest.approx(alone_cost, rel=1e-12)
        assert cost >= truth_cost - 1e-9  # no neighbour fits better than the truth's own converged fit


def test_a_stacked_fit_at_the_true_delays_recovers_the_parameters_without_noise():
    problem = _problem(noise=0.0)
    # an interaction's (the lag's) time constant is held where the start puts it: the truth's
    off = RowParameters(TRUTH.lin * 0.8, TRUTH.s + np.array([0.1, 0.0, 0.0, 0.1]), TRUTH.delays.copy())
    ((params, cost),) = fit_stacked(problem, [off])
    assert cost < 1e-10 * problem.system.beta.sum()
    np.testing.assert_allclose(params.lin, TRUTH.lin, atol=1e-6)
    np.testing.assert_allclose(params.s, TRUTH.s, atol=1e-5)
    assert fit_stacked(problem, []) == []


def test_prefetched_fits_are_the_fits_moved_computes_and_a_joint_search_is_unchanged():
    problem = _problem()
    grids = column_grids(problem.columns, problem.system.z_inv)
    alone, together = Trials(problem, grids), Trials(problem, grids)
    best_alone, best_together = alone.full(TRUTH), together.full(TRUTH)
    moves = [[(0, 1)], [(1, 4)], [(2, -2), (3, 1)]]
    together.prefetch(best_together, moves)
    for each in moves:
        a, b = alone.moved(best_alone, each), together.moved(best_together, each)
        np.testing.assert_allclose(b[0].lin, a[0].lin, rtol=1e-12, atol=1e-12)
        assert b[1] == pytest.approx(a[1], rel=1e-12)
    # a joint search (which prefetches each pair's candidates) tries the delay vectors that fitting each
    # candidate alone tries, in the same order and with the same costs
    fresh, single = Trials(problem, grids), Trials(problem, grids)
    best, best_single = fresh.full(TRUTH), single.full(TRUTH)
    pairs = [(0, 3), (1, 2)]
    joint_search(fresh, best, pairs)
    for k, m in pairs:
        for _, each, _ in _grid(single, best_single, k, m)[:JOINT_CANDIDATES]:
            single.moved(best_single, each)
    assert list(fresh.tried) == list(single.tried) and len(fresh.tried) > 10
    for key, (params, cost) in fresh.tried.items():
        np.testing.assert_allclose(params.lin, single.tried[key][0].lin, rtol=1e-12, atol=1e-12)
        assert cost == pytest.approx(single.tried[key][1], rel=1e-12)


@pytest.mark.parametrize(("m", "n"), [(1, 1), (3, 1), (1, 4), (5, 4), (12, 9)])
def test_hermitian_product_of_any_width_equals_numpy(m, n):
    rng = np.random.default_rng(m * 10 + n)
    a = rng.standard_normal((7, 42, m)) + 1j * rng.standard_normal((7, 42, m))
    b = rng.standard_normal((7, 42, n)) + 1j * rng.standard_normal((7, 42, n))
    expected = np.conj(np.swapaxes(a, 1, 2)) @ b
    np.testing.assert_allclose(hermitian_product(a, b), expected, rtol=1e-12, atol=1e-12)
    strided = np.transpose(np.transpose(a, (1, 0, 2)).copy(), (1, 0, 2))  # non-contiguous, as a window's segments
    np.testing.assert_allclose(hermitian_product(strided, b), expected, rtol=1e-12, atol=1e-12)


def test_coefficients_with_their_delays_gathered_once_are_the_ratio_shapes():
    """Evaluated again at delay vectors seen before (the gathered z^-d reused), each coefficient is its shape."""
    from pmr_ros.core.pmr.parametric.ratio import ratio_shape

    problem = _problem()
    z_inv = problem.system.z_inv
    for delays in ([2, 3, -1, 0], [1, 3, -1, 2], [2, 3, -1, 0], [1, 3, -1, 2]):
        params = RowParameters(TRUTH.lin, TRUTH.s, np.array(delays))
        theta = problem.coefficients(params).theta
        for k, column in enumerate(problem.columns):
            pole = column.pole(float(TRUTH.s[k])) if column.has_tau else 0.0
            expected = TRUTH.lin[k] * ratio_shape(z_inv, column.pole_model, pole, delays[k])
            np.testing.assert_allclose(theta[:, k], expected, rtol=1e-12, atol=1e-13)
