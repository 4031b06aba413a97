"""Welch cross-spectra: transfer functions, and a zero bin that survives."""

import numpy as np
import pytest
from scipy.signal import lfilter

from pmr_ros.core.pmr.spectra import WelchSettings, cross_spectra


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


def test_welch_equals_scipy_csd_without_detrending():
    from scipy.signal import csd

    rng = np.random.default_rng(1)
    x = rng.standard_normal((5000, 2)) + 3.0
    y = rng.standard_normal((5000, 3)) + x[:, :1]
    omega, S = cross_spectra(x, y, WelchSettings("hann", 512, 0.5))
    xc, yc = x - x.mean(axis=0), y - y.mean(axis=0)
    f, ref = csd(xc.T[:, None, :], yc.T[None, :, :], nperseg=512, noverlap=256, detrend=False, axis=-1)
    np.testing.assert_allclose(S, np.moveaxis(ref, -1, 0), atol=1e-12)
    np.testing.assert_allclose(omega, 2 * np.pi * f)


def test_segment_statistics_of_hann_at_half_overlap():
    from pmr_ros.core.pmr.spectra import segment_spectra

    s = WelchSettings("hann", 512, 0.5)
    # overlap correlation of Hann at 50 %: rho = 1/6, so K / (1 + 2 rho^2) for large K
    assert s.equivalent_segments(1000) == pytest.approx(1000 / (1 + 2 / 36), rel=2e-3)
    assert s.equivalent_segments(1) == 1.0
    assert s.bin_correlation == pytest.approx(1 + 2 * (2 / 3) ** 2 + 2 * (1 / 6) ** 2)
    seg = segment_spectra(np.random.default_rng(0).standard_normal((2048, 2)), s)
    assert seg.segments == 7 and seg.ffts.shape == (7, 257, 2)
    np.testing.assert_allclose(
        seg.cross(slice(0, 1), slice(1, 2)),
        cross_spectra(
            np.random.default_rng(0).standard_normal((2048, 2))[:, :1],
            np.random.default_rng(0).standard_normal((2048, 2))[:, 1:],
            s,
        )[1],
    )
