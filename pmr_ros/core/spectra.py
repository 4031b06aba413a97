"""Cross-spectral densities of records, by Welch's averaged modified periodogram.

Segments are *not* detrended: the record mean is removed once (deviation
variables), so the zero-frequency bin keeps the low-frequency content the gain
ratio is read from.  Welch's usual per-segment mean removal would empty it.

The segment FFTs are kept (:class:`SegmentSpectra`) so that every cross-spectrum
of a record comes from one transform, and so that the estimate's statistics
(equivalent number of segments, correlation of neighbouring bins) are at hand.
The result equals ``scipy.signal.csd(..., detrend=False)``; the tests check it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import get_window

from .foptd import FoptdMatrix


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

    @property
    def step(self) -> int:
        """Samples between segment starts."""
        return self.segment_length - int(self.segment_length * self.overlap)

    def segments(self, samples: int) -> int:
        """Number of segments averaged for a record of ``samples``."""
        return 0 if samples < self.segment_length else 1 + (samples - self.segment_length) // self.step

    @cached_property
    def taper(self) -> np.ndarray:
        """The window samples (periodic, as scipy's Welch uses)."""
        return get_window(self.window, self.segment_length)

    def equivalent_segments(self, segments: int) -> float:
        """Independent segments the average is worth, given the overlap.

        ``K / (1 + 2 sum_j (1 - j/K) rho(j step)^2)``, rho the window's
        normalized overlap correlation (Welch 1967): 1.9 K / 2 for Hann at 50 %.
        """
        w2 = self.taper**2
        total = 1.0
        for j in range(1, segments):
            shift = j * self.step
            if shift >= self.segment_length:
                break
            rho = np.dot(self.taper[shift:], self.taper[: self.segment_length - shift]) / w2.sum()
            total += 2.0 * (1.0 - j / segments) * rho**2
        return segments / total

    @cached_property
    def bin_correlation(self) -> float:
        """How much neighbouring bins repeat each other: ``sum_m |c(m)|^2``.

        ``c(m)`` is the correlation between periodogram values ``m`` bins apart,
        the DFT of the squared window normalized to ``c(0) = 1``: 1.94 for Hann.
        A fit that treats every bin as independent overstates its information by
        this factor.
        """
        c = np.fft.fft(self.taper**2)
        c = c / c[0]
        return float(np.sum(np.abs(c) ** 2))


@dataclass(frozen=True)
class SegmentSpectra:
    """The windowed FFTs of every segment of a multichannel record.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    ffts : ndarray of complex, shape (K, F, p)
        One row per segment; scaled so that averaging ``conj(X_a) X_b`` over
        segments gives the one-sided cross-spectral density (fs = 1).
    settings : WelchSettings
    """

    omega: np.ndarray
    ffts: np.ndarray
    settings: WelchSettings

    @property
    def segments(self) -> int:
        """Segments averaged."""
        return self.ffts.shape[0]

    def cross(self, a: slice | np.ndarray, b: slice | np.ndarray) -> np.ndarray:
        """Cross-spectra between channel groups, shape (F, len(a), len(b)): ``E{conj(X_a) X_b}``."""
        Xa = self.ffts[:, :, a]
        Xb = self.ffts[:, :, b]
        return np.einsum("kfa,kfb->fab", Xa.conj(), Xb) / self.segments


def segment_spectra(x: np.ndarray, settings: WelchSettings) -> SegmentSpectra:
    """Windowed segment FFTs of the columns of ``x`` (record means removed).

    Parameters
    ----------
    x : ndarray, shape (N, p)
    settings : WelchSettings
    """
    x = np.asarray(x, dtype=float)
    x = x - x.mean(axis=0)
    L = settings.segment_length
    K = settings.segments(x.shape[0])
    frames = sliding_window_view(x, L, axis=0)[:: settings.step][:K]  # (K, p, L)
    taper = settings.taper
    X = np.fft.rfft(frames * taper, axis=-1)  # (K, p, F)
    # one-sided density scaling of scipy.signal.csd: 2 / sum(w^2), DC and Nyquist once
    scale = np.full(X.shape[-1], np.sqrt(2.0 / np.sum(taper**2)))
    scale[0] = np.sqrt(1.0 / np.sum(taper**2))
    if L % 2 == 0:
        scale[-1] = scale[0]
    X = np.moveaxis(X * scale, 1, 2)  # (K, F, p)
    omega = 2.0 * np.pi * np.fft.rfftfreq(L)
    return SegmentSpectra(omega, X, settings)


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
    p = x.shape[1]
    seg = segment_spectra(np.hstack([x, np.asarray(y, dtype=float)]), settings)
    return seg.omega, seg.cross(slice(0, p), slice(p, None))


@dataclass(frozen=True)
class RecordSpectra:
    """The cross-spectra of a record that the PMR needs, from one Welch transform.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    rr : ndarray, shape (F, n_r, n_r)
        Setpoint spectra ``S_{r r}``.
    ry : ndarray, shape (F, n_r, n_out)
        ``S_{r_l y_i}``.
    ryhat : ndarray, shape (F, n_r, n_out, n_in)
        ``S_{r_l yhat_ik}``.
    yy : ndarray, shape (F, n_out)
        Output auto-spectra ``S_{y_i y_i}`` (real).
    yhat_y : ndarray, shape (F, n_out, n_in)
        ``S_{yhat_ik y_i}``.
    yhat_yhat : ndarray, shape (F, n_out, n_in, n_in)
        ``S_{yhat_ik yhat_im}``.
    segments : int
        Welch segments averaged.
    equivalent_segments : float
        Independent segments they are worth (overlap).
    settings : WelchSettings
    """

    omega: np.ndarray
    rr: np.ndarray
    ry: np.ndarray
    ryhat: np.ndarray
    yy: np.ndarray
    yhat_y: np.ndarray
    yhat_yhat: np.ndarray
    segments: int
    equivalent_segments: float
    settings: WelchSettings


def record_spectra(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, model: FoptdMatrix, welch: WelchSettings
) -> RecordSpectra:
    """Spectra of setpoints, outputs and per-element model outputs ``yhat_ik = Ghat_ik u_k``.

    The model's settling time (:meth:`FoptdMatrix.settling_samples`) is dropped
    from the start of every signal: ``yhat``'s filters start from a guessed state.
    The record must have passed :func:`check_record`.
    """
    n_out, n_in = model.n_outputs, model.n_inputs
    n_r = r.shape[1]
    yhat = model.element_outputs(u).reshape(u.shape[0], n_out * n_in)
    warmup = model.settling_samples()
    seg = segment_spectra(np.hstack([r, y, yhat])[warmup:], welch)
    R = slice(0, n_r)
    Y = slice(n_r, n_r + n_out)
    F = seg.omega.size
    yhat_cols = np.arange(n_r + n_out, n_r + n_out + n_out * n_in).reshape(n_out, n_in)
    yy = np.stack([seg.cross([n_r + i], [n_r + i])[:, 0, 0].real for i in range(n_out)], axis=1)
    yhat_y = np.stack([seg.cross(yhat_cols[i], [n_r + i])[:, :, 0] for i in range(n_out)], axis=1)
    yhat_yhat = np.stack([seg.cross(yhat_cols[i], yhat_cols[i]) for i in range(n_out)], axis=1)
    return RecordSpectra(
        omega=seg.omega,
        rr=seg.cross(R, R),
        ry=seg.cross(R, Y),
        ryhat=seg.cross(R, yhat_cols.ravel()).reshape(F, n_r, n_out, n_in),
        yy=yy,
        yhat_y=yhat_y,
        yhat_yhat=yhat_yhat,
        segments=seg.segments,
        equivalent_segments=welch.equivalent_segments(seg.segments),
        settings=welch,
    )
