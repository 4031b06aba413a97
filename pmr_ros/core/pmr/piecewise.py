"""Spectra of overlapping windows from pieces computed once: each unbroken stretch filtered and transformed once.

Rolling windows (14 days stepped by one) share all but one day of their data.
A window's spectra are built from its unbroken stretches, each on its own
(:class:`~pmr_ros.core.pmr.spectra.RecordSpectra`: filtered through the model,
its warm-up dropped, cut into Welch segments); the segments of all stretches
are then averaged.  A stretch that several windows hold whole -- the same
samples, the same means removed -- gives every one of them the same segments.
:class:`PieceCache` keeps, per stretch (its first and last sample in the whole
record), what every window would compute again: the instruments' segment
transforms, each row's regressors and their segment transforms, and the
products of those transforms (each stretch's sums over its segments).  A
window's spectra (:class:`PiecewiseSpectra`) join its stretches' pieces in
order and sum their products in order, as :class:`RecordSpectra` does with a
window alone (:func:`~.products.stretch_mean`), so every fit after them runs on
the same numbers: the same diagnosis to the last bit (test_piecewise.py).

Only what the current window holds is kept: a worker that runs consecutive
windows computes one new day per window, and its memory stays one window's.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from ..records import InstrumentSet, Record, moving_instruments, total_samples
from ..sim.model import TransferMatrix
from .products import row_products, stretch_mean
from .regressors import row_regressors
from .spectra import (
    RecordSpectra,
    RowSpectra,
    SegmentSpectra,
    WelchSettings,
    segment_spectra,
)
from .spectra_source import SPECTRA_SOURCE

__all__ = ["PieceCache", "PiecewiseSpectra", "stacked_segment_ffts"]

Span = tuple[int, int]


def _signature(moving: InstrumentSet) -> tuple[bytes, ...]:
    """A key of the instrument set (which columns are instruments)."""
    parts = (moving.setpoints, moving.dither, moving.manual)
    return tuple(np.asarray(p, dtype=bool).tobytes() for p in parts)


def stacked_segment_ffts(blocks: np.ndarray, settings: WelchSettings) -> np.ndarray:
    """:func:`~.spectra.segment_spectra`'s ``ffts`` of S blocks of one length at once, shape (S, K, F, q).

    ``blocks`` (N, S, q): block ``j`` is ``blocks[:, j]``.  Each block's means come from its own contiguous
    samples, its segments are cut, tapered, transformed and scaled as one block's call does them: the same
    numbers (test_piecewise.py), in one call instead of one per day-long stretch.

    Parameters
    ----------
    blocks : ndarray, shape (N, S, q)
    settings : WelchSettings
    """
    x = np.ascontiguousarray(np.transpose(np.asarray(blocks, dtype=float), (1, 0, 2)))  # (S, N, q): each a block
    x = x - x.mean(axis=1)[:, None, :]
    L = settings.segment_length
    frames = sliding_window_view(x, L, axis=1)[:, :: settings.step][:, : settings.segments(x.shape[1])]  # (S,K,q,L)
    taper = settings.taper
    X = np.fft.rfft(frames * taper, axis=-1)  # (S, K, q, F)
    scale = np.full(X.shape[-1], np.sqrt(2.0 / np.sum(taper**2)))
    scale[0] = np.sqrt(1.0 / np.sum(taper**2))
    if L % 2 == 0:
        scale[-1] = scale[0]
    return np.swapaxes(X * scale, 2, 3)


class PieceCache:
    """Per stretch of one record, its instruments' and rows' segment transforms and its rows' regressors.

    Parameters
    ----------
    model : TransferMatrix
        The controller's model ``Ghat`` every window is diagnosed with (a
        diagnosis with another model, e.g. augmented with DVs, is computed as usual).

    Examples
    --------
    >>> cache = PieceCache(model)  # doctest: +SKIP
    >>> with cache.window(stretches, spans):                            # doctest: +SKIP
    ...     diagnosis = diagnose_stretches(stretches, model=model, ...)
    """

    def __init__(self, model: TransferMatrix) -> None:
        self.model = model
        self._spans: dict[int, Span] = {}
        self._window: dict[tuple[Any, ...], PiecewiseSpectra] = {}
        self._store: dict[tuple[Any, ...], Any] = {}
        self.computed = 0
        """Pieces computed so far (instrument transforms of one stretch), for the tests and the benchmark."""

    @contextmanager
    def window(self, stretches: Sequence[Record], spans: Sequence[Span]) -> Iterator[PieceCache]:
        """Within the block, :func:`~pmr_ros.core.pmr.spectra.record_spectra` of these stretches comes from pieces.

        ``spans`` are the stretches' first and last samples in the whole record
        (the same span: the same samples, prepared the same way).  Pieces of
        spans outside this window are dropped first.
        """
        self._spans = {id(s): (int(a), int(b)) for s, (a, b) in zip(stretches, spans, strict=True)}
        held = set(self._spans.values())
        self._store = {key: value for key, value in self._store.items() if key[0] in held}
        token = SPECTRA_SOURCE.set(self.spectra)
        try:
            yield self
        finally:
            SPECTRA_SOURCE.reset(token)
            self._spans, self._window = {}, {}

    def spectra(
        self,
        stretches: Sequence[Record],
        model: TransferMatrix,
        welch: WelchSettings,
        *,
        moving: InstrumentSet | None = None,
    ) -> PiecewiseSpectra | None:
        """The spectra of ``stretches`` from pieces, or None when a stretch or the model is not this window's."""
        spans = [self._spans.get(id(s)) for s in stretches]
        if model is not self.model or any(span is None for span in spans):
            return None
        key = (tuple(spans), welch)  # the parametric fit and the data-quality figures ask for the same
        if key not in self._window:
            held = [span for span in spans if span is not None]
            self._window[key] = PiecewiseSpectra(self, stretches, held, welch, moving=moving)
        return self._window[key]

    def _held(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        if key not in self._store:
            self._store[key] = compute()
        return self._store[key]

    def instruments(self, span: Span, columns: np.ndarray, welch: WelchSettings, moving: InstrumentSet) -> Any:
        """The segment transforms of one stretch's instrument columns (its warm-up dropped)."""

        def compute() -> SegmentSpectra:
            self.computed += 1
            return segment_spectra(columns, welch)

        return self._held((span, "z", welch, _signature(moving)), compute)

    def stretch(self, span: Span, compute: Callable[[], Record]) -> Record:
        """The stretch ``span`` as the windows cut it (``compute()`` gives it), kept while the windows hold it.

        Asked before :meth:`window` (which drops the spans the new window does not hold), so that a window
        takes the stretches it shares with the window before from it.
        """
        return self._held((span, "stretch"), compute)

    def regressors(self, span: Span, u: np.ndarray, i: int) -> np.ndarray:
        """Row ``i``'s regressors of one stretch, undifferenced (:func:`~.regressors.row_regressors`)."""
        return self._held((span, "x", i), lambda: row_regressors(self.model, u, i))

    def row_segments(self, span: Span, i: int, welch: WelchSettings, compute: Callable[[], Any]) -> Any:
        """The segment transforms of row ``i``'s ``[y_i, x_i]`` of one stretch (``compute()`` gives them)."""
        return self._held((span, "row", i, welch), compute)

    def product(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        """A product of one stretch's transforms (``key`` starts with its span), ``compute()`` once."""
        return self._held(key, compute)


class PiecewiseSpectra(RecordSpectra):
    """:class:`RecordSpectra` of a window whose stretches' transforms come from a :class:`PieceCache`.

    Equal to ``RecordSpectra(stretches, model, welch)``: the same segments in
    the same order, averaged the same way.
    """

    def __init__(
        self,
        cache: PieceCache,
        stretches: Sequence[Record],
        spans: Sequence[Span],
        welch: WelchSettings,
        *,
        moving: InstrumentSet | None = None,
    ):
        model = cache.model
        self.model, self.settings, self._cache = model, welch, cache
        self._rows: dict[int, RowSpectra] = {}
        self._kept: dict[tuple[Any, ...], Any] = {}
        self.moving = moving_instruments(stretches) if moving is None else moving
        self.dithered, self.samples = self.moving.dither, total_samples(stretches)
        self.differenced = model.integrating_outputs
        warmup = model.settling_samples()
        kept = [(s, span) for s, span in zip(stretches, spans, strict=True) if welch.segments(s.samples - warmup) > 0]
        self._pieces = [(np.asarray(s.u, dtype=float), np.asarray(s.y, dtype=float), span) for s, span in kept]
        self._warmup = warmup
        self._data = [(u, y, warmup) for u, y, _ in self._pieces]
        parts = [cache.instruments(span, self.moving.columns(s)[warmup:], welch, self.moving) for s, span in kept]
        self._parts = parts
        self._z = SegmentSpectra(parts[0].omega, np.concatenate([p.ffts for p in parts], axis=0), welch)
        self.equivalent_segments = sum(welch.equivalent_segments(p.segments) for p in parts)
        self.omega = self._z.omega
        self.segments = self._z.segments
        self._signature = _signature(self.moving)
        sums = [
            cache.product((span, "zz", welch, self._signature), partial(p.cross, slice(None), slice(None), mean=False))
            for (_, span), p in zip(kept, parts, strict=True)
        ]
        self.rr = stretch_mean(sums, self.segments)

    def held(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        """``compute()`` once per window and ``key`` (:func:`~.implicit.row_estimate`: the same numbers)."""
        if key not in self._kept:
            self._kept[key] = compute()
        return self._kept[key]

    def row(self, i: int) -> RowSpectra:
        """:meth:`RecordSpectra.row` from each stretch's products, computed once per stretch and row.

        Kept per window too (the window's fit and data quality both read it).
        """
        if i not in self._rows:
            products = [
                self._cache.product(
                    (span, "row products", i, self.settings, self._signature),
                    partial(self._products, z, u, y, span, i),
                )
                for z, (u, y, span) in zip(self._parts, self._pieces, strict=True)
            ]
            self._rows[i] = RowSpectra.of(products, self.segments, differenced=bool(self.differenced[i]))
        return self._rows[i]

    def _products(
        self, z: SegmentSpectra, u: np.ndarray, y: np.ndarray, span: Span, i: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """One stretch's :func:`~.products.row_products` of row ``i``."""
        x = self._cache.row_segments(span, i, self.settings, partial(self._row_part, u, y, span, i))
        return row_products(np.transpose(z.ffts, (1, 0, 2)), np.transpose(x.ffts, (1, 0, 2)))

    def _block(self, x: np.ndarray, i: int) -> np.ndarray:
        """A stretch's block as :meth:`RecordSpectra._row_segments` prepares it: differenced, warm-up dropped."""
        if self.differenced[i]:
            x = np.diff(x, axis=0, prepend=x[:1])
        return x[self._warmup :]

    def _row_segments(self, i: int, transform: Callable[..., np.ndarray] | None) -> np.ndarray:
        """:meth:`RecordSpectra._row_segments` with each stretch's regressors and row transforms held."""
        if transform is None:
            parts = [
                self._cache.row_segments(span, i, self.settings, partial(self._row_part, u, y, span, i))
                for u, y, span in self._pieces
            ]
        else:
            parts = self._transformed(i, transform)
        return np.transpose(np.concatenate([p.ffts for p in parts], axis=0), (1, 0, 2))

    def _transformed(self, i: int, transform: Callable[..., np.ndarray]) -> list[SegmentSpectra]:
        """Each stretch's segment transforms of ``transform(x_i, u)``, the stretches of one length in one call.

        ``transform`` gets them stacked on axis 1, ``(N, S, n_in)``: a day-long stretch per day makes a
        window's model output (:func:`~.parametric.fit.leakage_offset`) 14 calls of its filters instead of
        14 per stretch; each stretch's samples go through the same arithmetic, so the numbers are the same.
        """
        by_length: dict[int, list[int]] = {}
        for j, (u, _, _) in enumerate(self._pieces):
            by_length.setdefault(u.shape[0], []).append(j)
        parts: list[Any] = [None] * len(self._pieces)
        for group in by_length.values():
            # the stacks are the window's (the fit's leakage rounds transform them again)
            x = self.held(("stacked x", i, tuple(group)), partial(self._stacked, group, i))
            u = self.held(("stacked u", tuple(group)), partial(self._stacked, group, None))
            ffts = stacked_segment_ffts(self._block(transform(x, u), i), self.settings)
            for place, j in enumerate(group):
                parts[j] = SegmentSpectra(self.omega, ffts[place], self.settings)
        return parts

    def _stacked(self, group: Sequence[int], i: int | None) -> np.ndarray:
        """Row ``i``'s regressors (None: the inputs) of the stretches ``group``, stacked on axis 1."""
        if i is None:
            return np.stack([self._pieces[j][0] for j in group], axis=1)
        return np.stack([self._cache.regressors(self._pieces[j][2], self._pieces[j][0], i) for j in group], axis=1)

    def _row_part(self, u: np.ndarray, y: np.ndarray, span: Span, i: int) -> SegmentSpectra:
        """One stretch's segment transforms of ``[y_i, x_i1 .. x_in]``."""
        x = self._cache.regressors(span, u, i)
        return segment_spectra(self._block(np.column_stack([y[:, i], x]), i), self.settings)
