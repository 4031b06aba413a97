"""The FIR start of the prediction-error peer (pmr_ros.peers.pem_start) and the fit it rescues.

Routine-operation data (rare setpoint steps, both MVs moving together) and a model
whose delay is 2 samples short: started from the model alone, the coordinate-wise
delay search ended in a local minimum (G21's delay -3, G22's 0, dK several points
off, as on run 1145 of the scenario file); started from the better of the model and the FIR
estimate, it finds the injected delays and gains.
"""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from pmr_ros.config import load_config
from pmr_ros.core.sim.model import Mismatch
from pmr_ros.peers import pem_diagnosis
from pmr_ros.peers.pem_start import delay_candidates, fir_start, impulse_responses

INJECTED = Mismatch(np.array([[0.0, 0.0], [0.0, 7.3]]), np.array([[0.0, 0.0], [0.0, 9.4]]), np.array([[0, 0], [0, 2]]))
"""x_B's row of Wood-Berry: G22 2 samples slower, +7.3 % gain, +9.4 % time constant; G21 right."""


def _routine_inputs(samples: int, seed: int) -> np.ndarray:
    """Rare steps on reflux, steam following at half of them plus a small +/-0.02 dither."""
    rng = np.random.default_rng(seed)
    steps = np.repeat(rng.uniform(-1.0, 1.0, size=samples // 200 + 1), 200)[:samples]
    dither = 0.02 * np.repeat(rng.choice([-1.0, 1.0], size=samples // 5 + 1), 5)[:samples]
    return np.column_stack([steps, 0.5 * steps + dither])


def _record(seed: int, samples: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    model = load_config().model
    u = _routine_inputs(samples, seed)
    noise = 0.01 * np.random.default_rng(seed + 100).standard_normal((samples, 2))
    return u, model.with_mismatch(INJECTED).element_outputs(u).sum(axis=2) + noise


def test_collinear_routine_inputs_and_a_short_model_delay_still_give_the_injected_row():
    model = load_config().model
    u, y = _record(seed=0)
    out = pem_diagnosis(u, y, model=model, max_delay_shift=10, start=0)
    assert (out["G21"].delay_samples, out["G22"].delay_samples) == (0, 2)
    assert_allclose([out["G21"].gain_pct, out["G22"].gain_pct], [0.0, 7.3], atol=0.5)  # pp
    assert_allclose(out["G22"].tau_pct, 9.4, atol=1.0)  # pp
    assert (out["G21"].verdict, out["G22"].verdict) == ("ok", "mismatch")


def test_fir_start_finds_the_delays_and_poles_of_a_noise_free_row():
    model = load_config().model
    u, _ = _record(seed=1)
    y = model.with_mismatch(INJECTED).element_outputs(u).sum(axis=2)[:, 1]
    disc = model.discretize()
    start = fir_start(
        y, u - u[0], integrating=np.zeros(2, dtype=bool), start=0, model_delays=model.delay_samples[1],
        model_poles=disc.pole[1], max_shift=10,
    )  # fmt: skip
    assert start is not None
    delays, theta = start
    assert delays.tolist() == [7, 5]
    true_tau = model.time_constant[1] * (1.0 + INJECTED.time_constant_pct[1] / 100.0)
    assert_allclose(-1.0 / np.log(theta[2:4]), true_tau, rtol=0.04)  # the pole grid's spacing is 6 %
    true_gain = model.gain[1] * (1.0 + INJECTED.gain_pct[1] / 100.0)
    # a start, not the fit: the pole grid's error passes into the gains through the collinear inputs
    assert_allclose(theta[:2] / (1.0 - theta[2:4]), true_gain, rtol=0.15)


def test_impulse_responses_recover_a_pulse_and_refuse_a_short_record():
    rng = np.random.default_rng(4)
    u = rng.standard_normal((2000, 2))
    y = 0.7 * np.concatenate(([0.0] * 3, u[:-3, 0])) + np.cumsum(np.concatenate(([0.0] * 2, 0.1 * u[:-2, 1])))
    h = impulse_responses(y, u, integrating=np.array([False, True]), start=0, lags=6)
    assert h is not None
    expected = np.zeros((2, 6))
    expected[0, 2], expected[1, 1] = 0.7, 0.1  # lag 3 of u1; lag 2 of u2, integrated
    assert_allclose(h, expected, atol=1e-9)
    assert impulse_responses(y[:50], u[:50], integrating=np.array([False, True]), start=0, lags=6) is None


def test_delay_candidates_are_the_model_delay_within_the_shift_and_never_negative():
    assert list(delay_candidates(5, 2)) == [3, 4, 5, 6, 7]
    assert list(delay_candidates(1, 3)) == [0, 1, 2, 3, 4]
    assert list(delay_candidates(0, 0)) == [0]
