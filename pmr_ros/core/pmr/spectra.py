"""Cross-spectral densities of records, by Welch's averaged modified periodogram.

Segments are *not* detrended: the record mean is removed once (deviation
variables), so the zero-frequency bin keeps the low-frequency content the gain
ratio is read from.  Welch's usual per-segment mean removal would empty it.

The segment FFTs are kept (:class:`SegmentSpectra`) so that every cross-spectrum
of a record comes from one transform, and so that the estimate's statistics
(equivalent number of segments, correlation of neighbouring bins) are at hand.
The result equals ``scipy.signal.csd(..., detrend=False)``; the tests check it.

**The regression of one output row** (:class:`RowSpectra`) relates the row's
output ``y_i`` to one regressor ``x_ik`` per input, through the instruments
z (the external signals that move, :class:`~pmr_ros.core.records.InstrumentSet`):

* a modeled element (of any type): ``x_ik = Ghat_ik u_k``,
  so that ``y_i = sum_k G_PMR_ik x_ik + v_i`` with ``G_PMR = G / Ghat``;
* an empty cell (``none``): the *reference* ``x_ik = u_k(t - 1)``, the output
  of a unit static gain behind the zero-order hold's sample of lag, so that
  the coefficient of ``x_ik`` is the plant's interaction ``G_ik`` itself
  (zero when there is none); the parametric method fits it with a
  first-order template (:mod:`pmr_ros.core.pmr.parametric.ratio`).

**Integrating rows are differenced.**  An output with an integrating element
(a level, a gas pressure) drifts: its model outputs ``Ghat_ik u_k`` ramp with
the mean of ``u_k``, its plant integrator starts from an unknown level, and
neither is a stationary signal Welch's estimate may average.  Every signal of
such a row -- ``y_i`` and each of its regressors -- is passed through the same
filter ``Delta = 1 - z^-1`` before the transform.  That is unbiased: the row's
relation ``y_i = sum_k G_PMR_ik x_ik + v_i`` is linear and time-invariant, so
``Delta y_i = sum_k G_PMR_ik (Delta x_ik) + Delta v_i`` with the *same* ratios;
the instruments are not filtered, so ``S_{z, Delta y} = Delta(w) S_{z y}``
scales both sides of the regression by the same ``Delta(w)`` and the ratios
solve the same equations.  Differencing makes the drift stationary: ``Delta
Ghat_ik`` of an integrator is the finite impulse ``K Ts z^-(1+D)``, an unknown
initial level becomes a single sample at the start (dropped with the warm-up),
and the noise ``Delta v_i`` is what the fit's weighting estimates from the
residual anyway.  The price: ``Delta(0) = 0``, so the zero-frequency bin of a
differenced row carries nothing, and its gain is read from the lowest nonzero
bins (an integrating ratio ``(K/Khat) z^-dD`` has the same magnitude at every
frequency).  In a differenced row the reference of an empty cell is the
differenced output of a unit integrator, ``Ts u_k(t - 1)``: an unmodeled
interaction on an integrating output is taken to integrate as well.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import get_window

from ..records import InstrumentSet, Record, moving_instruments, total_samples
from ..sim.model import TransferMatrix
from .products import hermitian_product, row_products, stretch_mean
from .regressors import row_regressors
from .spectra_source import SPECTRA_SOURCE

__all__ = [
    "RecordSpectra",
    "RowSpectra",
    "SegmentSpectra",
    "WelchSettings",
    "cross_spectra",
    "record_spectra",
    "segment_spectra",
    "stretch_segments",
]


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

    def cross(
        self, a: slice | list[int] | np.ndarray, b: slice | list[int] | np.ndarray, *, mean: bool = True
    ) -> np.ndarray:
        """Cross-spectra between channel groups, shape (F, len(a), len(b)): ``E{conj(X_a) X_b}``.

        ``mean=False``: the sums over the segments instead (a stretch's part of :func:`stretch_mean`).
        """
        total = np.einsum("kfa,kfb->fab", self.ffts[:, :, a].conj(), self.ffts[:, :, b])
        return total / self.segments if mean else total


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


def stretch_segments(blocks: Sequence[np.ndarray], settings: WelchSettings) -> tuple[SegmentSpectra, float]:
    """The Welch segments of every block (each its own mean removed), pooled; and what they are worth.

    Returns
    -------
    SegmentSpectra
        All segments that fit inside a block, in order.
    float
        Their equivalent number of independent segments (overlap counted within each block).
    """
    parts = [segment_spectra(block, settings) for block in blocks if settings.segments(block.shape[0]) > 0]
    ffts = np.concatenate([p.ffts for p in parts], axis=0)
    equivalent = sum(settings.equivalent_segments(p.segments) for p in parts)
    return SegmentSpectra(parts[0].omega, ffts, settings), equivalent


@dataclass(frozen=True)
class RowSpectra:
    """The cross-spectra of one output row's regression (see the module docstring).

    Attributes
    ----------
    zy : ndarray, shape (F, n_z)
        ``S_{z_l y_i}``.
    zx : ndarray, shape (F, n_z, n_in)
        ``S_{z_l x_ik}``: instruments with each regressor.
    yy : ndarray, shape (F,)
        ``S_{y_i y_i}`` (real).
    xy : ndarray, shape (F, n_in)
        ``S_{x_ik y_i}``.
    xx : ndarray, shape (F, n_in, n_in)
        ``S_{x_ik x_im}``.
    differenced : bool
        Whether the row's signals were differenced (an integrating output).
    """

    zy: np.ndarray
    zx: np.ndarray
    yy: np.ndarray
    xy: np.ndarray
    xx: np.ndarray
    differenced: bool

    @classmethod
    def of(cls, products: Sequence[tuple[np.ndarray, np.ndarray]], segments: int, *, differenced: bool) -> RowSpectra:
        """From each stretch's :func:`~.products.row_products`, averaged over the ``segments`` of all (its mean)."""
        zc = stretch_mean((p[0] for p in products), segments)
        cc = stretch_mean((p[1] for p in products), segments)
        return cls(zc[:, :, 0], zc[:, :, 1:], cc[:, 0, 0].real.copy(), cc[:, 1:, 0], cc[:, 1:, 1:], differenced)


class RecordSpectra:
    """The spectra of a record that the PMR needs: instruments at once, each output row on demand.

    The instruments' segment transforms are computed once; :meth:`row` filters
    the inputs through one row of the model, transforms that row's signals and
    crosses them with the instruments, so memory stays that of one row
    (a 32 x 32 model would need gigabytes for every row at once).

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    rr : ndarray, shape (F, n_z, n_z)
        Instrument spectra ``S_{z z}`` (the "r" of the names is the instrument
        vector z: the setpoints, dither columns and manual MVs that move).
    segments : int
        Welch segments averaged (over every stretch).
    equivalent_segments : float
        Independent segments they are worth (overlap).
    settings : WelchSettings
    differenced : ndarray of bool, shape (n_out,)
        Rows whose signals are differenced (integrating outputs).
    dithered : ndarray of bool, shape (n_in,)
        Inputs whose dither is an instrument.
    moving : InstrumentSet
        Which setpoints, dither columns and manual MVs are the instruments; which inputs never move.
    samples : int
        Samples of every stretch together.
    """

    def __init__(
        self,
        stretches: Sequence[Record],
        model: TransferMatrix,
        welch: WelchSettings,
        *,
        moving: InstrumentSet | None = None,
    ) -> None:
        self.model, self.settings = model, welch
        self.moving: InstrumentSet = moving_instruments(stretches) if moving is None else moving
        self.dithered, self.samples = self.moving.dither, total_samples(stretches)
        self.differenced = model.integrating_outputs
        warmup = model.settling_samples()
        self._data = [
            (np.asarray(s.u, dtype=float), np.asarray(s.y, dtype=float), warmup)
            for s in stretches
            if welch.segments(s.samples - warmup) > 0
        ]
        blocks = [self.moving.columns(s)[warmup:] for s in stretches]
        self._z, self.equivalent_segments = stretch_segments(blocks, welch)
        self.omega = self._z.omega
        self.segments = self._z.segments
        ends = np.cumsum([n for n in (welch.segments(b.shape[0]) for b in blocks) if n > 0])
        self._stretches = [slice(a, b) for a, b in zip((0, *ends[:-1]), ends, strict=True)]
        each = (SegmentSpectra(self.omega, self._z.ffts[k], welch) for k in self._stretches)
        self.rr = stretch_mean((s.cross(slice(None), slice(None), mean=False) for s in each), self.segments)

    @property
    def layout_inputs(self) -> dict:
        """What :func:`~pmr_ros.core.pmr.implicit.row_layout` reads of the data: instruments, dither, what moves."""
        return {"n_instruments": self.n_instruments, "dithered": self.dithered, "moving": self.moving}

    @property
    def n_instruments(self) -> int:
        """Instruments: the setpoints, dither columns and manual MVs that move."""
        return int(self._z.ffts.shape[2])

    def _row_segments(self, i: int, transform: Callable[[np.ndarray, np.ndarray], np.ndarray] | None) -> np.ndarray:
        """Segment FFTs, shape (F, K, q), of ``[y_i, x_i1 .. x_in]`` or of ``transform(x_i, u)`` per stretch.

        Each stretch as :meth:`row` takes it: filtered whole, differenced in an
        integrating row, its warm-up dropped, then cut into the instruments' segments.
        """
        blocks = []
        for u, y, warmup in self._data:
            x = row_regressors(self.model, u, i)
            block = np.column_stack([y[:, i], x]) if transform is None else transform(x, u)
            if self.differenced[i]:
                block = np.diff(block, axis=0, prepend=block[:1])
            blocks.append(block[warmup:])
        seg, _ = stretch_segments(blocks, self.settings)
        return np.transpose(seg.ffts, (1, 0, 2))

    def instrument_cross(
        self, i: int, transform: Callable[[np.ndarray, np.ndarray], np.ndarray], bins: np.ndarray | None = None
    ) -> np.ndarray:
        """Cross-spectra of the instruments with ``transform`` of row ``i``'s regressors, shape (F, n_z, q).

        Only at ``bins`` when given (shape (len(bins), n_z, q)).
        ``transform`` maps a stretch's regressors (N, n_in), filtered in the
        time domain over the whole stretch, and its inputs u (N, n_in) to q signals (N, q) (a
        :class:`~.piecewise.PiecewiseSpectra` passes the stretches of one length stacked on axis 1,
        ``(N, S, n_in)`` to ``(N, S, q)``); they are cut
        into the same segments as :meth:`row`'s.  A filter ``H`` applied in the
        time domain gives ``S_{z, H x}`` without the leakage of a Welch segment's
        edges, which ``H(w) S_{z x}`` has (:func:`~pmr_ros.core.pmr.parametric.fit.leakage_offset`).
        """
        Z, X = np.transpose(self._z.ffts, (1, 0, 2)), self._row_segments(i, transform)
        if bins is not None:
            Z, X = Z[bins], X[bins]
        return hermitian_product(Z, X) / X.shape[1]

    def row(self, i: int) -> RowSpectra:
        """The cross-spectra of row ``i``'s regression (each stretch's products summed: :func:`stretch_mean`)."""
        Z = np.transpose(self._z.ffts, (1, 0, 2))  # (F, K, n_z)
        X = self._row_segments(i, None)  # (F, K, 1 + n_in)
        products = [row_products(Z[:, k], X[:, k]) for k in self._stretches]
        return RowSpectra.of(products, self.segments, differenced=bool(self.differenced[i]))


def record_spectra(
    stretches: Sequence[Record], model: TransferMatrix, welch: WelchSettings, *, moving: InstrumentSet | None = None
) -> RecordSpectra:
    """The instrument spectra of a record, and each output row's regression on demand.

    Each stretch filtered through the model on its own, its first :meth:`TransferMatrix.settling_samples` dropped
    (the filters start from a guessed state), the segments of all averaged; a :data:`SPECTRA_SOURCE` may hold them.
    ``moving``: the stretches' :func:`~pmr_ros.core.records.moving_instruments`, when the caller has them.
    """
    source = SPECTRA_SOURCE.get()
    return (source and source(stretches, model, welch, moving=moving)) or RecordSpectra(
        stretches, model, welch, moving=moving
    )
