"""PRBS: maximal length, balance, decorrelated channels, statelessness."""

import numpy as np
import pytest
from scipy.signal import coherence

from pmr_ros.core.sim.excitation import (
    PrbsGenerator,
    PrbsSettings,
    is_primitive,
    m_sequence,
    primitive_polynomial_count,
    primitive_polynomials,
)


@pytest.mark.parametrize("degree", range(3, 17))
def test_m_sequence_has_period_2n_minus_1_and_is_balanced(degree):
    poly = primitive_polynomials(degree, 1)[0]
    bits = m_sequence(poly, degree)
    period = 2**degree - 1
    assert bits.size == period
    assert bits.sum() == 2 ** (degree - 1)  # one more 1 than 0s
    # no shorter period: the sequence differs from every non-trivial cyclic shift of itself
    signed = 2.0 * bits - 1.0
    spectrum = np.fft.fft(signed)
    autocorr = np.fft.ifft(spectrum * spectrum.conj()).real
    np.testing.assert_allclose(autocorr[0], period)
    np.testing.assert_allclose(autocorr[1:], -1.0, atol=1e-6)  # the two-level autocorrelation of an m-sequence


def test_is_primitive_knows_small_cases():
    assert is_primitive(0b111, 2)  # x^2 + x + 1
    assert is_primitive(0b1011, 3)  # x^3 + x + 1
    assert not is_primitive(0b10101, 4)  # (x^2 + x + 1)^2
    assert not is_primitive(0b11111, 4)  # irreducible but of order 5
    with pytest.raises(ValueError):
        primitive_polynomials(4, 3)  # degree 4 has only two


def _settings(**kw):
    base = dict(register_length=10, clock_period=8, amplitude=np.array([1.0, 0.5]), nominal=np.array([0.0, 2.0]))
    base.update(kw)
    return PrbsSettings(**base)


def test_generator_levels_clock_and_period():
    gen = PrbsGenerator(_settings(), seed=3)
    r = gen.sequence(3 * gen.period_samples)
    assert set(np.unique(r[:, 0])) == {-1.0, 1.0}
    assert set(np.unique(r[:, 1])) == {1.5, 2.5}
    # each bit is held for clock_period samples
    assert np.all(r[::8] == r[7::8][: r[::8].shape[0]])
    np.testing.assert_array_equal(r[: gen.period_samples], r[gen.period_samples : 2 * gen.period_samples])
    assert gen.period_samples == 1023 * 8


def test_value_is_stateless_and_equals_sequence():
    gen = PrbsGenerator(_settings(), seed=7)
    seq = gen.sequence(500)
    for k in (0, 1, 7, 8, 499, 123):
        np.testing.assert_array_equal(gen.value(k), seq[k])
    np.testing.assert_array_equal(PrbsGenerator(_settings(), seed=7).sequence(500), seq)
    assert not np.array_equal(PrbsGenerator(_settings(), seed=8).sequence(500), seq)


def test_channels_are_incoherent():
    # Different primitive polynomials, not shifted copies (which would be fully
    # coherent): with the period longer than the record, the coherence between
    # channels is that of independent white noise.
    gen = PrbsGenerator(
        _settings(register_length=14, clock_period=1, amplitude=np.ones(3), nominal=np.zeros(3)), seed=1
    )
    r = gen.sequence(16384)
    white = np.random.default_rng(0).standard_normal((16384, 2))
    _, reference = coherence(white[:, 0], white[:, 1], nperseg=512)
    for a, b in ((0, 1), (0, 2), (1, 2)):
        _, coh = coherence(r[:, a], r[:, b], nperseg=512)
        assert coh.mean() < 1.5 * reference.mean()
        assert coh.max() < 1.5 * reference.max()


def test_shifted_copies_would_be_coherent():
    # Why channels use different polynomials: a delayed copy is coherent everywhere.
    bits = 2.0 * m_sequence(primitive_polynomials(14, 1)[0], 14) - 1.0
    _, coh = coherence(bits[:8192], np.roll(bits, 100)[:8192], nperseg=512)
    assert coh.mean() > 0.6


def test_primitive_polynomial_count_is_what_the_search_finds():
    for degree in range(3, 12):
        count = primitive_polynomial_count(degree)
        assert len(primitive_polynomials(degree, count)) == count
        with pytest.raises(ValueError, match="fewer than"):
            primitive_polynomials(degree, count + 1)
    assert primitive_polynomial_count(12) == 144  # phi(4095) / 12: enough for 72 CVs and 72 dithered MVs
