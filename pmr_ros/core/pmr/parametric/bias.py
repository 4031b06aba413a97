"""The finite-segment bias of a row's instrumental equations, and its removal.

A row's equations (:func:`~.ratio.row_system`) are the projection of the
segments' transforms of ``[y_i, x_i1 .. x_in]`` onto the instruments: at one
bin, over the K Welch segments, the whitened ``b`` and ``A`` are
``Q^H y / sqrt(K)`` and ``Q^H X / sqrt(K)``, ``Q`` an orthonormal basis of the
instruments' n_z columns.  In closed loop a regressor carries the controller's
answer to the output's noise: its noise part ``X_v`` is correlated with the
noise ``v`` across segments (``S_{x v}(w) != 0``: ``x`` depends on past ``v``).
The projection keeps n_z of the K dimensions of that correlation, so the
equations hold at the true parameters only up to ``n_z / K`` of the
regressors' noise correlation -- the many-instruments bias of instrumental
variables, which pulls the fit towards the per-bin least-squares one.  It
vanishes as the segments grow in number, but with few segments (a short
window), several instruments (setpoints *and* measured disturbances) and
instruments whose power falls steeply with frequency (rare steps) it is no
longer small beside the noise: measured on Wood-Berry with two setpoints
stepping rarely and two DVs (15 segments), every delay of a row came out one
sample late with 98-100 % confidence on half the seeds.

The part of the same moments orthogonal to the instruments (``R = full -
projected``, from ``S_{yy}``, ``S_{x y}``, ``S_{x x}``) carries that noise
correlation K - n_z times without the signal; ``lambda = n_z / (K - n_z)`` of
it taken from the projected moments leaves them unbiased (Nagar's k-class
correction, ``k = K / (K - n_z)``).  Overlapping segments repeat each other,
the instruments' as the noise's: the projection then keeps ``n_z K / M`` of
the noise dimensions (M the equivalent number of segments), and ``lambda =
n_z / (M - n_z)``.  A constant restores the cost's chi-square scale (its
expectation at the true parameters), which the reduced chi-square of the fit
reads.
"""

from __future__ import annotations

import numpy as np

from ..products import hermitian_product
from ..spectra import RowSpectra
from .ratio import RowSystem, bin_scale

__all__ = ["residual_moments", "unscaled_residual_moments", "without_instrument_bias"]


def residual_moments(
    spectra: RowSpectra,
    factor: np.ndarray,
    *,
    columns: np.ndarray,
    noise: np.ndarray,
    bins: np.ndarray,
    omega: np.ndarray,
    equivalent_segments: float,
) -> np.ndarray:
    """The moments of ``[y_i, x_i columns]`` outside the instruments, whitened as the row's equations, (F', n+1, n+1).

    Full moments (``S_yy``, ``S_xy``, ``S_xx``) less their projection on the
    instruments (``S_cz S_zz^-1 S_zc``), scaled as :func:`~.ratio.row_system` scales.
    """
    scale = bin_scale(noise, bins=bins, omega=omega, equivalent_segments=equivalent_segments)
    return unscaled_residual_moments(spectra, factor, columns=columns, bins=bins) * (scale**2)[:, None, None]


def unscaled_residual_moments(
    spectra: RowSpectra, factor: np.ndarray, *, columns: np.ndarray, bins: np.ndarray
) -> np.ndarray:
    """:func:`residual_moments` before the weights' scaling (which alone changes with the noise spectrum)."""
    xy = spectra.xy[bins][:, columns]
    full = np.empty((bins.size, columns.size + 1, columns.size + 1), dtype=complex)
    full[:, 0, 0] = spectra.yy[bins]
    full[:, 1:, 0] = xy
    full[:, 0, 1:] = xy.conj()
    full[:, 1:, 1:] = spectra.xx[bins][:, columns][:, :, columns]
    cz = np.concatenate([spectra.zy[bins][:, :, None], spectra.zx[bins][:, :, columns]], axis=2)
    whitened = np.linalg.solve(factor[bins], cz)
    projected = hermitian_product(whitened, whitened)
    return full - projected


def without_instrument_bias(
    system: RowSystem, residual: np.ndarray, *, instruments: int, equivalent_segments: float
) -> RowSystem:
    """``system`` with ``lambda = n_z / (M - n_z)`` of the residual moments taken out (see the module docstring).

    Parameters
    ----------
    system : RowSystem
        The row's equations.
    residual : ndarray, shape (F', n+1, n+1)
        :func:`residual_moments` of the same row, bins and weights.
    instruments : int
        n_z.
    equivalent_segments : float
        M, what the Welch segments are worth (overlap); ``system`` itself when M <= n_z + 1.
    """
    if equivalent_segments <= instruments + 1:
        return system
    lam = instruments / (equivalent_segments - instruments)
    # lam * residual[0, 0] expects 2 n_z at the true parameters in a complex bin, n_z in the real DC one:
    # added back, the cost keeps the scale of a chi-square with the system's components
    real = (np.abs(system.z_inv.imag) <= 1e-8) & (system.z_inv.real > 0)  # np.isclose(imag, 0.0) without its cost
    expected = np.where(real, 1.0, 2.0) * instruments
    return RowSystem(
        M=system.M - lam * residual[:, 1:, 1:],
        v=system.v - lam * residual[:, 1:, 0],
        beta=system.beta - lam * residual[:, 0, 0].real + expected,
        z_inv=system.z_inv,
        components=system.components,
    )
