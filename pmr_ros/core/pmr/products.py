"""Complex matrix products as real ones.

The diagnosis multiplies many small complex matrices (a row's spectra, one
matrix per frequency bin).  OpenBLAS runs a complex product of that size on
several threads, and on a machine whose cores are busy with other work those
threads wait for each other: measured on the 2-core development machine at a
load of 8, a 41 x 200 by 200 x 12 complex product took 8 ms by ``zgemm`` and
27 us as four real products.  The four real products are also what a
complex product costs in arithmetic, so nothing is lost when the machine is idle
(the results agree to rounding, 1e-13 relative).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = ["hermitian_product", "product", "real_product", "row_products", "stretch_mean"]


def product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` (broadcast over leading axes like ``numpy.matmul``) from four real products.

    Parameters
    ----------
    a : ndarray, shape (..., m, k)
    b : ndarray, shape (..., k, n)
    """
    ar, ai = np.real(a), np.imag(a)
    br, bi = np.real(b), np.imag(b)
    return (ar @ br - ai @ bi) + 1j * (ar @ bi + ai @ br)


def real_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``Re(a @ b)``, the real part :func:`product` computes, from two real products instead of four.

    Parameters
    ----------
    a : ndarray, shape (..., m, k)
    b : ndarray, shape (..., k, n)
    """
    return np.real(a) @ np.real(b) - np.imag(a) @ np.imag(b)


def hermitian_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``conj(a).T @ b`` over the last two axes (leading axes broadcast), from four real products.

    Parameters
    ----------
    a : ndarray, shape (..., k, m)
    b : ndarray, shape (..., k, n)
    """
    ar, ai = np.swapaxes(np.real(a), -1, -2), np.swapaxes(np.imag(a), -1, -2)
    br, bi = np.real(b), np.imag(b)
    if min(a.shape[-1], b.shape[-1]) < 2:  # a matrix-vector product: kept as it is, numpy's path for it
        return (ar @ br + ai @ bi) + 1j * (ar @ bi - ai @ br)
    # the real and imaginary parts made contiguous first (numpy copies strided operands per matrix otherwise,
    # measured at twice the time of a window's cross-spectra), and written straight into the result
    ar, ai, br, bi = (np.ascontiguousarray(part) for part in (ar, ai, br, bi))
    real = ar @ br + ai @ bi
    out = np.empty(real.shape, dtype=np.result_type(a, b, 1j))
    out.real, out.imag = real, ar @ bi - ai @ br
    return out


def row_products(Z: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(sum_k conj(Z_k)^T X_k, sum_k conj(X_k)^T X_k)`` over one stretch's segments (Z (F, K, n_z), X (F, K, q))."""
    return hermitian_product(Z, X), hermitian_product(X, X)


def stretch_mean(parts: Iterable[np.ndarray], segments: int) -> np.ndarray:
    """Each stretch's product summed in order, over the ``segments`` of all: the cross-spectrum they average.

    A sum over stretches, so that a rolling window's spectra are the sums of its stretches' products, each
    computed once (:mod:`.piecewise`), to the same bits as the window alone.
    """
    total: np.ndarray | None = None
    for part in parts:
        total = part if total is None else total + part
    if total is None:
        raise ValueError("no stretch holds a segment")
    return total / segments
