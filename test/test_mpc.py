"""The constrained MPC: limits held, offset-free tracking, the QP shortcut is exact."""

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.core.mpc import LinearMpc
from pmr_ros.core.plant import FoptdPlant


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


def test_unconstrained_shortcut_equals_the_osqp_solution(wood_berry):
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
