"""What one row's fit reads (:class:`RowData`) and its whitened equations at given weights.

The equations are :func:`~.ratio.row_system`'s, with the segments' leakage
taken out where the fit gives it (:func:`~.fit.leakage_offset`) and the
finite-segment bias of the instruments removed (:mod:`.bias`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from ..spectra import RecordSpectra, RowSpectra
from .bias import unscaled_residual_moments, without_instrument_bias
from .ratio import RowSystem, bin_scale, column_moments, noise_spectrum, row_system, whitened_regressors

__all__ = ["RowData"]


@dataclass(frozen=True)
class RowData:
    """What a row's fit reads.

    Attributes
    ----------
    spectra : RowSpectra
    factor : ndarray, shape (F, n_z, n_z)
        Cholesky factor of the instrument spectra.
    columns : ndarray of int
        The regressors that enter.
    bins : ndarray of int
        Frequency bins that enter the fit.
    omega : ndarray, shape (F,)
        All frequencies [rad/sample].
    equivalent_segments : float
    bin_correlation : float
        Of the Welch window (:attr:`~pmr_ros.core.pmr.spectra.WelchSettings.bin_correlation`).
    record : RecordSpectra or None
        The record the spectra come from, for :func:`~.fit.leakage_offset`; None
        (spectra without a record) fits without the leakage correction.
    row : int
        The output row of ``record``.
    unbiased : bool
        Whether the finite-segment bias of the instrumental equations is taken
        out (:mod:`.bias`); False fits the equations as they are.
    """

    spectra: RowSpectra
    factor: np.ndarray
    columns: np.ndarray
    bins: np.ndarray
    omega: np.ndarray
    equivalent_segments: float
    bin_correlation: float
    record: RecordSpectra | None = None
    row: int = 0
    unbiased: bool = False

    @cached_property
    def _whitened(self) -> np.ndarray:
        """The whitened regressors: the same at every weighting (:func:`~.ratio.whitened_regressors`)."""
        return whitened_regressors(self.spectra, self.factor, columns=self.columns, bins=self.bins)

    @cached_property
    def _moments(self) -> tuple[np.ndarray, np.ndarray]:
        """``(S_xy, S_xx)`` of the regressors that enter: every noise spectrum of the fit reads them."""
        return column_moments(self.spectra, self.columns)

    @cached_property
    def _residual(self) -> np.ndarray:
        """The moments outside the instruments before the weights (:func:`~.bias.unscaled_residual_moments`)."""
        return unscaled_residual_moments(self.spectra, self.factor, columns=self.columns, bins=self.bins)

    def system(self, theta: np.ndarray, offset: np.ndarray | None = None, *, debiased: bool = True) -> RowSystem:
        """The row's whitened equations, weighted with the noise left by coefficients ``theta`` (F, n).

        ``offset`` (F, n_z), when given, is taken from ``S_{z y}`` first: the
        segments' leakage at the current fit (:func:`~.fit.leakage_offset`).  With
        ``unbiased`` and ``debiased``, the finite-segment bias of the
        instrumental equations is taken out (:mod:`.bias`).
        """
        return self.systems(theta, offset, debiased=debiased)[0]

    def systems(
        self, theta: np.ndarray, offset: np.ndarray | None = None, *, debiased: bool = True
    ) -> tuple[RowSystem, RowSystem]:
        """:meth:`system` and the same equations without the bias correction (the same when there is none).

        The one noise spectrum and whitening serve both.
        """
        noise = noise_spectrum(self.spectra, self.columns, theta, self.omega, moments=self._moments)
        spectra = self.spectra if offset is None else replace(self.spectra, zy=self.spectra.zy - offset)
        bins, omega, segments = self.bins, self.omega, self.equivalent_segments
        shared: dict[str, Any] = {
            "columns": self.columns,
            "noise": noise,
            "bins": bins,
            "omega": omega,
            "equivalent_segments": segments,
        }
        system = row_system(spectra, self.factor, whitened=self._whitened, **shared)
        if not (debiased and self.unbiased):
            return system, system
        # the moments outside the instruments from the spectra as measured: the leakage offset is the instruments'
        scale = bin_scale(noise, bins=bins, omega=omega, equivalent_segments=segments)
        residual = self._residual * (scale**2)[:, None, None]  # residual_moments(self.spectra, self.factor, **shared)
        corrected = without_instrument_bias(
            system,
            residual,
            instruments=int(self.factor.shape[1]),
            equivalent_segments=self.equivalent_segments,
        )
        return corrected, system
