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

from .lti import Element, Foptd, controllable_form

__all__ = ["cell_arrays", "element_outputs", "realize", "state_count"]


def _taps(b: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, bool] | None:
    """The register-tap weights ``c_1 .. c_L`` of an element that needs no state of its own, and its ramp flag.

    A finite impulse response (``a = 1``: a step-response curve) is
    ``sum_j c_j z^-j``; a ramp (``a = 1 - z^-1``: a ramp curve, an
    integrating element) is that plus ``c_L`` on every later sample, which one
    accumulator state sums.  None for other elements (own states).
    """
    if a.size == 1:
        return b[1:] / a[0], False
    if a.size == 2 and a[0] == 1.0 and a[1] == -1.0:
        return np.cumsum(b)[1:], True
    return None


def _registers(elements: Sequence[Sequence[Element]], n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """Per input: the register length and its first state.

    As long as the largest delay of the input's elements with own states,
    and as the longest delay plus tap weights of the elements read at taps.
    """
    lengths = np.zeros(n_in, dtype=int)
    for row in elements:
        for k, e in enumerate(row):
            disc = e.discrete()
            b, a = np.trim_zeros(disc.numerator, "b"), np.trim_zeros(disc.denominator, "b")
            if b.size:
                taps = _taps(b, a)
                lengths[k] = max(lengths[k], e.delay_samples + (taps[0].size if taps is not None else 0))
    return lengths, np.concatenate(([0], np.cumsum(lengths)[:-1]))


def realize(elements: Sequence[Sequence[Element]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``x+ = A x + B u``, ``y = C x`` for the matrix ``elements[i][k]`` (input k to output i).

    The input registers' states come first, then each element's own states
    (row-major, controllable canonical form), then one accumulator per ramp
    element.  An empty element has no state; a step-response curve (a finite
    impulse response) has none either: it reads the taps of its input's
    register, so a DMC model of N coefficients has about N states per input,
    not per element; a ramp curve or an integrating element adds one
    accumulator.

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
    lengths, start, own, tapped, nx = _layout(elements)
    n_reg = int(lengths.sum())
    A, B, C = np.zeros((nx, nx)), np.zeros((nx, n_in)), np.zeros((n_out, nx))
    for k in range(n_in):
        if lengths[k]:
            B[start[k], k] = 1.0
            span = np.arange(start[k] + 1, start[k] + lengths[k])
            A[span, span - 1] = 1.0
    at = n_reg
    for i, k, d, (Ae, Be, Ce, _) in own:
        n = Ae.shape[0]
        A[at : at + n, at : at + n] = Ae
        if d == 0:
            B[at : at + n, k] = Be[:, 0]
        else:
            A[at : at + n, start[k] + d - 1] = Be[:, 0]
        C[i, at : at + n] = Ce[0]
        at += n
    for i, first, weights, ramp in tapped:
        C[i, first : first + weights.size] += weights
        if ramp:  # the accumulator of everything older than the last tap
            A[at, at] = 1.0
            A[at, first + weights.size - 1] = 1.0
            C[i, at] = weights[-1]
            at += 1
    return A, B, C


def _layout(elements: Sequence[Sequence[Element]]) -> tuple[np.ndarray, np.ndarray, list, list, int]:
    """Register lengths and starts, the elements with own states and those read at taps, and the state count."""
    lengths, start = _registers(elements, len(elements[0]))
    own, tapped = _sort(elements, start)
    return (
        lengths,
        start,
        own,
        tapped,
        int(lengths.sum()) + sum(p[3][0].shape[0] for p in own) + sum(t[3] for t in tapped),
    )


def state_count(elements: Sequence[Sequence[Element]]) -> int:
    """The number of states of :func:`realize` of ``elements``, without forming its matrices.

    Examples
    --------
    >>> from pmr_ros.core.sim.rational import transfer_function
    >>> state_count([[transfer_function("1", "20, 12, 1", delay_samples=3, sample_time=1.0)]])  # 3 + 2
    5
    """
    return _layout(elements)[4]


def _sort(elements: Sequence[Sequence[Element]], start: np.ndarray) -> tuple[list, list]:
    """Elements with own states ``(i, k, delay, (A, B, C, D))`` and those read at taps ``(i, first tap, c, ramp)``."""
    own, tapped = [], []
    for i, row in enumerate(elements):
        for k, e in enumerate(row):
            disc = e.discrete()
            b, a = np.trim_zeros(disc.numerator, "b"), np.trim_zeros(disc.denominator, "b")
            if not b.size:
                continue
            taps = _taps(b, a)
            if taps is None:
                own.append((i, k, disc.delay_samples, controllable_form(b, a)))
            else:  # y_i += sum_j c_j u_k(t - d - j): register states d .. d + L - 1
                tapped.append((i, start[k] + disc.delay_samples, *taps))
    return own, tapped


def cell_arrays(
    elements: Sequence[Sequence[Element]], *, sample_time: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[tuple[Element | None, ...], ...]]:
    """The arrays a :class:`~.model.TransferMatrix` holds for the matrix ``elements[i][k]``.

    Parameters
    ----------
    elements : sequence of sequence of Element
        n_outputs rows of n_inputs elements, any type mixed.
    sample_time : float
        Ts [time unit]; every element must be sampled at it.

    Returns
    -------
    gain, time_constant, delay : ndarray, shape (n_outputs, n_inputs)
        Steady-state gain (ramp rate when integrating; 0 empty) [output unit / input unit],
        tau of FOPTD elements (NaN elsewhere) and dead time [time unit].
    element_type : ndarray of str
        Each element's ``kind``.
    general : tuple of tuple of (Element or None)
        The ``tf`` and ``step_response`` elements themselves, None elsewhere.

    Raises
    ------
    ValueError
        Rows of different lengths, or an element sampled at another time.
    """
    rows = [list(row) for row in elements]
    if not rows or not rows[0] or any(len(row) != len(rows[0]) for row in rows):
        raise ValueError("elements must be non-empty rows of equal length")
    shape = (len(rows), len(rows[0]))
    gain, tau, delay = np.zeros(shape), np.full(shape, np.nan), np.zeros(shape)
    kinds = np.empty(shape, dtype=object)
    general: list[list[Element | None]] = [[None] * shape[1] for _ in range(shape[0])]
    for i, row in enumerate(rows):
        for k, element in enumerate(row):
            if not np.isclose(element.sample_time, sample_time):
                raise ValueError(f"element ({i + 1}, {k + 1}) is sampled at {element.sample_time}, not {sample_time}")
            kinds[i, k] = element.kind
            delay[i, k] = element.delay_samples * sample_time
            gain[i, k] = 0.0 if element.kind == "none" else element.steady_state_gain
            if isinstance(element, Foptd):
                tau[i, k] = element.time_constant
            elif element.kind in ("tf", "step_response"):
                general[i][k] = element
    return gain, tau, delay, kinds, tuple(tuple(row) for row in general)


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
            b, a = _filter(b, disc.denominator)
            zi = np.zeros(max(b.size, a.size) - 1)
            if not e.integrating and a.size == 1:  # a FIR at rest at u[0]: each delay line holds the rest of the sum
                zi = u[0, k] * np.cumsum(b[::-1])[::-1][1:]
            elif not e.integrating:
                zi = lfilter_zi(b, a) * u[0, k]
            out[:, i, k] = lfilter(b, a, u[:, k], zi=zi)[0]
    return out


def _filter(b: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(b, a)`` for :func:`scipy.signal.lfilter`: a FIR as it is, else both padded to one length."""
    if a.size == 1:
        return b / a[0], np.ones(1)
    size = max(b.size, a.size)
    return np.pad(b, (0, size - b.size)), np.pad(a, (0, size - a.size))
