"""The implicit MIMO plant-model ratio estimate (the paper's eq. 13), frequency by frequency.

For output row i the estimate solves, at every frequency, the
instrument-correlated regression

    S_{z_l y_i}(w) = sum_k S_{z_l x_ik}(w) G_PMR_ik(w),   l = 1 .. n_instruments

with ``x_ik = Ghat_ik u_k`` the model's share of output i due to input k (the
reference ``u_k(t-1)`` in an empty cell, whose coefficient is the plant's
interaction itself; see :mod:`pmr_ros.core.pmr.spectra`) and z the instruments:
the setpoints and the MV dither columns that move.  Noise and disturbances
drop out because they are uncorrelated with z.  With more instruments than
regressors the equations are solved in the least-squares sense after
whitening the instruments (``S_zz^-1/2``), the frequency-domain two-stage
least squares; with as many, that is the paper's exact solution.

:func:`~pmr_ros.core.pmr.identifiable.row_layout` decides which regressors a
row's data can carry.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..records import Record
from ..sim.model import TransferMatrix
from .checks import check_stretches
from .identifiable import RowLayout, input_label, row_layout
from .products import hermitian_product
from .spectra import RecordSpectra, RowSpectra, WelchSettings, record_spectra

__all__ = [
    "Conditioning",
    "EstimateBuilder",
    "PmrEstimate",
    "RowEstimate",
    "RowLayout",
    "estimate_pmr",
    "implicit_estimate",
    "implicit_row",
    "input_label",
    "instrument_factor",
    "row_estimate",
    "row_layout",
    "spectra_factor",
    "whitened_row",
]

RIDGE = 1e-12
"""Relative ridge added to the instrument spectra before their Cholesky factor."""


class Conditioning:
    """The condition numbers of one row's regression (:func:`_condition`), each bin's computed when first asked.

    The verdicts read them on the fitted bins and the classic band only (a quarter of a window's bins); a
    bin's number is the same whichever bins are asked with it (one eigenvalue problem per bin).

    Parameters
    ----------
    zx : ndarray of complex, shape (F, n_z, n_c)
        The instruments' cross-spectra with the row's regressors that enter.
    rr : ndarray of complex, shape (F, n_z, n_z)
        The instrument spectra.
    """

    def __init__(self, zx: np.ndarray, rr: np.ndarray) -> None:
        self._zx, self._rr = zx, rr
        self._values = np.full(zx.shape[0], np.inf)
        self._known = np.full(zx.shape[0], zx.shape[2] == 0)  # no regressor: no regression, infinite

    def at(self, bins: np.ndarray | None = None) -> np.ndarray:
        """The condition numbers at ``bins`` (default every bin), shape (len(bins),)."""
        bins = np.arange(self._values.size) if bins is None else np.asarray(bins, dtype=int)
        missing = np.unique(bins[~self._known[bins]])
        if missing.size:
            self._values[missing] = _condition(self._zx[missing], self._rr[missing])
            self._known[missing] = True
        return self._values[bins]


@dataclass(frozen=True)
class RowEstimate:
    """The implicit estimate of one row.

    Attributes
    ----------
    ratio : ndarray of complex, shape (F, n_columns)
        ``G_PMR_ik(w)`` of the layout's columns.
    coherence : ndarray, shape (F,)
        Multiple squared coherence of the row's output with the instruments.
    conditioning : Conditioning
        Condition number of the regression, instruments and regressors scaled to unit power
        (:attr:`condition`, or :meth:`condition_at` some bins).
    power : ndarray, shape (F, n_columns)
        Instrument-driven power of each regressor, ``S_{x z} S_zz^-1 S_{z x}``.
    explained : ndarray, shape (F,)
        Instrument-driven power of the output, ``S_{y z} S_zz^-1 S_{z y}``.
    """

    ratio: np.ndarray
    coherence: np.ndarray
    conditioning: Conditioning
    power: np.ndarray
    explained: np.ndarray

    @property
    def condition(self) -> np.ndarray:
        """Condition number per bin, shape (F,)."""
        return self.conditioning.at()

    def condition_at(self, bins: np.ndarray) -> np.ndarray:
        """Condition number at ``bins`` only, shape (len(bins),)."""
        return self.conditioning.at(bins)


def instrument_factor(rr: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor ``L`` of the instrument spectra per bin (``S_zz = L L^H``), ridged."""
    ridge = RIDGE * np.trace(rr, axis1=1, axis2=2).real[:, None, None] * np.eye(rr.shape[1])
    return np.linalg.cholesky(rr + ridge)


def _gram(design: np.ndarray) -> np.ndarray:
    """``D^H D`` per bin, shape (F, n_c, n_c)."""
    return hermitian_product(design, design)


def _condition(zx: np.ndarray, rr: np.ndarray) -> np.ndarray:
    """Condition number per bin of the regression with instruments and regressors scaled to unit power.

    Not whitened: instruments that move together (nearly collinear setpoints)
    are exactly what it must show, and whitening would hide them.  From the
    eigenvalues of the Gram matrix: accurate to well beyond any threshold in use (1e6).
    """
    scale = np.sqrt(np.maximum(np.einsum("fll->fl", rr).real, 1e-300))
    design = zx / scale[:, :, None]
    design = design / np.maximum(np.linalg.norm(design, axis=1), 1e-300)[:, None, :]
    eigenvalues = np.linalg.eigvalsh(_gram(design))
    with np.errstate(divide="ignore", invalid="ignore"):
        condition = np.where(eigenvalues[:, 0] > 0, np.sqrt(eigenvalues[:, -1] / eigenvalues[:, 0]), np.inf)
    return np.nan_to_num(condition, nan=np.inf)


def _least_squares(design: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``argmin |target - design theta|`` per bin, shape (F, n_c).

    By the normal equations of the column-normalized design (the rows the
    methods read are well conditioned); by the pseudo-inverse, minimum norm,
    when a bin is singular.
    """
    norms = np.maximum(np.linalg.norm(design, axis=1), 1e-300)  # (F, n_c)
    scaled = design / norms[:, None, :]
    rhs = hermitian_product(scaled, target)
    try:
        solution = np.linalg.solve(_gram(scaled), rhs)
    except np.linalg.LinAlgError:
        solution = np.matmul(np.linalg.pinv(scaled), target)
    return solution[:, :, 0] / norms


def whitened_row(row: RowSpectra, factor: np.ndarray) -> np.ndarray:
    """``L^-1 [S_{z y_i}, S_{z x_i}]``, the row's equations with the instruments whitened, shape (F, n_z, 1 + n_in).

    One solve for the output and every regressor: LAPACK solves each right-hand side on its own, so a
    column of it is the same number as a solve of that column alone (and the factorization is done once).
    """
    return np.linalg.solve(factor, np.concatenate([row.zy[:, :, None], row.zx], axis=2))


def implicit_row(
    row: RowSpectra, rr: np.ndarray, factor: np.ndarray, columns: np.ndarray, *, whitened: np.ndarray | None = None
) -> RowEstimate:
    """Solve eq. (13) for one row at every frequency.

    Parameters
    ----------
    row : RowSpectra
    rr : ndarray, shape (F, n_z, n_z)
        The instrument spectra.
    factor : ndarray, shape (F, n_z, n_z)
        :func:`instrument_factor` of them.
    columns : ndarray of int
        The regressors that enter (a :class:`RowLayout`'s columns).
    whitened : ndarray, optional
        :func:`whitened_row` of ``row`` and ``factor`` when already at hand.
    """
    F = row.zy.shape[0]
    if whitened is None:
        whitened = whitened_row(row, factor)
    target = np.ascontiguousarray(whitened[:, :, :1])  # (F, n_z, 1), whitened instruments
    explained = np.sum(np.abs(target[:, :, 0]) ** 2, axis=1)
    coherence = np.clip(explained / np.maximum(row.yy, 1e-300), 0.0, 1.0)
    conditioning = Conditioning(row.zx[:, :, columns], rr)
    if columns.size == 0:
        return RowEstimate(np.empty((F, 0), dtype=complex), coherence, conditioning, np.empty((F, 0)), explained)
    design = np.ascontiguousarray(whitened[:, :, 1 + np.asarray(columns)])  # (F, n_z, n_c)
    power = np.sum(np.abs(design) ** 2, axis=1)
    ratio = _least_squares(design, target)
    return RowEstimate(ratio, coherence, conditioning, power, explained)


def _held(spectra: RecordSpectra, key: tuple, compute: Callable[[], Any]) -> Any:
    """``compute()``, kept by spectra that keep what their users share (a window's PiecewiseSpectra)."""
    held = getattr(spectra, "held", None)
    return compute() if held is None else held(key, compute)


def spectra_factor(spectra: RecordSpectra) -> np.ndarray:
    """:func:`instrument_factor` of ``spectra.rr``, computed once per window where the spectra keep it."""
    return _held(spectra, ("factor",), lambda: instrument_factor(spectra.rr))


def row_estimate(spectra: RecordSpectra, i: int, columns: np.ndarray, *, row: RowSpectra | None = None) -> RowEstimate:
    """:func:`implicit_row` of row ``i`` of ``spectra`` with regressors ``columns``.

    ``row`` is ``spectra.row(i)`` when the caller holds it already.  Spectra that keep their rows (a window's
    :class:`~.piecewise.PiecewiseSpectra`) keep this too: the parametric fit and the data-quality figures
    solve the same row with the same regressors, to the same numbers.
    """

    def compute() -> RowEstimate:
        spectra_row = spectra.row(i) if row is None else row
        # the row's whitening, kept too: its layouts (the classic one and the parametric one) share it
        whitened = _held(spectra, ("whitened", i), lambda: whitened_row(spectra_row, spectra_factor(spectra)))
        return implicit_row(spectra_row, spectra.rr, spectra_factor(spectra), columns, whitened=whitened)

    return _held(spectra, ("implicit", i, np.asarray(columns).tobytes()), compute)


@dataclass(frozen=True)
class PmrEstimate:
    """The estimated PMR matrix over frequency.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    ratio : ndarray of complex, shape (F, n_outputs, n_inputs)
        ``G_PMR_ik(w)``; for an empty cell the plant's interaction ``G_ik(w)``
        relative to its reference regressor; NaN where the row's layout has no column.
    coherence : ndarray, shape (F, n_outputs)
        Multiple squared coherence of output i with the instruments: the share
        of its spectrum they explain.
    conditioning : tuple of Conditioning or None
        Per row, the condition number of its regression, instruments and regressors scaled to unit power
        (:attr:`condition`, or :meth:`condition_at` some bins of a row); None: a row not estimated (infinite).
    segments : int
        Welch segments averaged.
    power : ndarray, shape (F, n_outputs, n_inputs)
        Instrument-driven power of each regressor (0 where the layout has no column).
    explained : ndarray, shape (F, n_outputs)
        Instrument-driven power of each output.
    layouts : tuple of RowLayout
        Each row's regressors.
    differenced : ndarray of bool, shape (n_outputs,)
        Rows estimated from differenced signals (integrating outputs).
    """

    omega: np.ndarray
    ratio: np.ndarray
    coherence: np.ndarray
    conditioning: tuple[Conditioning | None, ...]
    segments: int
    power: np.ndarray
    explained: np.ndarray
    layouts: tuple[RowLayout, ...]
    differenced: np.ndarray

    @property
    def condition(self) -> np.ndarray:
        """Condition number of each row's regression per bin, shape (F, n_outputs)."""
        return np.column_stack(
            [self.condition_at(np.arange(self.omega.size), i) for i in range(self.coherence.shape[1])]
        )

    def condition_at(self, bins: np.ndarray, i: int) -> np.ndarray:
        """Row ``i``'s condition numbers at ``bins`` only, shape (len(bins),)."""
        conditioning = self.conditioning[i]
        return np.full(np.size(bins), np.inf) if conditioning is None else conditioning.at(bins)


class EstimateBuilder:
    """Collects the row estimates of a record into a :class:`PmrEstimate`.

    Parameters
    ----------
    spectra : RecordSpectra
        The record whose rows are added.
    """

    def __init__(self, spectra: RecordSpectra) -> None:
        model = spectra.model
        F, n_out, n_in = spectra.omega.size, model.n_outputs, model.n_inputs
        self.spectra = spectra
        self.ratio = np.full((F, n_out, n_in), np.nan, dtype=complex)
        self.conditioning: list[Conditioning | None] = [None] * n_out
        self.coherence = np.zeros((F, n_out))
        self.power = np.zeros((F, n_out, n_in))
        self.explained = np.zeros((F, n_out))
        self.layouts: list[RowLayout] = []

    def add(self, layout: RowLayout, row: RowEstimate) -> None:
        """Row ``layout.row``'s estimate (rows are added in order)."""
        i = layout.row
        self.ratio[:, i, layout.columns] = row.ratio
        self.conditioning[i] = row.conditioning
        self.coherence[:, i] = row.coherence
        self.power[:, i, layout.columns] = row.power
        self.explained[:, i] = row.explained
        self.layouts.append(layout)

    def build(self) -> PmrEstimate:
        """The estimate of every row added."""
        return PmrEstimate(
            omega=self.spectra.omega,
            ratio=self.ratio,
            coherence=self.coherence,
            conditioning=tuple(self.conditioning),
            segments=self.spectra.segments,
            power=self.power,
            explained=self.explained,
            layouts=tuple(self.layouts),
            differenced=self.spectra.differenced.copy(),
        )


def implicit_estimate(spectra: RecordSpectra, *, test_empty: bool) -> PmrEstimate:
    """Solve eq. (13) row by row and frequency by frequency.

    Parameters
    ----------
    spectra : RecordSpectra
        The record's cross-spectra.
    test_empty : bool
        Whether empty cells get regressors (:func:`row_layout`).

    Returns
    -------
    PmrEstimate
    """
    model = spectra.model
    factor = instrument_factor(spectra.rr)
    builder = EstimateBuilder(spectra)
    for i in range(model.n_outputs):
        layout = row_layout(model, i, **spectra.layout_inputs, test_empty=test_empty)
        builder.add(layout, implicit_row(spectra.row(i), spectra.rr, factor, layout.columns))
    return builder.build()


def estimate_pmr(
    stretches: Sequence[Record], *, model: TransferMatrix, welch: WelchSettings, test_empty: bool = True
) -> PmrEstimate:
    """The implicit MIMO PMR estimate (eq. 13) from closed-loop data.

    Parameters
    ----------
    stretches : sequence of Record
        Unbroken stretches of setpoints, inputs and outputs (and dither).
    model : TransferMatrix
        The controller's model ``Ghat``.
    welch : WelchSettings
    test_empty : bool
        Whether empty cells get regressors where the instruments allow (:func:`row_layout`).

    Raises
    ------
    InsufficientData
        The data cannot support an estimate (see :func:`~pmr_ros.core.pmr.checks.check_stretches`).
    """
    check_stretches(stretches, model=model, welch=welch)
    return implicit_estimate(record_spectra(stretches, model, welch), test_empty=test_empty)
