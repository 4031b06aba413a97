"""The prediction-error peer (pmr_ros.peers.pem): exact noise-free, closed-loop recovery, OE bias under drift."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pmr_ros.config import load_config
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import Mismatch, TransferMatrix
from pmr_ros.peers import Tolerances, pem_diagnosis

NAMES = ("G11", "G12", "G21", "G22")


def _truth(config):
    m = config.mismatch
    return m.gain_pct.ravel(), m.time_constant_pct.ravel(), m.delay_samples.ravel()


def _prbs(samples: int, inputs: int, seed: int) -> np.ndarray:
    """Random +/-1 steps held 10 samples: an open-loop test input."""
    rng = np.random.default_rng(seed)
    return np.repeat(rng.choice([-1.0, 1.0], size=(samples // 10 + 1, inputs)), 10, axis=0)[:samples]


@pytest.mark.parametrize("noise_model", ["output_error", "box_jenkins"])
def test_noise_free_foptd_rows_are_recovered_exactly(noise_model):
    config = load_config()
    plant = config.plant("full")  # the paper's mismatch: dK, dtau and dD on every element
    u = _prbs(2000, 2, seed=3)
    y = plant.element_outputs(u).sum(axis=2)  # starts at steady state for u[0], as the fit assumes
    out = pem_diagnosis(u, y, model=config.model, noise_model=noise_model, max_delay_shift=3, start=0)
    gain, tau, delay = _truth(config)
    assert_allclose([out[n].gain_pct for n in NAMES], gain, rtol=1e-6)
    assert_allclose([out[n].tau_pct for n in NAMES], tau, rtol=1e-6)
    assert [out[n].delay_samples for n in NAMES] == delay.tolist()
    assert [out[n].verdict for n in NAMES] == ["mismatch"] * 4


def test_integrating_element_and_empty_cell():
    """A row of a FOPTD, an integrating element (pole fixed at 1, K per time unit) and an empty cell, noise-free."""
    model = TransferMatrix(
        gain=[[2.0, 0.05, 0.0]],
        time_constant=[[8.0, np.nan, np.nan]],
        delay=[[2.0, 1.0, 0.0]],
        sample_time=1.0,
        element_type=np.array([["foptd", "integrating", "none"]], dtype=object),
    )
    injected = Mismatch(np.array([[20.0, -10.0, 0.0]]), np.array([[-15.0, 0.0, 0.0]]), np.array([[1, 2, 0]]))
    u = _prbs(2000, 3, seed=5)
    u[:, 1] -= u[:, 1].mean()  # no net drift of the integrated input
    y = model.with_mismatch(injected).element_outputs(u).sum(axis=2)
    out = pem_diagnosis(u, y, model=model, max_delay_shift=3, start=0)
    assert_allclose([out["G11"].gain_pct, out["G11"].tau_pct, out["G12"].gain_pct], [20.0, -15.0, -10.0], rtol=1e-6)
    assert (out["G11"].delay_samples, out["G12"].delay_samples) == (1, 2)
    assert out["G12"].tau_pct is None and out["G12"].tau_verdict is None
    assert out["G13"].verdict == "inconclusive" and out["G13"].gain_pct is None


def test_unknown_noise_model_and_bad_shapes_are_refused():
    config = load_config()
    u = np.zeros((100, 2))
    with pytest.raises(ValueError, match="noise_model"):
        pem_diagnosis(u, u, model=config.model, noise_model="arx")
    with pytest.raises(ValueError, match="do not fit"):
        pem_diagnosis(u, np.zeros((100, 3)), model=config.model)


@pytest.fixture(scope="module")
def white_noise_run():
    config = load_config(overrides={"run": {"samples": 16384, "scenario": "full"}})
    return config, simulate(config)


@pytest.mark.parametrize("noise_model", ["output_error", "box_jenkins"])
def test_closed_loop_white_noise_gains_within_a_point(white_noise_run, noise_model):
    config, record = white_noise_run
    tolerances = Tolerances.from_settings(config.parametric)
    out = pem_diagnosis(
        record.u, record.y, model=config.model, noise_model=noise_model, tolerances=tolerances, max_delay_shift=3
    )
    gain, tau, delay = _truth(config)
    assert_allclose([out[n].gain_pct for n in NAMES], gain, atol=1.0)  # percentage points
    assert_allclose([out[n].tau_pct for n in NAMES], tau, atol=3.0)
    assert [out[n].delay_samples for n in NAMES] == delay.tolist()
    assert [out[n].verdict for n in NAMES] == ["mismatch"] * 4
    for n in NAMES:
        low, high = out[n].gain_interval
        assert low < high and high - low < 4.0  # a real interval, a couple of points wide at 16,384 samples
        assert out[n].detected and out[n].score > 10.0


def test_coloured_disturbance_biases_output_error_not_box_jenkins():
    """A drift (pole 0.97, std 0.3) the MPC feeds back into u: OE is far off, BJ's intervals hold the truth.

    Delays searched over +/-3 samples (the truth lies within +/-2) to keep the test short.
    """
    config = load_config(
        overrides={
            "run": {"samples": 16384, "scenario": "full"},
            "noise": {"disturbance_std": [0.3, 0.3], "disturbance_pole": 0.97},
        }
    )
    record = simulate(config)
    gain = _truth(config)[0]
    oe = pem_diagnosis(record.u, record.y, model=config.model, noise_model="output_error", max_delay_shift=3)
    bj = pem_diagnosis(record.u, record.y, model=config.model, noise_model="box_jenkins", max_delay_shift=3)
    oe_error = np.abs([oe[n].gain_pct - g for n, g in zip(NAMES, gain, strict=True)])
    bj_error = np.abs([bj[n].gain_pct - g for n, g in zip(NAMES, gain, strict=True)])
    assert np.median(oe_error) > 10.0  # measured 17 pp (seed 1)
    assert np.median(bj_error) < 3.0  # measured 1.9 pp
    for n, true in zip(NAMES, gain, strict=True):
        low, high = bj[n].gain_interval
        assert low <= true <= high
