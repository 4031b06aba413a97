"""FOPTD matrices: discretization against python-control, realization, mismatch."""

import control
import numpy as np
import pytest

from pmr_ros.core.sim.model import SCENARIOS, Mismatch, TransferMatrix, element_name


def _element(K=12.8, tau=16.7, theta=3.0, ts=1.0):
    return TransferMatrix([[K]], [[tau]], [[theta]], ts)


@pytest.mark.parametrize(
    "K,tau,theta,ts", [(12.8, 16.7, 1.0, 1.0), (-19.4, 14.4, 3.0, 1.0), (6.6, 10.9, 7.0, 1.0), (2.0, 3.0, 1.0, 0.5)]
)
def test_discrete_step_response_matches_python_control(K, tau, theta, ts):
    model = _element(K, tau, theta, ts)
    n = 200
    # python-control: exact ZOH of the delay-free part, then the dead time as whole samples.
    sysd = control.c2d(control.tf([K], [tau, 1.0]), ts, "zoh")
    _, reference = control.step_response(sysd, T=np.arange(n) * ts)
    d = int(round(theta / ts))
    reference = np.concatenate([np.zeros(d), reference[: n - d]])
    ours = model.element_outputs(np.r_[np.zeros(1), np.ones(n - 1)][:, None])[:, 0, 0]
    # element_outputs starts from rest when u[0] = 0; our step starts at sample 1
    np.testing.assert_allclose(ours[1:], reference[:-1], atol=1e-12)
    # and the state-space realization gives the same response
    ss = model.state_space()
    x = np.zeros(ss.A.shape[0])
    y = []
    for _ in range(n):
        y.append((ss.C @ x)[0])
        x = ss.A @ x + ss.B @ np.ones(1)
    np.testing.assert_allclose(y, reference, atol=1e-12)


def test_frequency_response_matches_python_control():
    model = _element(-18.9, 21.0, 3.0)
    sysd = control.c2d(control.tf([-18.9], [21.0, 1.0]), 1.0, "zoh")
    omega = np.linspace(0.01, 3.0, 50)
    ref = sysd(np.exp(1j * omega)) * np.exp(-3j * omega)
    np.testing.assert_allclose(model.discretize().frequency_response(omega)[0, 0], ref, rtol=1e-10)


def test_state_space_of_matrix_matches_elementwise_filters(wood_berry):
    model = wood_berry.model
    rng = np.random.default_rng(0)
    u = rng.standard_normal((300, 2))
    u[0] = 0.0
    ss = model.state_space()
    x = np.zeros(ss.A.shape[0])
    y = np.empty((300, 2))
    for k in range(300):
        y[k] = ss.C @ x
        x = ss.A @ x + ss.B @ u[k]
    np.testing.assert_allclose(y, model.element_outputs(u).sum(axis=2), atol=1e-12)
    # 4 first-order states + shift registers of the largest delay per input (7 and 3)
    assert ss.A.shape == (4 + 7 + 3, 4 + 7 + 3)


def test_with_mismatch_applies_percentages_and_samples(wood_berry):
    plant = wood_berry.plant("full")
    np.testing.assert_allclose(plant.gain, [[12.8 * 1.10, -18.9 * 1.15], [6.6 * 0.85, -19.4 * 0.90]])
    np.testing.assert_allclose(plant.time_constant, [[16.7 * 1.10, 21.0 * 1.12], [10.9 * 0.85, 14.4 * 0.92]])
    np.testing.assert_array_equal(plant.delay_samples, [[1, 4], [9, 3]])


def test_scenarios_keep_only_their_part(wood_berry):
    mm = wood_berry.mismatch
    assert set(SCENARIOS) == {"none", "gain", "time_constant", "delay", "full"}
    none = mm.for_scenario("none")
    assert not none.gain_pct.any() and not none.time_constant_pct.any() and not none.delay_samples.any()
    gain = mm.for_scenario("gain")
    np.testing.assert_array_equal(gain.gain_pct, mm.gain_pct)
    assert not gain.time_constant_pct.any() and not gain.delay_samples.any()
    tau = mm.for_scenario("time_constant")
    np.testing.assert_array_equal(tau.time_constant_pct, mm.time_constant_pct)
    assert not tau.gain_pct.any() and not tau.delay_samples.any()
    delay = mm.for_scenario("delay")
    np.testing.assert_array_equal(delay.delay_samples, mm.delay_samples)
    assert not delay.gain_pct.any() and not delay.time_constant_pct.any()
    np.testing.assert_allclose(mm.for_scenario("full").gain_ratio, [[1.10, 1.15], [0.85, 0.90]])
    with pytest.raises(ValueError, match="unknown scenario"):
        mm.for_scenario("bogus")


def test_zero_mismatch_and_names():
    assert Mismatch.zero(3, 3).gain_pct.shape == (3, 3)
    assert element_name(1, 0, 2) == "G21"
    assert element_name(9, 10, 11) == "G10_11"
    model = TransferMatrix(np.ones((3, 3)), np.ones((3, 3)), np.zeros((3, 3)), 1.0)
    assert model.element_names()[:4] == ["G11", "G12", "G13", "G21"]
    assert model.output_names == ("y1", "y2", "y3")


def test_with_time_constant_replaces_one_element(wood_berry):
    swept = wood_berry.model.with_time_constant(0, 0, 16.7 * 2.5)
    assert swept.time_constant[0, 0] == pytest.approx(41.75)
    assert swept.time_constant[1, 0] == 10.9
    assert wood_berry.model.time_constant[0, 0] == 16.7


def test_settling_samples_and_filter_coefficients(wood_berry):
    model = wood_berry.model
    # 8 x the largest tau (21 min) + the largest delay (7) + 1, in samples
    assert model.settling_samples() == 168 + 7 + 1
    assert model.settling_samples(time_constants=1.0) == 21 + 7 + 1
    b, a = model.discretize().filter_coefficients(1, 0)  # G21: 7 samples dead time + the ZOH's one
    np.testing.assert_array_equal(b[:-1], np.zeros(8))
    assert b[-1] == pytest.approx(6.6 * (1 - np.exp(-1 / 10.9)))
    np.testing.assert_allclose(a, [1.0, -np.exp(-1 / 10.9)])


def _mixed() -> TransferMatrix:
    """A 2x3 model: an integrating row with an empty cell, a FOPTD row with an empty cell."""
    return TransferMatrix(
        gain=[[0.05, 0.0, -0.04], [1.5, 2.0, 0.0]],
        time_constant=[[0.0, 0.0, 0.0], [10.0, 14.0, 0.0]],
        delay=[[2.0, 0.0, 1.0], [3.0, 1.0, 0.0]],
        sample_time=1.0,
        element_type=[["integrating", "none", "integrating"], ["foptd", "foptd", "none"]],
    )


def test_integrating_and_empty_elements_discretize_exactly():
    model = _mixed()
    disc = model.discretize()
    np.testing.assert_array_equal(disc.pole, [[1.0, 0.0, 1.0], [np.exp(-0.1), np.exp(-1 / 14), 0.0]])
    np.testing.assert_allclose(
        disc.numerator, [[0.05, 0.0, -0.04], [1.5 * (1 - np.exp(-0.1)), 2.0 * (1 - np.exp(-1 / 14)), 0.0]]
    )
    # an integrating element is K Ts z^-(1+d) / (1 - z^-1): check against scipy's own discretisation of K/s
    from scipy.signal import cont2discrete

    num, den, _ = cont2discrete(([0.05], [1.0, 0.0]), 1.0, method="zoh")
    omega = np.linspace(0.05, 3.0, 20)
    z = np.exp(1j * omega)
    scipy_response = np.polyval(num.ravel(), z) / np.polyval(den, z) * z**-2.0  # theta = 2 samples
    np.testing.assert_allclose(disc.frequency_response(omega)[0, 0], scipy_response, rtol=1e-12)


def test_state_space_of_a_mixed_model_steps_like_the_difference_equations():
    model = _mixed()
    ss = model.state_space()
    assert ss.A.shape[0] == 4 + 3 + 1 + 1  # four elements there, registers of 3 (u1), 1 (u2) and 1 (u3) samples
    rng = np.random.default_rng(0)
    u = rng.standard_normal((60, 3))
    x = np.zeros(ss.A.shape[0])
    y = []
    for k in range(60):
        y.append(ss.C @ x)
        x = ss.A @ x + ss.B @ u[k]
    y = np.array(y)
    # y1(k) = y1(k-1) + 0.05 u1(k-3) - 0.04 u3(k-2): a ramp CV; the empty cell adds nothing
    expected = np.zeros(60)
    for k in range(1, 60):
        expected[k] = (
            expected[k - 1] + (0.05 * u[k - 3, 0] if k >= 3 else 0.0) - (0.04 * u[k - 2, 2] if k >= 2 else 0.0)
        )
    np.testing.assert_allclose(y[:, 0], expected, atol=1e-12)
    np.testing.assert_allclose(model.element_outputs(u).sum(axis=2)[:, 0], expected, atol=1e-12)
    assert np.all(model.element_outputs(u)[:, 0, 1] == 0.0) and np.all(model.element_outputs(u)[:, 1, 2] == 0.0)


def test_a_mixed_model_reports_its_elements_and_settles_on_its_foptd_ones():
    model = _mixed()
    assert list(model.present.ravel()) == [True, False, True, True, True, False]
    assert list(model.integrating_outputs) == [True, False]
    assert model.slowest_time_constant == 14.0 and model.settling_samples() == int(np.ceil(8 * 14.0)) + 3 + 1
    kinds = {name: element.kind for name, (_, _, element) in model.element_models().items()}
    assert kinds == {
        "G11": "integrating",
        "G12": "none",
        "G13": "integrating",
        "G21": "foptd",
        "G22": "foptd",
        "G23": "none",
    }
    with pytest.raises(ValueError, match="element_type"):
        TransferMatrix(gain=[[1.0]], time_constant=[[1.0]], delay=[[0.0]], sample_time=1.0, element_type=[["ramp"]])


def test_element_names_beyond_nine_channels():
    model = TransferMatrix(
        gain=np.ones((10, 3)), time_constant=np.ones((10, 3)), delay=np.zeros((10, 3)), sample_time=1.0
    )
    names = model.element_names()
    assert names[0] == "G1_1" and names[-1] == "G10_3" and len(set(names)) == 30


def test_state_space_advance_equals_the_dense_step_and_is_the_same_on_a_batch():
    kinds = [["integrating", "foptd", "none"], ["foptd", "none", "foptd"]]
    model = TransferMatrix(
        [[0.05, 2.0, 0.0], [1.0, 0.0, -1.5]],
        [[0.0, 5.0, 0.0], [7.0, 0.0, 3.0]],
        [[2, 0, 0], [3, 0, 1]],
        1.0,
        element_type=kinds,
    )
    ss = model.state_space()
    rng = np.random.default_rng(0)
    x, u = rng.normal(size=(5, ss.A.shape[0])), rng.normal(size=(5, 3))
    batch = ss.advance(x, u)
    for j in range(5):
        np.testing.assert_allclose(batch[j], ss.A @ x[j] + ss.B @ u[j], rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(batch[j], ss.advance(x[j], u[j]))
    pole, source, weight = ss.one_source_form
    assert pole.shape == source.shape == weight.shape == (ss.A.shape[0],)


def test_element_of_a_cell_gives_the_same_step_response_as_the_matrix_filter():
    """``TransferMatrix.element`` is the cell's element: its step response is the matrix's own filter's."""
    import numpy as np
    from numpy.testing import assert_allclose

    from pmr_ros.core.sim.model import TransferMatrix

    model = TransferMatrix(
        gain=[[2.0, 0.5], [0.0, -1.0]],
        time_constant=[[5.0, 0.0], [0.0, 3.0]],
        delay=[[2.0, 1.0], [0.0, 0.0]],
        sample_time=1.0,
        element_type=np.array([["foptd", "integrating"], ["none", "foptd"]], dtype=object),
    )
    u = np.zeros((40, 2))
    u[1:, :] = 1.0
    outputs = model.element_outputs(u)
    for i in range(2):
        for k in range(2):
            step = model.element(i, k).step_response(38)  # s_n: n samples after the step at sample 1
            assert_allclose(outputs[2:, i, k], step, atol=1e-12)


def test_a_matrix_of_mixed_elements_filters_and_scales_each_cell_as_its_element():
    """``of_elements`` keeps tf and step-response cells; outputs and mismatch go through each element."""
    import numpy as np
    from numpy.testing import assert_allclose

    from pmr_ros.core.sim.lti import Empty, Foptd
    from pmr_ros.core.sim.mismatch import Mismatch
    from pmr_ros.core.sim.model import TransferMatrix
    from pmr_ros.core.sim.rational import transfer_function
    from pmr_ros.core.sim.step_curve import as_step_response

    second = transfer_function("2", "20, 12, 1", delay_samples=2, sample_time=1.0, name="G12")
    curve = as_step_response(Foptd(-1.5, 4.0, 1, 1.0), 60, name="G21")
    rows = [[Foptd(1.0, 5.0, 0, 1.0), second], [curve, Empty(1.0)]]
    model = TransferMatrix.of_elements(rows, sample_time=1.0)
    assert list(model.element_type.ravel()) == ["foptd", "tf", "step_response", "none"]
    assert_allclose(model.gain, [[1.0, 2.0], [-1.5, 0.0]], rtol=1e-3)  # the curve's 60 samples are 15 tau
    assert model.element(0, 1) is second and model.has_general
    u = np.zeros((80, 2))
    u[1:, 0], u[1:, 1] = 1.0, 1.0
    out = model.element_outputs(u)
    assert_allclose(out[2:, 0, 1], second.step_response(78), atol=1e-12)
    assert_allclose(out[2:, 1, 0], curve.step_response(78), atol=1e-12)
    z = np.zeros((2, 2))
    plant = model.with_mismatch(Mismatch(z + 20.0, z - 50.0, np.array([[0, 1], [2, 0]])))
    assert_allclose(plant.gain, 1.2 * model.gain, rtol=1e-9)
    assert_allclose(plant.delay_samples, [[0, 3], [3, 0]])
    # the tf element twice as fast (alpha 0.5): 2.4 / (5 s^2 + 6 s + 1), one sample more delay
    faster = transfer_function("2.4", "5, 6, 1", delay_samples=3, sample_time=1.0)
    assert_allclose(plant.element(0, 1).step_response(60), faster.step_response(60), atol=1e-12)


def test_an_injected_gain_change_of_an_integrating_tf_is_its_ramp_rate_change_whatever_its_speed():
    """``with_mismatch`` on ``0.05/(s(8s+1))``: +10 % gain and +20 % dynamics give a ramp 1.1x as steep, 1.2x slower."""
    import numpy as np
    from numpy.testing import assert_allclose

    from pmr_ros.core.sim.lti import Foptd
    from pmr_ros.core.sim.mismatch import Mismatch
    from pmr_ros.core.sim.model import TransferMatrix
    from pmr_ros.core.sim.rational import transfer_function

    ramp = transfer_function("0.05", "8, 1, 0", delay_samples=1, sample_time=1.0)
    model = TransferMatrix.of_elements([[ramp, Foptd(1.0, 5.0, 0, 1.0)]], sample_time=1.0)
    plant = model.with_mismatch(Mismatch(np.array([[10.0, 0.0]]), np.array([[20.0, 0.0]]), np.zeros((1, 2), int)))
    assert_allclose(plant.element(0, 0).steady_state_gain, 1.1 * 0.05, rtol=1e-12)
    assert_allclose(
        plant.element(0, 0).step_response(400)[-1] - plant.element(0, 0).step_response(400)[-2], 0.055, rtol=1e-6
    )
    slower = transfer_function("0.055", "9.6, 1, 0", delay_samples=1, sample_time=1.0)
    assert_allclose(plant.element(0, 0).step_response(100), slower.step_response(100), atol=1e-12)


def test_with_elements_keeps_the_names_sample_time_and_dv_count():
    """``with_elements``: other elements in the same frame (what a corrected or mismatched model is built with)."""
    from pmr_ros.core.sim.lti import Foptd, Integrating
    from pmr_ros.core.sim.model import TransferMatrix

    model = TransferMatrix.of_elements(
        [[Foptd(1.0, 5.0, 0, 2.0), Foptd(0.5, 3.0, 1, 2.0)]],
        sample_time=2.0,
        output_names=("level",),
        input_names=("valve", "feed"),
        name="tank",
        n_disturbances=1,
    )
    other = model.with_elements([[Integrating(0.1, 2, 2.0), Foptd(0.5, 3.0, 1, 2.0)]])
    assert (other.output_names, other.input_names, other.name, other.n_disturbances) == (
        ("level",),
        ("valve", "feed"),
        "tank",
        1,
    )
    assert other.sample_time == 2.0 and list(other.element_type.ravel()) == ["integrating", "foptd"]
    assert other.delay_samples[0, 0] == 2
