"""The warm-started active-set QP: the same unique minimizer as a cold start and as OSQP from scratch."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from qp_cases import osqp_solution, random_qp

from pmr_ros.config import config_dir, load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.mpc.qp import DenseQp
from pmr_ros.core.mpc.solver import QpSolver
from pmr_ros.core.sim.closed_loop import simulate


def _guesses(exact, other, m):
    """Guesses of an active set: the right one, another problem's, the right one with rows added or missing."""
    wrong_side = tuple(-s for s in exact)
    extra = tuple(exact) + tuple(r + 1 for r in range(m) if r + 1 not in exact and -(r + 1) not in exact)[:2]
    return {"exact": exact, "other": other, "wrong_side": wrong_side, "extra": extra, "missing": exact[1:]}


@pytest.mark.parametrize("seed", range(12))
def test_a_warm_start_from_any_guess_gives_the_cold_minimizer_and_osqps(seed):
    rng = np.random.default_rng(seed)
    H, A, q, lower, upper = random_qp(rng)
    qp = DenseQp(H, A)
    cold = qp.solve(q, lower=lower, upper=upper)
    other = qp.solve(rng.normal(scale=5.0, size=q.size), lower=lower, upper=upper)
    assert cold.solved and other.solved and len(cold.active) >= 2
    reference = osqp_solution(H, A, q, lower, upper)
    for name, guess in _guesses(cold.active, other.active, A.shape[0]).items():
        warm = DenseQp(H, A).solve(q, lower=lower, upper=upper, guess=guess)
        assert warm.solved, name
        np.testing.assert_allclose(warm.x, cold.x, rtol=1e-9, atol=1e-10 * np.abs(cold.x).max(), err_msg=name)
        np.testing.assert_allclose(warm.x, reference, atol=1e-6, err_msg=name)
        assert set(warm.active) == set(cold.active), name


def test_the_exact_guess_needs_no_iteration_and_a_dependent_one_falls_back_to_a_cold_start():
    rng = np.random.default_rng(4)
    H, A, q, lower, upper = random_qp(rng)
    qp = DenseQp(H, A)
    cold = qp.solve(q, lower=lower, upper=upper)
    again = qp.solve(q, lower=lower, upper=upper, guess=cold.active)
    assert again.iterations == 0
    np.testing.assert_allclose(again.x, cold.x, rtol=1e-12, atol=1e-12)
    row = abs(cold.active[0])
    doubled = DenseQp(H, np.vstack([A, A[row - 1]]))  # row m+1 repeats row `row`: dependent normals
    both = (row, A.shape[0] + 1) if cold.active[0] > 0 else (-row, -(A.shape[0] + 1))
    extended = (np.append(lower, lower[row - 1]), np.append(upper, upper[row - 1]))
    dependent = doubled.solve(q, lower=extended[0], upper=extended[1], guess=both)
    assert dependent.solved
    np.testing.assert_allclose(dependent.x, cold.x, rtol=1e-9, atol=1e-10 * np.abs(cold.x).max())


class _Recording(QpSolver):
    """A QpSolver keeping every problem it was given and its answer."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.problems = []

    def solve(self, q, *, lower, upper):
        x = super().solve(q, lower=lower, upper=upper)
        self.problems.append((q.copy(), lower.copy(), upper.copy(), x))
        return x


def test_every_warm_started_mpc_step_equals_a_qp_solved_from_scratch(wood_berry):
    """Tight limits, setpoints far and changing: the active set changes step by step."""
    tight = dataclasses.replace(wood_berry.mpc, u_min=np.array([-0.3, -0.2]), u_max=np.array([0.3, 0.2]))
    mpc = LinearMpc(wood_berry.model, tight, always_solve_qp=True)
    old = mpc._solver
    mpc._solver = recording = _Recording(old.hessian, old.constraints, mpc.statistics)
    rng = np.random.default_rng(7)
    setpoints = np.repeat(rng.normal(scale=2.0, size=(12, 2)), 10, axis=0)
    for r in setpoints:
        mpc.step(rng.normal(scale=0.05, size=2), r)
    sizes = {len(recording.qp.solve(q, lower=lo, upper=up).active) for q, lo, up, _ in recording.problems}
    assert len(sizes) > 2  # the active set did change
    for q, lower, upper, x in recording.problems:
        cold = DenseQp(recording.hessian, recording.constraints).solve(q, lower=lower, upper=upper)
        np.testing.assert_allclose(x, cold.x, rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(
            x, osqp_solution(recording.hessian, recording.constraints, q, lower, upper), atol=1e-6
        )


@pytest.mark.parametrize("system", ["three_by_three.yaml", "sparse_sixteen.yaml"])
def test_the_closed_loop_inputs_equal_those_of_cold_started_qps(system, monkeypatch):
    """The whole loop with the warm start equals the loop with every QP cold-started, to rounding."""
    overrides = {"mpc": {"u_min": -0.4, "u_max": 0.4, "du_max": 0.08}} if system == "three_by_three.yaml" else None
    config = load_config(config_dir() / system, overrides=overrides)
    warm = simulate(config, samples=300)
    cold_solve = DenseQp.solve

    def cold_only(self, q, *, lower, upper, guess=()):
        return cold_solve(self, q, lower=lower, upper=upper)

    monkeypatch.setattr(DenseQp, "solve", cold_only)
    cold = simulate(config, samples=300)
    scale_u, scale_y = np.abs(cold.u).max(), np.abs(cold.y).max()
    assert scale_u > 0.1  # the loop moved
    np.testing.assert_allclose(warm.u, cold.u, rtol=0.0, atol=1e-9 * scale_u)
    np.testing.assert_allclose(warm.y, cold.y, rtol=0.0, atol=1e-9 * scale_y)
