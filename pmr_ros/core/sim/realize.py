"""A matrix of elements of any type as one discrete state-space system, and its per-element outputs.

What the plant simulation and the MPC prediction need of a model whatever
its elements are (:class:`~.lti.Element`): :func:`realize` generalises the
one-state-per-FOPTD realization of the transfer matrices so far (one shift
register per input as long as its largest delay; each element's own states
read the register tap of its delay) to elements of any order;
:func:`element_outputs` filters the inputs through every element, as the
spectra of the diagnosis use them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import lfilter, lfilter_zi

from .lti import Element, controllable_form

__all__ = ["element_outputs", "realize"]


def _registers(elements: Sequence[Sequence[Element]], n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """Per input: the register length (its largest delay among elements with states) and its first state."""
    lengths = np.zeros(n_in, dtype=int)
    for row in elements:
        for k, e in enumerate(row):
            if np.any(e.discrete().numerator != 0):
                lengths[k] = max(lengths[k], e.delay_samples)
    return lengths, np.concatenate(([0], np.cumsum(lengths)[:-1]))


def realize(elements: Sequence[Sequence[Element]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``x+ = A x + B u``, ``y = C x`` for the matrix ``elements[i][k]`` (input k to output i).

    The input registers' states come first, then each element's own states
    (row-major, controllable canonical form); an empty element has none.

    Parameters
    ----------
    elements : sequence of sequence of Element
        n_outputs rows of n_inputs elements, one sample time.

    Returns
    -------
    A, B, C : ndarray
        Shapes (nx, nx), (nx, n_inputs), (n_outputs, nx).
    """
    n_out, n_in = len(elements), len(elements[0])
    lengths, start = _registers(elements, n_in)
    parts = []
    for i, row in enumerate(elements):
        for k, e in enumerate(row):
            disc = e.discrete()
            b, a = np.trim_zeros(disc.numerator, "b"), np.trim_zeros(disc.denominator, "b")
            if b.size:
                parts.append((i, k, disc.delay_samples, controllable_form(b, a)))
    n_reg = int(lengths.sum())
    nx = n_reg + sum(p[3][0].shape[0] for p in parts)
    A, B, C = np.zeros((nx, nx)), np.zeros((nx, n_in)), np.zeros((n_out, nx))
    for k in range(n_in):
        if lengths[k]:
            B[start[k], k] = 1.0
            span = np.arange(start[k] + 1, start[k] + lengths[k])
            A[span, span - 1] = 1.0
    at = n_reg
    for i, k, d, (Ae, Be, Ce, _) in parts:
        n = Ae.shape[0]
        A[at : at + n, at : at + n] = Ae
        if d == 0:
            B[at : at + n, k] = Be[:, 0]
        else:
            A[at : at + n, start[k] + d - 1] = Be[:, 0]
        C[i, at : at + n] = Ce[0]
        at += n
    return A, B, C


def element_outputs(elements: Sequence[Sequence[Element]], u: np.ndarray) -> np.ndarray:
    """Per-element outputs ``yhat_ik = G_ik u_k``, shape (N, n_outputs, n_inputs).

    Parameters
    ----------
    elements : sequence of sequence of Element
        n_outputs rows of n_inputs elements.
    u : ndarray, shape (N, n_inputs)
        Inputs.  Stable elements start at steady state for ``u[0]``; the true
        initial state is unknown, so drop their settling samples before use.
        Integrating elements start at zero (they have no steady state).

    Returns
    -------
    ndarray
    """
    u = np.asarray(u, dtype=float)
    out = np.zeros((u.shape[0], len(elements), len(elements[0])))
    for i, row in enumerate(elements):
        for k, e in enumerate(row):
            disc = e.discrete()
            if not np.any(disc.numerator != 0):
                continue
            b = np.concatenate((np.zeros(disc.delay_samples), disc.numerator))
            a = disc.denominator
            size = max(b.size, a.size)
            b, a = np.pad(b, (0, size - b.size)), np.pad(a, (0, size - a.size))
            zi = np.zeros(size - 1) if e.integrating else lfilter_zi(b, a) * u[0, k]
            out[:, i, k] = lfilter(b, a, u[:, k], zi=zi)[0]
    return out
