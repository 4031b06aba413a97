"""Cross-spectral densities of records, by Welch's averaged modified periodogram.

Segments are *not* detrended: the record mean is removed once (deviation
variables), so the zero-frequency bin keeps the low-frequency content the gain
ratio is read from.  Welch's usual per-segment mean removal would empty it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import csd


@dataclass(frozen=True)
class WelchSettings:
    """Welch estimator settings.

    Attributes
    ----------
    window : str
        ``scipy.signal.get_window`` name applied to each segment.
    segment_length : int
        Samples per segment; the frequency resolution is ``2 pi / segment_length`` rad/sample.
    overlap : float
        Fraction of a segment shared with the next, in [0, 1).
    """

    window: str = "hann"
    segment_length: int = 512
    overlap: float = 0.5

    def segments(self, samples: int) -> int:
        """Number of segments averaged for a record of ``samples``."""
        step = self.segment_length - int(self.segment_length * self.overlap)
        return 0 if samples < self.segment_length else 1 + (samples - self.segment_length) // step


def cross_spectra(x: np.ndarray, y: np.ndarray, settings: WelchSettings) -> tuple[np.ndarray, np.ndarray]:
    """Cross-spectral densities between every column of ``x`` and of ``y``.

    Parameters
    ----------
    x : ndarray, shape (N, p)
    y : ndarray, shape (N, q)
        Records sampled together; their means are removed here.

    Returns
    -------
    omega : ndarray, shape (F,)
        Frequencies [rad/sample], 0 .. pi.
    S : ndarray, shape (F, p, q)
        ``S[f, a, b]`` estimates E{conj(X_a) Y_b}: for ``y = H x`` it is ``H S_xx``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    x = x - x.mean(axis=0)
    y = y - y.mean(axis=0)
    nperseg = settings.segment_length
    freqs, S = csd(
        x.T[:, None, :],
        y.T[None, :, :],
        fs=1.0,
        window=settings.window,
        nperseg=nperseg,
        noverlap=int(nperseg * settings.overlap),
        detrend=False,
        scaling="density",
        axis=-1,
    )
    return 2.0 * np.pi * freqs, np.moveaxis(S, -1, 0)
