"""The constrained MPC: limits held, offset-free tracking, the QP shortcut is exact."""

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.true_plant import FoptdPlant


def _loop(model, plant_model, tuning, setpoints, noise=0.0, **mpc_kw):
    plant = FoptdPlant(plant_model, noise, seed=0)
    mpc = LinearMpc(model, tuning, **mpc_kw)
    ys, us = [], []
    for r in setpoints:
        y = plant.measure()
        u = mpc.step(y, r)
        plant.advance(u)
        ys.append(plant.output() * 0 + y)
        us.append(u)
    return np.array(ys), np.array(us), mpc


def test_tracks_a_step_without_offset_when_model_equals_plant(wood_berry):
    r = np.tile([1.0, -0.5], (400, 1))
    y, _, mpc = _loop(wood_berry.model, wood_berry.model, wood_berry.mpc, r)
    np.testing.assert_allclose(y[-50:], r[-50:], atol=1e-6)
    assert mpc.statistics.failures == 0


def test_tracks_without_offset_under_mismatch_thanks_to_the_bias(wood_berry):
    r = np.tile([0.5, 0.5], (600, 1))
    y, _, _ = _loop(wood_berry.model, wood_berry.plant("full"), wood_berry.mpc, r)
    np.testing.assert_allclose(y[-50:], r[-50:], atol=1e-4)


def test_input_magnitude_and_rate_limits_hold(wood_berry):
    tight = replace(
        wood_berry.mpc, u_min=np.array([-0.3, -0.2]), u_max=np.array([0.3, 0.2]), du_max=np.array([0.05, 0.04])
    )
    r = np.zeros((300, 2))
    r[20:150] = [3.0, -3.0]  # far beyond what the limits allow
    r[150:] = [-3.0, 3.0]
    _, u, mpc = _loop(wood_berry.model, wood_berry.plant("full"), tight, r, noise=0.1)
    du = np.diff(np.vstack([np.zeros(2), u]), axis=0)
    assert np.all(u >= tight.u_min - 1e-9) and np.all(u <= tight.u_max + 1e-9)
    assert np.all(np.abs(du) <= tight.du_max + 1e-9)
    assert np.isclose(u[:, 0].max(), 0.3) and np.isclose(u[:, 1].max(), 0.2)  # limits reached, so they bound
    assert mpc.statistics.solves > 0 and mpc.statistics.failures == 0


def test_unconstrained_shortcut_equals_the_qp_solution(wood_berry):
    rng = np.random.default_rng(1)
    fast = LinearMpc(wood_berry.model, wood_berry.mpc)
    qp = LinearMpc(wood_berry.model, wood_berry.mpc, always_solve_qp=True, record_solve_times=True)
    for _ in range(40):
        y, r = rng.normal(0, 0.1, 2), rng.normal(0, 0.1, 2)
        u_fast, u_qp = fast.step(y, r), qp.step(y, r)
        np.testing.assert_allclose(u_fast, u_qp, atol=1e-5)
    assert fast.statistics.solves == 0 and qp.statistics.solves == 40
    assert len(qp.statistics.solve_time_s) == 40 and fast.statistics.steps == 40


def test_model_output_and_reset(wood_berry):
    mpc = LinearMpc(wood_berry.model, wood_berry.mpc)
    for _ in range(10):
        mpc.step([0.0, 0.0], [1.0, 1.0])
    assert np.any(mpc.model_output != 0)
    mpc.reset()
    np.testing.assert_array_equal(mpc.model_output, [0.0, 0.0])


def test_control_horizon_longer_than_prediction_is_refused(wood_berry):
    with pytest.raises(ValueError, match="control_horizon"):
        LinearMpc(wood_berry.model, replace(wood_berry.mpc, control_horizon=50, prediction_horizon=40))


# --- industrial shapes: extra MVs, integrating CVs, empty cells, more CVs than MVs ----------------

from pmr_ros.core.mpc.controller import MpcTuning  # noqa: E402
from pmr_ros.core.mpc.design import steady_state_gain  # noqa: E402
from pmr_ros.core.sim.model import TransferMatrix  # noqa: E402


def _level_and_temperature():
    """2x3: y1 a level (integrating in u1 and u2), y2 a temperature (FOPTD in u1 and u3); two empty cells."""
    kinds = [["integrating", "integrating", "none"], ["foptd", "none", "foptd"]]
    return TransferMatrix(
        [[-0.05, 0.03, 0.0], [0.8, 0.0, 1.5]],
        [[0.0, 0.0, 0.0], [10.0, 0.0, 8.0]],
        [[1.0, 2.0, 0.0], [2.0, 0.0, 1.0]],
        1.0,
        element_type=kinds,
    )


def _tuning(n_out, n_in, *, output_weight=1.0, input_target=0.0, input_target_weight=1.0, ramp_filter=10.0):
    ones_out, ones_in = np.ones(n_out), np.ones(n_in)
    return MpcTuning(
        prediction_horizon=40,
        control_horizon=8,
        output_weight=output_weight * ones_out,
        move_weight=ones_in,
        u_min=-5.0 * ones_in,
        u_max=5.0 * ones_in,
        du_max=0.5 * ones_in,
        input_target=input_target * ones_in,
        input_target_weight=input_target_weight * ones_in,
        ramp_filter_samples=ramp_filter,
    )


def _run(model, tuning, setpoints, *, plant=None, load=None, noise=0.0):
    """Closed loop with an optional unmeasured input disturbance ``load`` (rows: samples)."""
    plant_sim = FoptdPlant(plant or model, noise, seed=3)
    mpc = LinearMpc(model, tuning)
    ys, us = [], []
    for k, r in enumerate(setpoints):
        y = plant_sim.measure()
        u = mpc.step(y, r)
        plant_sim.advance(u, disturbance=None if load is None else load[k])
        ys.append(y)
        us.append(u)
    return np.array(ys), np.array(us), mpc


def _nearest_steady_input(model, targets, *, load, input_target, weight):
    """Closed form: the S-nearest input to its target among those that hold the steady state.

    Stable rows settle at ``targets``, integrating rows' rates at 0, with the plant seeing ``u + load``:
    ``min (u - ut)' S (u - ut)  s.t.  G (u + load) = b`` gives
    ``u = ut + S^-1 G' (G S^-1 G')^-1 (b - G (ut + load))``.
    """
    G = steady_state_gain(model)
    b = np.where(model.integrating_outputs, 0.0, targets)
    s_inv = np.diag(1.0 / weight)
    return input_target + s_inv @ G.T @ np.linalg.solve(G @ s_inv @ G.T, b - G @ (input_target + load))


def test_extra_mv_and_integrating_cv_track_steps_without_offset():
    model = _level_and_temperature()
    r = np.tile([1.0, 0.5], (2500, 1))
    r[:50] = 0.0
    y, u, mpc = _run(model, _tuning(2, 3), r)
    np.testing.assert_allclose(y[-500:], r[-500:], atol=1e-8)  # level and temperature at their setpoints
    expected = _nearest_steady_input(model, r[-1], load=np.zeros(3), input_target=np.zeros(3), weight=np.ones(3))
    np.testing.assert_allclose(u[-500:], np.broadcast_to(expected, (500, 3)), atol=1e-8)  # rests, does not wander
    assert mpc.statistics.failures == 0


def test_an_unmeasured_load_on_the_integrating_cv_leaves_no_offset_and_no_ramp():
    model = _level_and_temperature()
    n = 4000
    r = np.tile([1.0, 0.5], (n, 1))
    load = np.zeros((n, 3))
    load[1500:, 0] = 0.4  # u1 drains the level (and heats y2): a constant unmeasured extra opening
    y, u, mpc = _run(model, _tuning(2, 3), r, load=load)
    assert np.max(np.abs(y[1500:1600] - r[1500:1600])) > 0.05  # the load did upset the loop
    np.testing.assert_allclose(y[-800:], r[-800:], atol=1e-8)
    step, slope = mpc.disturbance
    np.testing.assert_allclose(slope, [-0.05 * 0.4], rtol=1e-6)  # the level's ramp (K11 d1 Ts), found and cancelled
    expected = _nearest_steady_input(model, r[-1], load=load[-1], input_target=np.zeros(3), weight=np.ones(3))
    np.testing.assert_allclose(u[-800:], np.broadcast_to(expected, (800, 3)), atol=1e-8)


def test_extra_freedom_goes_to_the_input_targets_by_their_weights():
    model = _level_and_temperature()
    r = np.tile([-0.5, 1.0], (3000, 1))
    target, weight = np.array([0.3, -0.2, 0.4]), np.array([1.0, 4.0, 0.5])
    tuning = _tuning(2, 3, input_target=0.0)
    tuning = replace(tuning, input_target=target, input_target_weight=weight)
    y, u, _ = _run(model, tuning, r)
    np.testing.assert_allclose(y[-300:], r[-300:], atol=1e-8)
    expected = _nearest_steady_input(model, r[-1], load=np.zeros(3), input_target=target, weight=weight)
    np.testing.assert_allclose(u[-1], expected, atol=1e-8)
    plain = _nearest_steady_input(model, r[-1], load=np.zeros(3), input_target=np.zeros(3), weight=np.ones(3))
    assert np.max(np.abs(expected - plain)) > 0.05  # the targets did move the resting point


def test_input_targets_do_not_change_a_square_controller(wood_berry):
    shifted = replace(wood_berry.mpc, input_target=np.array([1.0, -1.0]), input_target_weight=np.array([5.0, 0.1]))
    r = np.tile([1.0, -0.5], (300, 1))
    y_plain, u_plain, _ = _loop(wood_berry.model, wood_berry.plant("full"), wood_berry.mpc, r)
    y_shift, u_shift, _ = _loop(wood_berry.model, wood_berry.plant("full"), shifted, r)
    np.testing.assert_array_equal(u_shift, u_plain)  # no freedom left: the targets have nothing to act on
    assert not np.any(LinearMpc(wood_berry.model, shifted).matrices.gain_offset)


def _three_by_two():
    """3x2 with an empty cell: three stable CVs, two MVs -- not every setpoint can be met."""
    kinds = [["foptd", "foptd"], ["foptd", "none"], ["foptd", "foptd"]]
    return TransferMatrix(
        [[1.0, 0.5], [0.7, 0.0], [-0.4, 1.2]],
        [[8.0, 12.0], [10.0, 0.0], [6.0, 9.0]],
        [[1, 2], [3, 0], [1, 1]],
        1.0,
        element_type=kinds,
    )


def test_more_cvs_than_mvs_settle_at_the_weighted_least_squares_compromise():
    model = _three_by_two()
    q = np.array([1.0, 4.0, 0.5])
    n = 3000
    r = np.tile([1.0, 0.2, -0.5], (n, 1))
    load = np.zeros((n, 2))
    load[1500:] = [0.3, -0.2]
    y, u, _ = _run(model, replace(_tuning(3, 2), output_weight=q), r, load=load)
    G = model.gain
    for span, d in ((slice(1200, 1500), np.zeros(2)), (slice(-300, None), load[-1])):
        # the plant sees u + d; the controller's best u minimises sum q (G (u + d) - r)^2: u + d is the fit
        best = np.linalg.lstsq(np.sqrt(q)[:, None] * G, np.sqrt(q) * r[-1], rcond=None)[0]
        np.testing.assert_allclose(u[span], np.broadcast_to(best - d, (300, 2)), atol=1e-7)
        np.testing.assert_allclose(y[span], np.broadcast_to(G @ best, (300, 3)), atol=1e-7)
    assert np.max(np.abs(G @ best - r[-1])) > 0.1  # a real compromise, not a met setpoint


def test_a_tall_system_with_a_level_holds_the_level_first():
    kinds = [["foptd", "foptd"], ["foptd", "none"], ["integrating", "foptd"]]
    model = TransferMatrix(
        [[1.0, 0.5], [0.7, 0.0], [0.2, 0.6]],
        [[8.0, 12.0], [10.0, 0.0], [0.0, 6.0]],
        [[1, 2], [3, 0], [1, 1]],
        1.0,
        element_type=kinds,
    )
    r = np.tile([1.0, 0.2, -0.5], (3000, 1))
    y, u, _ = _run(model, _tuning(3, 2), r)
    # the level's rate 0.2 u1 must vanish: u1 = 0; then y2 = 0 and u2 fits y1 alone: 0.5 u2 = 1
    np.testing.assert_allclose(u[-300:], np.broadcast_to([0.0, 2.0], (300, 2)), atol=1e-6)
    np.testing.assert_allclose(y[-300:], np.broadcast_to([1.0, 0.0, -0.5], (300, 3)), atol=1e-6)


def test_limit_helpers_work_alike_on_one_run_and_a_batch(wood_berry):
    mpc = LinearMpc(wood_berry.model, wood_berry.mpc)  # |u| <= 2, |du| <= 0.5, Nc = 8
    Nc = wood_berry.mpc.control_horizon
    small = np.full(2 * Nc, 0.1)  # eight moves of 0.1: the path reaches 0.8
    too_fast = small.copy()
    too_fast[0] = 0.6  # one move beyond du_max
    too_far = np.full(2 * Nc, 0.3)  # the path reaches 2.4 > u_max
    u_prev = np.array([0.0, 0.0])
    batch = mpc.within_limits(np.stack([small, too_fast, too_far]), np.zeros((3, 2)))
    assert batch.tolist() == [True, False, False]
    assert [bool(mpc.within_limits(m, u_prev)) for m in (small, too_fast, too_far)] == batch.tolist()
    assert bool(mpc.within_limits(small, np.array([1.5, 0.0]))) is False  # 1.5 + 0.8 > 2
    lower, upper = mpc.move_bounds(np.array([1.5, -1.0]))
    np.testing.assert_allclose(lower[:2], [-3.5, -1.0])
    np.testing.assert_allclose(upper[:2], [0.5, 3.0])
    np.testing.assert_allclose(lower[2 * Nc :], -0.5)
    np.testing.assert_allclose(upper[2 * Nc :], 0.5)
    u, applied = mpc.apply_move(np.array([1.8, 0.0]), np.array([0.9, -0.2]), np.array([0.1, 0.3]))
    np.testing.assert_allclose(u, [2.0, -0.2])  # the move is cut to 0.5, then the input to 2
    np.testing.assert_allclose(applied, [2.0, 0.1])  # the dither too stays within the limits
