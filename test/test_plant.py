"""The plant simulator: closed-form step response, seeded noise."""

import numpy as np

from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.core.sim.true_plant import (
    DisturbanceStream,
    FoptdPlant,
    OutputDisturbance,
    disturbance_generator,
    noise_generator,
)


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


def test_the_output_disturbance_is_a_stationary_ar1_of_the_given_std_and_pole():
    settings = OutputDisturbance(np.array([0.3, 0.0, 1.0]), 0.97)
    d = DisturbanceStream(settings, 3, seed=7).sequence(200_000)
    # stationary from the first sample: std 0.3 and 1.0 (standard error of a std over ~3,000 independent
    # stretches of 33 samples: about 1.3 %), lag-k autocorrelation 0.97^k
    np.testing.assert_allclose(d[:, [0, 2]].std(axis=0), [0.3, 1.0], rtol=0.05)
    assert np.all(d[:, 1] == 0.0)
    for lag in (1, 10, 33):
        np.testing.assert_allclose(np.corrcoef(d[lag:, 0], d[:-lag, 0])[0, 1], 0.97**lag, atol=0.03)
    starts = np.array([DisturbanceStream(settings, 3, seed=s).draw()[0] for s in range(2000)])
    np.testing.assert_allclose(starts.std(), 0.3, rtol=0.05)  # d(0) already has the stationary spread
    # sequence() is draw() called that often, from the run's own stream
    one = DisturbanceStream(settings, 3, seed=7)
    np.testing.assert_array_equal(np.array([one.draw() for _ in range(50)]), d[:50])
    np.testing.assert_array_equal(d[0], 0.3 * disturbance_generator(7).standard_normal(3) * [1, 0, 1 / 0.3])
    white = DisturbanceStream(OutputDisturbance(np.array([0.5]), 0.0), 1, seed=1).sequence(20_000)
    assert abs(np.corrcoef(white[1:, 0], white[:-1, 0])[0, 1]) < 0.03 and OutputDisturbance.off(2).active is False


def test_a_plant_with_a_disturbance_adds_it_to_the_measurement_and_keeps_the_noise_stream(wood_berry):
    settings = OutputDisturbance(np.array([0.3, 0.2]), 0.9)
    plain = FoptdPlant(wood_berry.model, noise_std=0.1, seed=3)
    disturbed = FoptdPlant(wood_berry.model, noise_std=0.1, seed=3, disturbance=settings)
    off = FoptdPlant(wood_berry.model, noise_std=0.1, seed=3, disturbance=OutputDisturbance.off(2))
    stream = DisturbanceStream(settings, 2, seed=3)
    for k in range(30):
        y, y_dist, y_off = plain.measure(), disturbed.measure(), off.measure()
        np.testing.assert_array_equal(y_off, y)  # off: bit for bit the plant without the option
        np.testing.assert_allclose(y_dist - y, stream.draw(), rtol=0, atol=1e-15)
        for plant in (plain, disturbed, off):
            plant.advance([np.sin(k), 1.0])
