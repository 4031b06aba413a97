"""Delay estimation: Hilbert transform of log |G| and the Hamon-Hannan search."""

import numpy as np
import pytest

from pmr_ros.core.pmr.delay import hamon_hannan_delay, informative_band, minimum_phase

OMEGA = np.linspace(0, np.pi, 257)
Z1 = np.exp(-1j * OMEGA)


def _fopdt_ratio(gain_ratio, tau_plant, tau_model):
    a, ah = np.exp(-1 / tau_plant), np.exp(-1 / tau_model)
    return gain_ratio * (1 - a) / (1 - ah) * (1 - ah * Z1) / (1 - a * Z1)


@pytest.mark.parametrize("tau_plant,tau_model", [(18.37, 16.7), (9.265, 10.9), (3.0, 5.0), (1.0, 2.0)])
def test_minimum_phase_of_a_fopdt_ratio(tau_plant, tau_model):
    G = _fopdt_ratio(1.1, tau_plant, tau_model)
    phase = minimum_phase(OMEGA, np.log(np.abs(G)))
    np.testing.assert_allclose(phase, np.angle(G), atol=1e-6)


@pytest.mark.parametrize("delay", [-4, -1, 0, 1, 2, 7])
def test_hamon_hannan_finds_the_delay(delay):
    G = _fopdt_ratio(0.85, 9.265, 10.9) * Z1**delay
    found, cost = hamon_hannan_delay(OMEGA, G, np.full(OMEGA.size, 0.9), 10)
    assert found == delay
    assert cost.shape == (21,) and np.argmax(cost) == delay + 10


def test_noise_beyond_the_band_does_not_bias_the_delay():
    rng = np.random.default_rng(3)
    G = _fopdt_ratio(1.0, 14.4, 14.4) * Z1**2
    coherence = np.where(OMEGA < 0.6, 0.95, 0.05)
    noisy = G * np.where(OMEGA < 0.6, 1.0, np.exp(rng.normal(0, 1.5, OMEGA.size)))
    band = informative_band(OMEGA, coherence, 0.5)
    assert band[1] and not band[0] and not band[OMEGA >= 0.6].any()
    assert hamon_hannan_delay(OMEGA, noisy, coherence, 10, band)[0] == 2


def test_informative_band_stops_at_the_first_drop():
    coherence = np.array([1.0, 0.9, 0.8, 0.3, 0.9, 0.9])
    omega = np.linspace(0, np.pi, 6)
    np.testing.assert_array_equal(informative_band(omega, coherence, 0.5), [False, True, True, False, False, False])
