"""The sampled FOPTD matrix and its one-source state-space realization (what the fast simulation steps)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["DiscreteFoptd", "StateSpace"]


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
    def one_source_form(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(pole, source, weight)`` per state: ``x+[j] = pole[j] x[j] + weight[j] [x; u][source[j]]``."""
        pole = np.diag(self.A).copy()
        feed = np.hstack([self.A - np.diag(pole), self.B])  # columns: states, then inputs
        if np.any(np.count_nonzero(feed, axis=1) > 1):
            raise ValueError("advance needs one source per state (the realization of TransferMatrix.state_space)")
        source = np.argmax(np.abs(feed), axis=1)
        return pole, source, feed[np.arange(feed.shape[0]), source]

    def advance(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``A x + B u`` for one state ``(nx,)`` or a batch ``(runs, nx)``, elementwise (same numbers either way).

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
        pole, source, weight = self.one_source_form
        return pole * x + weight * np.concatenate((x, u), axis=-1)[..., source]
