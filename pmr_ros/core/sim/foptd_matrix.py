"""The sampled FOPTD matrix and its one-source state-space realization (what the fast simulation steps).

A realization of elements of any order (:func:`~.realize.realize`) is a
:class:`StateSpace` too; it has states with several sources and is stepped
with the sparse products instead (:attr:`StateSpace.one_source`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

__all__ = ["DiscreteFoptd", "StateSpace", "foptd_state_space"]


@dataclass(frozen=True)
class DiscreteFoptd:
    """ZOH discretization of a FOPTD matrix, element-wise.

    Attributes
    ----------
    pole : ndarray, shape (n_outputs, n_inputs)
        ``a = exp(-Ts / tau)``.
    numerator : ndarray, shape (n_outputs, n_inputs)
        ``b = K (1 - a)``.
    delay_samples : ndarray of int, shape (n_outputs, n_inputs)
        Dead time in whole samples (the ZOH adds one more sample of lag).
    """

    pole: np.ndarray
    numerator: np.ndarray
    delay_samples: np.ndarray

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """Complex response at ``omega`` [rad/sample], shape (n_out, n_in, len(omega))."""
        z_inv = np.exp(-1j * np.asarray(omega, dtype=float))
        a = self.pole[..., None]
        b = self.numerator[..., None]
        d = self.delay_samples[..., None]
        return b * z_inv ** (1 + d) / (1.0 - a * z_inv)

    def filter_coefficients(self, i: int, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` polynomials in z^-1 of element (i, k) for ``scipy.signal.lfilter``."""
        d = int(self.delay_samples[i, k])
        num = np.zeros(d + 2)
        num[-1] = self.numerator[i, k]
        return num, np.array([1.0, -self.pole[i, k]])


@dataclass(frozen=True)
class StateSpace:
    """Discrete realization ``x+ = A x + B u``, ``y = C x`` of a transfer matrix.

    Each input feeds a shift register as long as its largest delay; each
    element is one first-order state reading the register tap of its delay.
    So every state has its own pole (0 for a register) and exactly one other
    source, a register tap or an input: :meth:`advance` steps it with two
    multiplications per state instead of the dense products.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray

    @cached_property
    def one_source(self) -> bool:
        """Whether every state has one source (the FOPTD realization): :meth:`advance` steps it elementwise."""
        feed = np.hstack([self.A - np.diag(np.diag(self.A)), self.B])
        return not np.any(np.count_nonzero(feed, axis=1) > 1)

    @cached_property
    def one_source_form(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(pole, source, weight)`` per state: ``x+[j] = pole[j] x[j] + weight[j] [x; u][source[j]]``."""
        pole = np.diag(self.A).copy()
        feed = np.hstack([self.A - np.diag(pole), self.B])  # columns: states, then inputs
        if not self.one_source:
            raise ValueError("advance needs one source per state (the realization of TransferMatrix.state_space)")
        source = np.argmax(np.abs(feed), axis=1)
        return pole, source, feed[np.arange(feed.shape[0]), source]

    @cached_property
    def sparse(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """``(A, B)`` as sparse matrices: a realization of general elements is mostly shift registers."""
        return sp.csr_matrix(self.A), sp.csr_matrix(self.B)

    def advance(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``A x + B u`` for one state ``(nx,)`` or a batch ``(runs, nx)`` (same numbers either way).

        Elementwise for a one-source realization, else by sparse products.

        Parameters
        ----------
        x : ndarray, shape (..., nx)
            State.
        u : ndarray, shape (..., n_inputs)
            Input held over the sample [input unit].

        Returns
        -------
        ndarray, shape (..., nx)
        """
        if not self.one_source:
            A, B = self.sparse
            x, u = np.asarray(x, dtype=float), np.asarray(u, dtype=float)
            if x.ndim == 1:
                return A @ x + B @ u
            return np.asarray((A @ x.T + B @ u.T).T)
        pole, source, weight = self.one_source_form
        return pole * x + weight * np.concatenate((x, u), axis=-1)[..., source]


def foptd_state_space(disc: DiscreteFoptd, present: np.ndarray) -> StateSpace:
    """The one-source realization of a sampled FOPTD matrix (``TransferMatrix.state_space`` of such a model).

    One first-order state per element that is there (row-major), reading
    the register tap of its delay; one shift register per input as long as
    its largest delay; empty cells have no state.

    Parameters
    ----------
    disc : DiscreteFoptd
        The sampled elements.
    present : ndarray of bool, shape (n_outputs, n_inputs)
        Where there is an element.

    Returns
    -------
    StateSpace
    """
    n_out, n_in = present.shape
    elements = [(int(i), int(k)) for i, k in zip(*np.nonzero(present), strict=False)]  # row-major
    lengths = np.where(present, disc.delay_samples, 0).max(axis=0)
    reg_start = len(elements) + np.concatenate(([0], np.cumsum(lengths)[:-1]))
    nx = len(elements) + int(lengths.sum())
    A = np.zeros((nx, nx))
    B = np.zeros((nx, n_in))
    C = np.zeros((n_out, nx))
    for k in range(n_in):
        if lengths[k] > 0:
            B[reg_start[k], k] = 1.0
            for t in range(1, lengths[k]):
                A[reg_start[k] + t, reg_start[k] + t - 1] = 1.0
    for e, (i, k) in enumerate(elements):
        A[e, e] = disc.pole[i, k]
        d = disc.delay_samples[i, k]
        if d == 0:
            B[e, k] = disc.numerator[i, k]
        else:
            A[e, reg_start[k] + d - 1] = disc.numerator[i, k]
        C[i, e] = 1.0
    return StateSpace(A, B, C)
