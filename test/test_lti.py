"""Model elements of any linear form (pmr_ros.core.sim): sampling, responses, realization, scaling, bad input.

Truth: closed-form step responses, scipy.signal's own continuous simulation
(``step``) and ``freqz`` of the ``cont2discrete`` sampled system.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import signal

from pmr_ros.core.sim.elements import ELEMENT_KINDS, build_element
from pmr_ros.core.sim.lti import ElementError, Empty, Foptd, Integrating
from pmr_ros.core.sim.rational import TransferFunction, parse_coefficients, transfer_function
from pmr_ros.core.sim.step_curve import StepResponse, as_step_response, dead_time_samples

OMEGA = np.linspace(0.01, np.pi, 200)
"""Frequencies [rad/sample] the responses are compared at."""


def _tf(num: str, den: str, delay: int = 0, ts: float = 1.0) -> TransferFunction:
    return transfer_function(num, den, delay_samples=delay, sample_time=ts, name="G11")


def _continuous_step(num, den, times: np.ndarray) -> np.ndarray:
    """The continuous step response by scipy.signal.step at ``times`` (0 at t = 0, before the step acts)."""
    _, y = signal.step((num, den), T=np.concatenate(([0.0], times)))
    return y[1:]


# -- sampling: the step response at the sample instants is the continuous one -----------------


def test_foptd_step_response_is_the_closed_form_after_its_delay():
    g = Foptd(gain=12.8, time_constant=16.7, delay_samples=3, sample_time=0.5)
    k = np.arange(1, 61)
    truth = np.where(k > 3, 12.8 * (1 - np.exp(-(k - 3) * 0.5 / 16.7)), 0.0)
    assert_allclose(g.step_response(60), truth, rtol=1e-12, atol=1e-14)


def test_first_order_tf_is_the_foptd_element():
    tf, foptd = _tf("12.8", "16.7, 1", delay=2), Foptd(12.8, 16.7, 2, 1.0)
    assert_allclose(tf.step_response(80), foptd.step_response(80), rtol=1e-10, atol=1e-12)
    assert_allclose(tf.frequency_response(OMEGA), foptd.frequency_response(OMEGA), rtol=1e-10)
    assert tf.steady_state_gain == pytest.approx(12.8, rel=1e-12)


def test_inverse_response_second_order_tf_sampled_exactly():
    # (1 - 0.5 s) / ((10 s + 1)(2 s + 1)): roots -0.1, -0.5 of 20 s^2 + 12 s + 1
    g = _tf("-0.5, 1", "20, 12, 1", delay=4, ts=0.5)
    t = 0.5 * np.arange(1, 121)
    tau = t - 4 * 0.5
    a, b = (-0.5 - 10) / (10 - 2), (2 + 0.5) / (10 - 2)  # partial fractions of the step response
    closed = np.where(tau > 0, 1 + a * np.exp(-np.maximum(tau, 0) / 10) + b * np.exp(-np.maximum(tau, 0) / 2), 0.0)
    assert_allclose(g.step_response(120), closed, atol=1e-10)
    assert g.step_response(120)[4] < 0  # it goes the wrong way first
    after = t > 2.0
    want = np.zeros_like(t)
    want[after] = _continuous_step([-0.5, 1], [20, 12, 1], t[after] - 2.0)
    assert_allclose(g.step_response(120), want, atol=1e-6)


def test_oscillatory_tf_sampled_exactly_against_scipy_step():
    g = _tf("2", "4, 0.8, 1", ts=0.25)
    t = 0.25 * np.arange(1, 201)
    assert_allclose(g.step_response(200), _continuous_step([2], [4, 0.8, 1], t), atol=1e-6)
    assert g.step_response(200).max() > 2.5  # it overshoots its gain 2


def test_integrating_tf_is_a_ramp_after_its_lag():
    g = _tf("0.5", "4, 1, 0", ts=1.0)
    k = np.arange(1, 41.0)
    assert g.integrating and g.steady_state_gain == pytest.approx(0.5)
    assert_allclose(g.step_response(40), 0.5 * (k - 4 * (1 - np.exp(-k / 4))), atol=1e-10)


def test_integrating_element_rises_by_k_ts_per_sample():
    g = Integrating(gain=0.3, delay_samples=2, sample_time=2.0)
    assert_allclose(g.step_response(6), [0, 0, 0.6, 1.2, 1.8, 2.4], atol=1e-14)


def test_biproper_lead_lag_acts_one_sample_after_the_move():
    # (5 s + 1)/(2 s + 1): s(t) = 1 - (1 - 5/2) exp(-t/2); the sample-0 value stays 0 (measured before the move)
    g = _tf("5, 1", "2, 1")
    k = np.arange(1, 31.0)
    assert_allclose(g.step_response(30), 1 - (1 - 2.5) * np.exp(-k / 2), atol=1e-10)
    assert g.discrete().numerator[0] == 0.0


# -- frequency response ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("num", "den", "delay"), [("12.8", "16.7, 1", 1), ("-0.5, 1", "20, 12, 1", 3), ("2", "4, 0.8, 1", 0)]
)
def test_frequency_response_is_freqz_of_the_sampled_system_with_its_delay(num, den, delay):
    g = _tf(num, den, delay=delay)
    num_d, den_d, _ = signal.cont2discrete(
        ([float(v) for v in num.split(",")], [float(v) for v in den.split(",")]), 1.0
    )
    _, h = signal.freqz(num_d.ravel(), den_d, worN=OMEGA)
    assert_allclose(g.frequency_response(OMEGA), h * np.exp(-1j * OMEGA * delay), rtol=1e-8, atol=1e-10)


def test_foptd_frequency_response_closed_form():
    g = Foptd(-18.9, 21.0, 3, 1.0)
    a = np.exp(-1 / 21.0)
    z1 = np.exp(-1j * OMEGA)
    assert_allclose(g.frequency_response(OMEGA), -18.9 * (1 - a) * z1**4 / (1 - a * z1), rtol=1e-12)


# -- state space ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "element",
    [
        Foptd(2.0, 5.0, 3, 1.0),
        Integrating(0.4, 1, 1.0),
        _tf("-0.5, 1", "20, 12, 1", delay=2),
        _tf("5, 1", "2, 1"),
        _tf("0.5", "4, 1, 0", delay=1),
        StepResponse((0, 0, 1, 2, 2.5, 2.7, 2.8), 2, 1.0),
        StepResponse((0, 0.1, 0.3, 0.6, 0.9), 1, 1.0, ramp=True),
    ],
    ids=["foptd", "integrating", "inverse", "leadlag", "tf-integrating", "curve", "curve-ramp"],
)
def test_state_space_simulates_the_impulse_response(element):
    rng = np.random.default_rng(3)
    u = rng.standard_normal(150)
    A, B, C, D = element.state_space()
    _, y, _ = signal.dlsim((A, B, C, D, 1.0), u)
    h = np.concatenate(([0.0], element.impulse_response(149)))
    assert_allclose(y.ravel(), np.convolve(u, h)[:150], atol=1e-9)
    assert np.all(D == 0)


def test_empty_element_is_zero_everywhere_and_has_no_state():
    e = Empty(1.0)
    assert_allclose(e.step_response(5), 0.0)
    assert_allclose(np.abs(e.frequency_response(OMEGA)), 0.0)
    assert e.state_space()[0].shape == (0, 0)
    assert e.scaled(gain_ratio=2.0, time_scale=3.0) is e


# -- scaled: rho G(s alpha) exp(-dD s) ------------------------------------------------------


def test_scaled_foptd_is_the_foptd_with_changed_gain_time_constant_and_delay():
    g = Foptd(12.8, 16.7, 1, 1.0).scaled(gain_ratio=1.1, time_scale=1.2, delay_change=2)
    assert g == Foptd(12.8 * 1.1, 16.7 * 1.2, 3, 1.0)


def test_scaled_integrating_changes_the_rate_by_rho_over_alpha():
    g = Integrating(0.4, 1, 1.0).scaled(gain_ratio=1.2, time_scale=2.0, delay_change=-1)
    assert g.gain == pytest.approx(0.24) and g.delay_samples == 0


def test_scaled_tf_is_the_analytically_scaled_tf():
    # 1.1 (1 - 0.5 (1.3 s)) / (20 (1.3 s)^2 + 12 (1.3 s) + 1)
    got = _tf("-0.5, 1", "20, 12, 1", delay=2).scaled(gain_ratio=1.1, time_scale=1.3, delay_change=1)
    want = _tf("-0.715, 1.1", "33.8, 15.6, 1", delay=3)
    assert_allclose(got.step_response(100), want.step_response(100), rtol=1e-10, atol=1e-12)
    assert_allclose(got.frequency_response(OMEGA), want.frequency_response(OMEGA), rtol=1e-10)


@pytest.mark.parametrize("alpha", [0.7, 1.0, 1.25])
def test_scaled_curve_matches_the_curve_of_the_scaled_tf(alpha):
    tf = _tf("-0.5, 1", "20, 12, 1", delay=3)
    curve = as_step_response(tf, 150)
    got = curve.scaled(gain_ratio=0.9, time_scale=alpha, delay_change=2)
    want = tf.scaled(gain_ratio=0.9, time_scale=alpha, delay_change=2)
    n = len(got.curve)
    assert n == 5 + int(np.ceil(alpha * 147 - 1e-9))
    # the spline's error (second order tf at 1 sample) and the held end of the truncated curve
    assert_allclose(got.step_response(n), want.step_response(n), atol=5e-4)
    assert got.delay_samples == 5


def test_scaled_ramp_curve_keeps_rising_at_rho_over_alpha_the_slope():
    curve = as_step_response(_tf("0.5", "4, 1, 0"), 80)
    got = curve.scaled(gain_ratio=1.2, time_scale=2.0)
    assert got.ramp
    assert got.last_slope == pytest.approx(0.5 * 1.2 / 2.0, rel=1e-3)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: Foptd(1.0, 2.0, 1, 1.0).scaled(time_scale=0.0), "time_scale 0.0 must be"),
        (lambda: Foptd(1.0, 2.0, 1, 1.0).scaled(delay_change=-2), "would be negative"),
        (lambda: Foptd(1.0, 2.0, 1, 1.0).scaled(delay_change=0.5), "whole samples"),
    ],
)
def test_scaling_refuses_a_bad_alpha_or_delay(call, match):
    with pytest.raises(ElementError, match=match):
        call()


# -- step-response curves -------------------------------------------------------------------


@pytest.mark.parametrize(("num", "den"), [("-0.5, 1", "20, 12, 1"), ("0.5", "4, 1, 0"), ("2", "4, 0.8, 1")])
def test_curve_from_a_tf_has_its_frequency_response_within_the_truncation(num, den):
    tf = _tf(num, den, delay=2)
    n = 90
    curve = as_step_response(tf, n)
    assert curve.ramp == tf.integrating and curve.delay_samples == 2
    assert_allclose(curve.step_response(n), tf.step_response(n), atol=1e-12)
    # what the curve drops: the pulses after n (for a ramp, their departure from the last slope)
    h = tf.impulse_response(5000)
    tail = h[n:] - (h[n - 1] if tf.integrating else 0.0)
    bound = np.sum(np.abs(tail)) * (1 + 1e-9) + 1e-12
    omega = OMEGA[OMEGA > 0.05]  # away from a ramp's infinite response at 0
    diff = np.abs(curve.frequency_response(omega) - tf.frequency_response(omega))
    assert diff.max() <= bound
    assert bound < 0.05 * np.abs(tf.frequency_response(omega)).max()


def test_curve_holds_its_last_value_or_ramps_on_beyond_its_end():
    held = StepResponse((0, 1, 1.5, 1.75), 1, 1.0)
    ramp = StepResponse((0, 1, 1.5, 1.75), 1, 1.0, ramp=True)
    assert_allclose(held.step_response(6), [0, 1, 1.5, 1.75, 1.75, 1.75])
    assert_allclose(ramp.step_response(6), [0, 1, 1.5, 1.75, 2.0, 2.25])
    assert held.steady_state_gain == 1.75 and ramp.steady_state_gain == pytest.approx(0.25)
    assert_allclose(held.impulse_response(5), [0, 1, 0.5, 0.25, 0])


def test_curve_frequency_response_is_the_sum_of_its_pulses():
    curve = StepResponse((0, 0.5, 0.8, 0.9, 1.0), 1, 1.0)
    h = np.diff(np.concatenate(([0.0], curve.curve)))
    want = np.exp(-1j * np.outer(OMEGA, np.arange(1, 6))) @ h
    assert_allclose(curve.frequency_response(OMEGA), want, rtol=1e-12)


def test_stated_gain_wins_over_the_curve_and_scales():
    curve = StepResponse((0.5, 0.99), 0, 2.0, stated_gain=1.0)
    assert curve.steady_state_gain == 1.0
    assert curve.scaled(gain_ratio=1.5).steady_state_gain == 1.5


def test_dead_time_is_the_leading_exact_zeros():
    assert dead_time_samples(np.array([0.0, -0.0, 0.0, 1e-9, 1.0])) == 3
    assert dead_time_samples(np.zeros(4)) == 3


def test_settle_samples_is_where_the_dynamics_faded():
    g = Foptd(1.0, 10.0, 2, 1.0)
    n = g.settle_samples(1e-3)
    assert abs(g.step_response(n)[-1] - 1.0) < 1e-3 <= abs(g.step_response(n - 5)[-1] - 1.0)


# -- bad input: one clear line each ---------------------------------------------------------


@pytest.mark.parametrize(
    ("num", "den", "words"),
    [
        ("1, 2, 3", "1, 1", ["G11", "improper", "numerator degree 2 > denominator degree 1"]),
        ("1", "5, -1", ["G11", "unstable", "s = 0.2", "right half-plane"]),
        ("1", "1, 0, 1", ["G11", "unstable", "imaginary axis"]),
        ("1", "1, 0, 0", ["G11", "2 poles at s = 0", "at most one integrator"]),
        ("12.8x", "16.7, 1", ["G11", "numerator", "'12.8x'", "does not parse"]),
        ("12.8", "", ["G11", "denominator", "empty"]),
        ("0", "16.7, 1", ["G11", "numerator is zero", "none"]),
    ],
)
def test_bad_transfer_functions_are_refused_in_one_line(num, den, words):
    with pytest.raises(ElementError) as info:
        _tf(num, den)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_curve_shorter_than_its_delay_is_refused_in_one_line():
    with pytest.raises(ElementError) as info:
        StepResponse((0.0, 0.0, 0.0), 4, 1.0, name="G21")
    assert str(info.value) == "G21: the step-response curve of 3 coefficients is shorter than its delay of 4 samples"
    with pytest.raises(ElementError, match="G21: the step-response curve responds before its delay of 2 samples"):
        StepResponse((0.0, 0.3, 0.6), 2, 1.0, name="G21")
    with pytest.raises(ElementError, match="shorter than its delay"):
        as_step_response(Foptd(1.0, 2.0, 6, 1.0), 5)


def test_parse_coefficients_takes_matlab_forms():
    assert parse_coefficients("[20 12, 1]", element="G", field="denominator") == (20.0, 12.0, 1.0)
    assert parse_coefficients(" 1;2 ", element="G", field="numerator") == (1.0, 2.0)
    with pytest.raises(ElementError, match="'inf' is not finite"):
        parse_coefficients("1, inf", element="G", field="numerator")
    with pytest.raises(ElementError, match="must be a string"):
        parse_coefficients(12.8, element="G", field="numerator")  # type: ignore[arg-type]


# -- building from the fields of a system block ---------------------------------------------


def test_build_element_makes_every_kind():
    common = {"name": "G12", "sample_time": 1.0, "delay_samples": 1}
    made = {
        "foptd": build_element("foptd", gain=2.0, time_constant=3.0, **common),
        "integrating": build_element("integrating", gain=0.1, **common),
        "none": build_element("none", **common),
        "tf": build_element("tf", tf=("2", "3, 1"), **common),
        "step_response": build_element("step_response", curve=([0.0, 1.0, 2.0], False), gain=2.0, **common),
    }
    assert set(made) == set(ELEMENT_KINDS)
    for kind, element in made.items():
        assert element.kind == kind
    assert_allclose(made["tf"].step_response(20), made["foptd"].step_response(20), atol=1e-12)
    assert made["step_response"].steady_state_gain == 2.0


@pytest.mark.parametrize(
    ("kind", "extra", "match"),
    [
        ("foptd", {"time_constant": 0.0}, "G12: time constant 0.0 must be > 0"),
        ("step_response", {}, "G12: a step_response element needs its curve"),
        ("fopdt", {}, "G12: element type 'fopdt' is not one of"),
    ],
)
def test_build_element_refuses_in_one_line(kind, extra, match):
    with pytest.raises(ElementError, match=match):
        build_element(kind, name="G12", sample_time=1.0, delay_samples=0, **extra)


def test_cell_element_builds_each_cell_of_a_block_as_build_element_does():
    """``cell_element``: the fields of cell (i, k) of row-major block matrices, the delay from time units."""
    import numpy as np
    from numpy.testing import assert_allclose

    from pmr_ros.core.sim.elements import build_element, cell_element

    fields = {
        "element_type": np.array([["foptd", "tf"]], dtype=object),
        "gain": np.array([[2.0, 0.0]]),
        "time_constant": np.array([[6.0, 0.0]]),
        "delay": np.array([[4.0, 2.0]]),
        "numerator": np.array([["", "-0.5, 1"]], dtype=object),
        "denominator": np.array([["", "20, 12, 1"]], dtype=object),
        "sample_time": 2.0,
    }
    lag = cell_element(fields, 0, 0, name="G11")
    same = build_element("foptd", name="G11", sample_time=2.0, delay_samples=2, gain=2.0, time_constant=6.0)
    assert_allclose(lag.step_response(20), same.step_response(20), atol=1e-15)
    inverse = cell_element(fields, 0, 1, name="G12")
    assert inverse.kind == "tf" and inverse.delay_samples == 1
    assert_allclose(inverse.steady_state_gain, 1.0, rtol=1e-12)  # (-0.5 s + 1) / (20 s^2 + 12 s + 1) at s = 0
