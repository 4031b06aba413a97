"""Welch cross-spectra: transfer functions, and a zero bin that survives."""

import numpy as np
from scipy.signal import lfilter

from pmr_ros.core.spectra import WelchSettings, cross_spectra


def test_cross_spectrum_ratio_recovers_filter_including_zero_frequency():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((20000, 1)) + 5.0  # an offset must not matter
    b, a = [0.0, 0.3], [1.0, -0.7]  # gain 1 at DC, one sample of lag
    y = lfilter(b, a, x[:, 0])[:, None]
    settings = WelchSettings("hann", 256, 0.5)
    omega, Sxy = cross_spectra(x, y, settings)
    _, Sxx = cross_spectra(x, x, settings)
    H = Sxy[:, 0, 0] / Sxx[:, 0, 0]
    z1 = np.exp(-1j * omega)
    truth = 0.3 * z1 / (1 - 0.7 * z1)
    assert omega[0] == 0.0 and np.isclose(omega[-1], np.pi)
    assert abs(H[0] - 1.0) < 0.05  # the DC bin carries the gain
    np.testing.assert_allclose(H[1:60], truth[1:60], atol=0.05)


def test_segments_count():
    s = WelchSettings("hann", 512, 0.5)
    assert s.segments(100) == 0
    assert s.segments(512) == 1
    assert s.segments(16384) == 63
