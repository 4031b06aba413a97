"""A matrix of elements of any type as one state-space system (pmr_ros.core.sim.realize).

Truth: the FOPTD transfer matrix's own realization, and the sum of each
element's impulse response convolved with its input.
"""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose
from scipy import signal

from pmr_ros.core.sim.lti import Empty, Foptd, Integrating
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.realize import element_outputs, realize
from pmr_ros.core.sim.step_curve import StepResponse, as_step_response

try:  # the transfer matrix moves to core/sim/model.py
    from pmr_ros.core.sim.model import TransferMatrix
except ImportError:
    from pmr_ros.core.sim.model import TransferMatrix


def _mixed():
    tf = transfer_function("-0.5, 1", "20, 12, 1", delay_samples=2, sample_time=1.0)
    return [
        [tf, transfer_function("5, 1", "2, 1", delay_samples=0, sample_time=1.0), Empty(1.0)],
        [Foptd(1.5, 4.0, 1, 1.0), as_step_response(tf, 60), StepResponse((0, 0.1, 0.3, 0.6), 1, 1.0, ramp=True)],
        [Integrating(0.2, 3, 1.0), Empty(1.0), transfer_function("0.5", "4, 1, 0", delay_samples=1, sample_time=1.0)],
    ]


def _simulate(A, B, C, u):
    _, y, _ = signal.dlsim((A, B, C, np.zeros((C.shape[0], B.shape[1])), 1.0), u)
    return y


def test_foptd_matrix_realizes_as_the_transfer_matrix_does():
    kinds = np.array([["foptd", "foptd"], ["integrating", "none"]], dtype=object)
    tm = TransferMatrix(
        [[12.8, -18.9], [0.2, 0.0]], [[16.7, 21.0], [0.0, 0.0]], [[1, 3], [2, 0]], 1.0, element_type=kinds
    )
    elements = [[Foptd(12.8, 16.7, 1, 1.0), Foptd(-18.9, 21.0, 3, 1.0)], [Integrating(0.2, 2, 1.0), Empty(1.0)]]
    A, B, C = realize(elements)
    ss = tm.state_space()
    u = np.random.default_rng(0).standard_normal((200, 2))
    assert_allclose(_simulate(A, B, C, u), _simulate(ss.A, ss.B, ss.C, u), atol=1e-10)
    assert_allclose(element_outputs(elements, u), tm.element_outputs(u), atol=1e-10)


def test_mixed_matrix_is_the_sum_of_its_elements_responses():
    elements = _mixed()
    u = np.random.default_rng(1).standard_normal((300, 3))
    A, B, C = realize(elements)
    want = np.zeros((300, 3))
    for i, row in enumerate(elements):
        for k, e in enumerate(row):
            h = np.concatenate(([0.0], e.impulse_response(299)))
            want[:, i] += np.convolve(u[:, k], h)[:300]
    assert_allclose(_simulate(A, B, C, u), want, atol=1e-9)
    # a register per input: the largest delay (+ taps): integrating delay 3 + 1 tap; curve delay 2 + 58 taps;
    # ramp curve delay 1 + 3 taps; then own states: the tfs (2, 2, integrating 2), the foptd 1, 2 accumulators
    registers = [4, 60, 4]
    assert A.shape[0] == sum(registers) + (2 + 2 + 2) + 1 + 2


def test_step_response_model_shares_one_register_per_input():
    def curve(i, k):
        return (k + 1) * np.concatenate((np.zeros(1 + i), 1 - np.exp(-np.arange(1, 90 - i) / 10.0)))

    curves = [[StepResponse(tuple(curve(i, k)), 1 + i, 1.0) for k in range(3)] for i in range(4)]
    A, B, C = realize(curves)
    assert A.shape[0] == 3 * 90  # the 90 coefficients' taps per input, no state of any element's own
    u = np.random.default_rng(4).standard_normal((200, 3))
    want = np.zeros((200, 4))
    for i, row in enumerate(curves):
        for k, e in enumerate(row):
            want[:, i] += np.convolve(u[:, k], np.concatenate(([0.0], e.impulse_response(199))))[:200]
    assert_allclose(_simulate(A, B, C, u), want, atol=1e-9)


def test_element_outputs_start_at_steady_state_and_follow_each_element():
    elements = _mixed()
    u = np.vstack([np.ones((50, 3)), np.random.default_rng(2).standard_normal((250, 3))])
    out = element_outputs(elements, u)
    assert_allclose(out[:50, 0, 0], elements[0][0].steady_state_gain, rtol=1e-9)  # stable: at steady state
    assert_allclose(out[:3, 2, 0], 0.0)  # integrating: from zero
    for i, row in enumerate(elements):
        for k, e in enumerate(row):
            if e.integrating or isinstance(e, Empty):
                continue
            h = np.concatenate(([0.0], e.impulse_response(299)))
            change = np.convolve(u[:, k] - u[0, k], h)[:300]
            assert_allclose(
                out[:, i, k], e.steady_state_gain * u[0, k] + change, atol=1e-6 * max(1.0, abs(e.steady_state_gain))
            )
