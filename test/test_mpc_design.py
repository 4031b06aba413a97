"""The MPC's offline design and its disturbance model, checked against direct simulation and closed forms."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.core.mpc.controller import LinearMpc, MpcTuning
from pmr_ros.core.mpc.design import (
    QpWeights,
    condensed_qp,
    input_target_penalty,
    null_space,
    prediction_matrices,
    setpoints_reachable,
    steady_state_gain,
    target_map,
)
from pmr_ros.core.mpc.estimator import DisturbanceEstimator, ramp_filter_gains
from pmr_ros.core.mpc.stability import closed_loop_matrix, loop_spectral_radius, neutral_modes
from pmr_ros.core.sim.model import Mismatch, TransferMatrix
from pmr_ros.core.sim.true_plant import FoptdPlant


def level_and_temperature() -> TransferMatrix:
    """2x3: a level integrating in u1 and u2, a temperature (FOPTD) in u1 and u3; two empty cells."""
    kinds = [["integrating", "integrating", "none"], ["foptd", "none", "foptd"]]
    return TransferMatrix(
        [[-0.05, 0.03, 0.0], [0.8, 0.0, 1.5]],
        [[0.0, 0.0, 0.0], [10.0, 0.0, 8.0]],
        [[1.0, 2.0, 0.0], [2.0, 0.0, 1.0]],
        1.0,
        element_type=kinds,
    )


def tuning(n_out: int, n_in: int, **changes) -> MpcTuning:
    ones_out, ones_in = np.ones(n_out), np.ones(n_in)
    base = MpcTuning(40, 8, ones_out, ones_in, -5 * ones_in, 5 * ones_in, 0.5 * ones_in, 0 * ones_in, ones_in, 10.0)
    return replace(base, **changes)


# --- predictions and the steady state -----------------------------------------------------------


def test_prediction_matrices_equal_a_direct_simulation_of_the_model():
    model = level_and_temperature()
    ss = model.state_space()
    Np, Nc = 12, 4
    Phi, Psi, Theta = prediction_matrices(ss, prediction_horizon=Np, control_horizon=Nc)
    rng = np.random.default_rng(0)
    x0, u_prev, moves = rng.normal(size=ss.A.shape[0]), rng.normal(size=3), rng.normal(size=(Nc, 3))
    u_path = u_prev + np.cumsum(moves, axis=0)
    x, predicted = x0, []
    for j in range(Np):
        x = ss.A @ x + ss.B @ u_path[min(j, Nc - 1)]  # the input is held after the control horizon
        predicted.append(ss.C @ x)
    np.testing.assert_allclose(Phi @ x0 + Psi @ u_prev + Theta @ moves.ravel(), np.ravel(predicted), atol=1e-12)


def test_steady_state_gain_has_values_for_stable_rows_and_rates_for_integrating_rows():
    model = replace(level_and_temperature(), sample_time=2.0)
    np.testing.assert_allclose(steady_state_gain(model), [[-0.1, 0.06, 0.0], [0.8, 0.0, 1.5]])


def test_null_space_reachability_and_the_input_target_penalty():
    G = steady_state_gain(level_and_temperature())
    N = null_space(G)
    assert N.shape == (3, 1)
    np.testing.assert_allclose(G @ N, 0.0, atol=1e-15)
    np.testing.assert_allclose(N.T @ N, np.eye(1), atol=1e-15)
    assert setpoints_reachable(G) and not setpoints_reachable(G.T)
    assert not setpoints_reachable(np.array([[1.0, 2.0], [2.0, 4.0]]))  # collinear rows
    S = np.array([1.0, 4.0, 0.5])
    M = input_target_penalty(G, S)
    # zero on every direction a setpoint needs (S^-1 G'), positive on the free one, symmetric PSD
    np.testing.assert_allclose(M @ np.diag(1 / S) @ G.T, 0.0, atol=1e-14)
    assert float(N[:, 0] @ M @ N[:, 0]) > 0
    np.testing.assert_allclose(M, M.T, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(M) > -1e-14)
    np.testing.assert_array_equal(input_target_penalty(np.eye(2), np.ones(2)), np.zeros((2, 2)))


def test_target_map_is_the_identity_when_reachable_and_least_squares_otherwise():
    G = steady_state_gain(level_and_temperature())
    F = target_map(G, np.array([True, False]), np.ones(2))
    np.testing.assert_array_equal(F, [[1, 0, -1, 0, 0], [0, 1, 0, -1, 0]])
    tall = np.array([[1.0, 0.5], [0.7, 0.0], [-0.4, 1.2]])
    q = np.array([1.0, 4.0, 0.5])
    F = target_map(tall, np.zeros(3, dtype=bool), q)
    r, d = np.array([1.0, 0.2, -0.5]), np.array([0.1, -0.3, 0.2])
    u = np.linalg.lstsq(np.sqrt(q)[:, None] * tall, np.sqrt(q) * (r - d), rcond=None)[0]
    np.testing.assert_allclose(F @ np.concatenate([r, d]), tall @ u, atol=1e-12)  # y_s - d = G u_s


def test_target_map_holds_a_level_rate_at_zero_before_the_compromise():
    G = np.array([[1.0, 0.5], [0.7, 0.0], [0.2, 0.6]])  # row 3: an integrating output's rates
    F = target_map(G, np.array([False, False, True]), np.ones(3))
    r, d, p = np.array([1.0, 0.2, -0.5]), np.array([0.1, -0.3, 0.2]), np.array([0.04])
    offset = F @ np.concatenate([r, d, p])
    # u_s: 0.2 u1 + 0.6 u2 + p = 0, then the stable rows by least squares along that line
    line = np.array([0.6, -0.2]) / np.hypot(0.6, 0.2)
    u_p = -np.linalg.pinv(G[2:]) @ p
    c = np.linalg.lstsq(G[:2] @ line[:, None], r[:2] - d[:2] - G[:2] @ u_p, rcond=None)[0]
    u_s = u_p + line * c
    np.testing.assert_allclose(offset[:2], G[:2] @ u_s, atol=1e-12)
    np.testing.assert_allclose(offset[2], r[2] - d[2])
    assert G[2] @ u_s + p[0] == pytest.approx(0.0, abs=1e-14)


def test_condensed_qp_is_the_cost_of_the_predicted_path():
    model = level_and_temperature()
    ss = model.state_space()
    Np, Nc = 15, 3
    est = DisturbanceEstimator.for_model(model, filter_samples=5.0)
    G = steady_state_gain(model)
    S = np.array([1.0, 2.0, 0.5])
    weights = QpWeights(
        np.array([1.0, 3.0]), np.array([0.5, 1.0, 2.0]), np.array([0.1, -0.2, 0.3]), input_target_penalty(G, S)
    )
    F = target_map(G, model.integrating_outputs, weights.output)
    qp = condensed_qp(ss, horizons=(Np, Nc), weights=weights, targets=F, estimator=est)
    Phi, Psi, Theta = prediction_matrices(ss, prediction_horizon=Np, control_horizon=Nc)
    rng = np.random.default_rng(1)
    x, u_prev, r, d, p = (rng.normal(size=n) for n in (ss.A.shape[0], 3, 2, 2, 1))
    z = np.concatenate([x, u_prev, r, d, p])

    def cost(moves):
        ramp = np.outer(np.arange(1, Np + 1), [p[0], 0.0]).ravel()
        y = Phi @ x + Psi @ u_prev + Theta @ moves + np.tile(d, Np) + ramp
        y_s = F @ np.concatenate([r, d, p]) + d
        path = u_prev + np.cumsum(moves.reshape(Nc, 3), axis=0) - weights.input_target
        e = y - np.tile(y_s, Np)
        return (
            e @ (np.tile(weights.output, Np) * e)
            + moves @ (np.tile(weights.move, Nc) * moves)
            + sum(v @ weights.input_target_penalty @ v for v in path)
        )

    a, b = rng.normal(size=3 * Nc), rng.normal(size=3 * Nc)
    q = qp.gradient @ z + qp.gradient_offset
    quadratic = lambda m: m @ qp.hessian @ m + 2 * q @ m  # noqa: E731  the cost up to a constant
    assert cost(a) - cost(b) == pytest.approx(quadratic(a) - quadratic(b), rel=1e-10)


# --- the disturbance model ----------------------------------------------------------------------


@pytest.mark.parametrize("samples", [0.0, 3.0, 25.0])
def test_ramp_filter_error_poles_are_where_asked(samples):
    alpha, beta = ramp_filter_gains(samples)
    rho = np.exp(-1 / samples) if samples else 0.0
    # filtered-estimate error dynamics of the step+slope model: (I - L C) A
    error = (np.eye(2) - np.array([[alpha], [beta]]) @ np.array([[1.0, 0.0]])) @ np.array([[1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(np.abs(np.linalg.eigvals(error)), [rho, rho], atol=1e-7)
    with pytest.raises(ValueError, match=">= 0"):
        ramp_filter_gains(-1.0)


def test_estimator_follows_a_ramp_without_error_and_steps_at_once():
    est = DisturbanceEstimator.for_model(level_and_temperature(), filter_samples=8.0)
    assert list(est.integrating) == [0] and est.n_ramps == 1
    step, slope = np.zeros(2), np.zeros(1)
    for k in range(400):
        step, slope = est.update(np.array([0.5 + 0.02 * k, -0.7]), step, slope)
    np.testing.assert_allclose(step, [0.5 + 0.02 * 399, -0.7], atol=1e-10)
    np.testing.assert_allclose(slope, [0.02], atol=1e-12)


def test_estimator_on_a_batch_equals_each_run():
    est = DisturbanceEstimator.for_model(level_and_temperature(), filter_samples=4.0)
    rng = np.random.default_rng(2)
    residuals = rng.normal(size=(50, 3, 2))
    step_b, slope_b = np.zeros((3, 2)), np.zeros((3, 1))
    singles = [(np.zeros(2), np.zeros(1)) for _ in range(3)]
    for e in residuals:
        step_b, slope_b = est.update(e, step_b, slope_b)
        singles = [est.update(e[j], *singles[j]) for j in range(3)]
    for j in range(3):
        np.testing.assert_array_equal(step_b[j], singles[j][0])
        np.testing.assert_array_equal(slope_b[j], singles[j][1])


# --- the unconstrained loop ---------------------------------------------------------------------


def _mismatched(model):
    gain = np.array([[20.0, -10.0, 0.0], [15.0, 0.0, -10.0]])
    return model.with_mismatch(Mismatch(gain, np.array([[0, 0, 0], [10, 0, -8.0]]), np.array([[1, 0, 0], [0, 0, 1]])))


def test_closed_loop_matrix_steps_like_the_controller_and_plant():
    model = level_and_temperature()
    plant_model = _mismatched(model)
    mpc = LinearMpc(model, tuning(2, 3, u_min=-1e6 * np.ones(3), u_max=1e6 * np.ones(3), du_max=1e6 * np.ones(3)))
    plant = FoptdPlant(plant_model, 0.0, seed=0)
    M = closed_loop_matrix(mpc, plant_model)

    def state():  # s = [x_plant; x_model; u_prev; d_int; p_int]
        step, slope = mpc.disturbance
        return np.concatenate([plant._x, mpc._x, mpc._u_prev, step[[0]], slope])

    for k in range(60):
        s = state()
        plant.advance(mpc.step(plant.measure(), np.zeros(2)), disturbance=[0.3, -0.1, 0.2] if k < 5 else None)
        if k >= 5:  # the loop is autonomous once the load pulse is over
            np.testing.assert_allclose(state(), M @ s, atol=1e-12)
    assert np.abs(state()).max() > 1e-3  # there was something to follow


def test_neutral_modes_are_invariant_and_the_rest_is_stable():
    model = level_and_temperature()
    mpc = LinearMpc(model, tuning(2, 3))
    for plant in (model, _mismatched(model)):
        M, V = closed_loop_matrix(mpc, plant), neutral_modes(mpc, plant)
        assert V.shape[1] == 3  # two controller-model integrators, one pair of plant integrators on the level
        np.testing.assert_allclose(M @ V, V, atol=1e-14)
        assert np.abs(np.linalg.eigvals(M)).max() == pytest.approx(1.0)  # what the neutral modes hide
        assert loop_spectral_radius(mpc, plant) < 0.99
    aggressive = LinearMpc(model, tuning(2, 3, move_weight=1e-4 * np.ones(3), prediction_horizon=8, control_horizon=8))
    assert (
        loop_spectral_radius(
            aggressive,
            model.with_mismatch(Mismatch(np.full((2, 3), 60.0), np.zeros((2, 3)), np.array([[3, 3, 0], [3, 0, 3]]))),
        )
        > 1.0
    )
