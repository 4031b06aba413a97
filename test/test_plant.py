"""The plant simulator: closed-form step response, seeded noise."""

import numpy as np

from pmr_ros.core.model import TransferMatrix
from pmr_ros.core.plant import FoptdPlant, noise_generator


def test_noise_free_step_matches_closed_form():
    K, tau, theta = 6.6, 10.9, 7.0
    plant = FoptdPlant(TransferMatrix([[K]], [[tau]], [[theta]], 1.0), noise_std=0.0, seed=0)
    y = []
    for _ in range(60):
        y.append(plant.measure()[0])
        plant.advance([1.0])
    k = np.arange(60)
    # sampled continuous FOPTD step response: y(k) = K (1 - exp(-(k - theta)/tau)) for k >= theta
    expected = np.where(k >= theta, K * (1.0 - np.exp(-(k - theta) / tau)), 0.0)
    np.testing.assert_allclose(y, expected, atol=1e-12)


def test_noise_is_seeded_white_with_the_given_std(wood_berry):
    plant = FoptdPlant(wood_berry.model, noise_std=[0.1, 0.3], seed=5)
    y = np.array([plant.measure() for _ in range(20000)])  # plant at rest: only noise
    np.testing.assert_allclose(y.std(axis=0), [0.1, 0.3], rtol=0.03)
    assert abs(np.corrcoef(y[1:, 0], y[:-1, 0])[0, 1]) < 0.03
    again = FoptdPlant(wood_berry.model, noise_std=[0.1, 0.3], seed=5)
    np.testing.assert_array_equal(again.measure(), y[0])
    np.testing.assert_array_equal(noise_generator(5).standard_normal(2) * [0.1, 0.3], y[0])


def test_output_is_noise_free_and_advance_moves_it(wood_berry):
    plant = FoptdPlant(wood_berry.model, noise_std=1.0, seed=0)
    np.testing.assert_array_equal(plant.output(), [0.0, 0.0])
    plant.advance([1.0, 0.0])
    plant.advance([1.0, 0.0])  # G11 has one sample of dead time plus the ZOH lag
    assert plant.output()[0] > 0.0 and plant.output()[1] == 0.0


def test_an_input_disturbance_acts_as_an_unseen_move_and_ramps_an_integrating_output():
    kinds = [["integrating", "foptd"]]
    model = TransferMatrix([[0.05, 2.0]], [[0.0, 5.0]], [[2.0, 0.0]], 1.0, element_type=kinds)
    loaded = FoptdPlant(model, noise_std=0.0, seed=0)
    moved = FoptdPlant(model, noise_std=0.0, seed=0)
    for _ in range(40):
        loaded.advance([0.0, 0.0], disturbance=[0.4, 0.0])
        moved.advance([0.4, 0.0])
    np.testing.assert_array_equal(loaded.output(), moved.output())
    # a level under a constant load: y(k) = K Ts d (k - 1 - delay) once the delay has passed
    np.testing.assert_allclose(loaded.output(), [0.05 * 0.4 * (40 - 2)], rtol=1e-12)
