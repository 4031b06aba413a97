"""Measured disturbances: the plant [G, Gd] moved by them, the MPC's feedforward, the record's DVs."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from pmr_ros.config import load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.augment import augmented_model
from pmr_ros.core.sim.batch import run_lockstep
from pmr_ros.core.sim.closed_loop import routine_features, simulate
from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.core.sim.true_plant import FoptdPlant

DVS = {
    "disturbance_names": ["feed_rate", "feed_light"],
    "disturbance_gain": [3.8, 1.5, 4.9, -2.0],
    "disturbance_time_constant": [14.9, 10.0, 13.2, 12.0],
    "disturbance_delay": [8.0, 2.0, 3.0, 4.0],
}


@pytest.fixture(scope="module")
def with_dvs():
    return load_config(
        overrides={
            "system": DVS,
            "disturbance_signal": {"kind": ["steps", "walk"], "amplitude": [0.5, 0.3], "mean_interval_samples": 200.0},
        }
    )


def _ise_after_dv_step(config, *, feedforward: bool) -> float:
    """Squared output error of the loop at constant setpoints after a unit step of the first DV (noise-free)."""
    plant = FoptdPlant(augmented_model(config.plant("none"), config.disturbance_plant("none")), 0.0, 1)
    mpc = LinearMpc(config.model, config.mpc, disturbance_model=config.disturbance_model if feedforward else None)
    ise = 0.0
    for k in range(400):
        v = np.array([1.0 if k >= 20 else 0.0, 0.0])
        y = plant.measure()
        ise += float(y @ y)
        u = mpc.step(y, np.zeros(2), disturbance=v if feedforward else None)
        plant.advance(np.concatenate((u, v)))
    return ise


def test_feedforward_rejects_a_measured_disturbance_step_much_better(with_dvs):
    with_ff = _ise_after_dv_step(with_dvs, feedforward=True)
    without = _ise_after_dv_step(with_dvs, feedforward=False)
    assert without > 0 and with_ff < 0.05 * without, (with_ff, without)  # measured: 0.0018


def _scipy_element(gain: float, tau: float, delay: int, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH discretization of K e^(-theta s) / (tau s + 1) by scipy, with the dead time as z^-delay."""
    num, den, _ = scipy.signal.cont2discrete(([gain], [tau, 1.0]), ts, method="zoh")
    return np.concatenate((np.zeros(delay), np.ravel(num))), np.ravel(den)


def _scipy_outputs(model: TransferMatrix, inputs: np.ndarray) -> np.ndarray:
    """Each output of ``model`` driven by ``inputs`` (N, n_in) from rest, by scipy.signal.lfilter."""
    y = np.zeros((inputs.shape[0], model.n_outputs))
    for i in range(model.n_outputs):
        for k in range(model.n_inputs):
            b, a = _scipy_element(model.gain[i, k], model.time_constant[i, k], model.delay_samples[i, k], 1.0)
            y[:, i] += scipy.signal.lfilter(b, a, inputs[:, k])
    return y


def test_the_prediction_with_measured_disturbances_is_scipys_simulation_of_g_and_gd(with_dvs):
    mpc = LinearMpc(with_dvs.model, with_dvs.mpc, disturbance_model=with_dvs.disturbance_model)
    rng = np.random.default_rng(5)
    applied, dvs = [], []
    for _ in range(30):
        v = rng.normal(size=2)
        applied.append(mpc.step(rng.normal(size=2), rng.normal(size=2), disturbance=v))
        dvs.append(v)
    v_now = rng.normal(size=2)
    predicted = mpc.prediction(v_now)
    horizon = with_dvs.mpc.prediction_horizon
    held = np.tile(np.concatenate((applied[-1], v_now)), (horizon, 1))  # the input held, the DV at its value now
    history = np.hstack([np.array(applied), np.array(dvs)])
    whole = augmented_model(with_dvs.model, with_dvs.disturbance_model)
    expected = _scipy_outputs(whole, np.vstack([history, held, np.zeros((1, 4))]))[31 : 31 + horizon]
    np.testing.assert_allclose(predicted, expected, rtol=0, atol=1e-9)
    dv_only = mpc.prediction(v_now) - mpc.prediction(np.zeros(2))
    gd_step = _scipy_outputs(with_dvs.disturbance_model, np.tile(v_now, (horizon + 1, 1)))[1:]
    np.testing.assert_allclose(dv_only, gd_step, rtol=0, atol=1e-9)


def test_a_controller_with_a_dv_model_needs_the_measured_dvs(with_dvs):
    mpc = LinearMpc(with_dvs.model, with_dvs.mpc, disturbance_model=with_dvs.disturbance_model)
    with pytest.raises(ValueError, match="2 measured disturbances"):
        mpc.step(np.zeros(2), np.zeros(2))


def test_simulate_moves_the_plant_with_the_dvs_and_records_them(with_dvs):
    record = simulate(with_dvs, samples=600)
    expected = with_dvs.disturbance_signal.generator(with_dvs.run.seed).sequence(600)
    assert record.dv is not None and record.manual is None
    np.testing.assert_array_equal(record.dv, expected)
    assert np.ptp(record.dv[:, 0]) > 0 and np.std(record.dv[:, 1]) > 0.1
    # the same run without the DVs moving differs: they reach the plant
    still = load_config(overrides={"system": DVS, "disturbance_signal": {"amplitude": 0.0}})
    calm = simulate(still, samples=600)
    np.testing.assert_array_equal(calm.dv, 0.0)
    assert np.max(np.abs(calm.y - record.y)) > 0.1


def test_the_lockstep_batch_runs_routine_configurations_as_simulate_does(with_dvs):
    assert routine_features(with_dvs) == ["measured disturbances"]
    result = run_lockstep(with_dvs, [("full", 1), ("none", 2)], samples=300)
    for (scenario, seed), record in zip([("full", 1), ("none", 2)], result.records, strict=True):
        alone = simulate(with_dvs, samples=300, seed=seed, scenario=scenario)
        np.testing.assert_allclose(record.y, alone.y, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(record.dv, alone.dv)
    assert result.statistics[0].steps == 300


def test_the_loop_matrix_of_a_feedforward_controller_is_the_plain_ones(with_dvs):
    from pmr_ros.core.mpc.stability import closed_loop_matrix, loop_spectral_radius

    plain = LinearMpc(with_dvs.model, with_dvs.mpc)
    fed = LinearMpc(with_dvs.model, with_dvs.mpc, disturbance_model=with_dvs.disturbance_model)
    plant = with_dvs.plant()
    # the DVs are external inputs: with them at zero the loop is the plain controller's on the G part of the model
    radius = loop_spectral_radius(fed, plant)
    np.testing.assert_allclose(radius, loop_spectral_radius(plain, plant), rtol=1e-9)
    assert closed_loop_matrix(fed, plant).shape[0] > closed_loop_matrix(plain, plant).shape[0]  # the DV states
