"""Whether the data separate each element of a row from the others: identifiability from the information matrix.

A row's condition number says whether its regression as a whole is well
posed; it does not say whether one element's parameters can be told from a
neighbour's.  In closed loop the controller moves its inputs together, and
two elements whose filtered inputs move together over the fitted band trade
gain for gain (and delay for delay) at almost no cost in fit.  From the
Gauss-Newton information matrix ``I`` of the row at its fit:

* **collinearity** of element k: the share of its gain's information that
  the other columns' parameters account for, ``1 - S_kk / I_kk`` with ``S``
  the Schur complement of the others' block -- the multiple squared
  coherence of its filtered input with the others' in the fit's weighting
  (0: fully separable, 1: indistinguishable; the variance-inflation factor
  is ``1 / (1 - collinearity)``).  The *partner* is the column with the
  largest pairwise squared coherence with it;
* **delay correlation** of element k: the largest correlation of its
  (continuous) delay's estimate with its own time constant's or with any
  other column's delay or time constant, from the inverse of the
  information matrix extended by ``d theta / d D = -j w theta``.  A delay
  that trades off against a time constant or another delay cannot be read
  one coordinate at a time (:mod:`.fit` then searches the pair jointly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lsq import RowParameters, RowProblem

__all__ = ["Separation", "delay_coupling", "separation"]


@dataclass(frozen=True)
class Separation:
    """How well the data separate each column of a row from the others.

    Attributes
    ----------
    collinearity : ndarray, shape (n,)
        Share of column k's gain information the other columns account for, 0..1.
    partner : ndarray of int, shape (n,)
        The column most coherent with column k (-1 alone in its row).
    partner_coherence : ndarray, shape (n,)
        Their pairwise squared coherence in the fit's weighting, 0..1.
    delay_correlation : ndarray, shape (n,)
        Largest absolute correlation of column k's delay estimate with a time
        constant (its own or another's) or another delay (NaN without a delay to judge).
    delay_rival : ndarray of int, shape (n,)
        Whose parameter that is: the column (k itself: its own time constant; -1: none).
    delay_rival_is_tau : ndarray of bool, shape (n,)
        Whether the rival parameter is a time constant (else a delay).
    delay_coupling : ndarray, shape (n, n)
        Absolute correlation of the delay estimates of two columns (0 on the
        diagonal and where a column has no delay): the pairs whose delays
        :mod:`.joint` searches together.
    """

    collinearity: np.ndarray
    partner: np.ndarray
    partner_coherence: np.ndarray
    delay_correlation: np.ndarray
    delay_rival: np.ndarray
    delay_rival_is_tau: np.ndarray
    delay_coupling: np.ndarray


def _collinearity(info: np.ndarray, owner: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column: share of its gain's information the others explain, its partner and their pairwise coherence."""
    diagonal = np.maximum(np.diag(info), 1e-300)
    coherence = info[:n, :n] ** 2 / np.outer(diagonal[:n], diagonal[:n])
    np.fill_diagonal(coherence, -1.0)
    collinearity, partner = np.zeros(n), np.full(n, -1)
    pair = np.zeros(n)
    for k in range(n):
        others = np.flatnonzero(owner != k)
        if others.size == 0:
            continue
        block = info[others][:, others]  # np.ix_'s block without its cost
        cross = info[k, others]
        explained = float(cross @ np.linalg.lstsq(block, cross, rcond=1e-12)[0])
        collinearity[k] = float(np.clip(explained / diagonal[k], 0.0, 1.0))
        partner[k] = int(np.argmax(coherence[k]))
        pair[k] = float(np.clip(coherence[k, partner[k]], 0.0, 1.0))
    return collinearity, partner, pair


def _delay_coupling(correlation: np.ndarray, owner: np.ndarray, kinds: np.ndarray, n: int) -> np.ndarray:
    """``|corr(D_k, D_m)|`` per pair of columns (0 where either has no delay, and on the diagonal)."""
    coupling = np.zeros((n, n))
    rows = np.flatnonzero(kinds == 2)
    cols = owner[rows]
    coupling[np.ix_(cols, cols)] = np.minimum(correlation[np.ix_(rows, rows)], 1.0)
    np.fill_diagonal(coupling, 0.0)
    return coupling


def _delay_correlation(
    correlation: np.ndarray, owner: np.ndarray, kinds: np.ndarray, delayed: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column: the largest |correlation| of its delay with a time constant or another delay, and whose."""
    n = delayed.size
    out, rival, is_tau = np.full(n, np.nan), np.full(n, -1), np.zeros(n, dtype=bool)
    for k in np.flatnonzero(delayed):
        row = np.flatnonzero((owner == k) & (kinds == 2))[0]
        candidates = np.flatnonzero((kinds == 1) | ((kinds == 2) & (owner != k)))
        if candidates.size == 0:
            out[k] = 0.0
            continue
        best = candidates[int(np.argmax(correlation[row, candidates]))]
        out[k], rival[k], is_tau[k] = float(min(correlation[row, best], 1.0)), int(owner[best]), bool(kinds[best] == 1)
    return out, rival, is_tau


def _information(problem: RowProblem, params: RowParameters) -> tuple[np.ndarray, ...]:
    """``(info, owner, kinds, delayed)``: the information extended by the delays, each parameter's column and kind."""
    n = problem.n
    coefficients = problem.coefficients(params)
    derivatives, owner = problem.jacobian(coefficients)
    delayed = np.array([not c.interaction for c in problem.columns], dtype=bool)
    omega = -np.angle(problem.system.z_inv)
    d_delay = -1j * omega[:, None] * coefficients.theta[:, delayed]
    derivatives = np.concatenate([derivatives, d_delay], axis=1)
    owner = np.concatenate([owner, np.flatnonzero(delayed)])
    kinds = np.concatenate(
        [np.zeros(n, dtype=int), np.ones(problem.free_tau.size, dtype=int), np.full(delayed.sum(), 2)]
    )
    M = problem.system.M[:, owner][:, :, owner]
    info = np.einsum("fp,fpq,fq->pq", derivatives.conj(), M, derivatives).real
    return info, owner, kinds, delayed


def _correlation(info: np.ndarray) -> np.ndarray:
    """``|corr|`` of the parameters' estimates: the (pseudo-)inverse of the information, normalized."""
    scale = 1.0 / np.sqrt(np.maximum(np.diag(info), 1e-300))
    covariance = np.linalg.pinv(info * np.outer(scale, scale), rcond=1e-12, hermitian=True)
    sd = np.sqrt(np.maximum(np.diag(covariance), 1e-300))
    return np.abs(covariance / np.outer(sd, sd))


def delay_coupling(problem: RowProblem, params: RowParameters) -> np.ndarray:
    """:func:`separation`'s ``delay_coupling`` alone, the same numbers: what the delay search reads.

    Without the collinearity's least-squares solve per column, which the search does not read.

    Parameters
    ----------
    problem : RowProblem
    params : RowParameters
        As :func:`separation`.
    """
    info, owner, kinds, _ = _information(problem, params)
    return _delay_coupling(_correlation(info), owner, kinds, problem.n)


def separation(problem: RowProblem, params: RowParameters) -> Separation:
    """The :class:`Separation` of a row's columns at its fitted ``params``.

    Parameters
    ----------
    problem : RowProblem
        The row's final weighted problem.
    params : RowParameters
        Its fit.
    """
    n = problem.n
    info, owner, kinds, delayed = _information(problem, params)
    base = kinds < 2
    collinearity, partner, pair = _collinearity(info[np.ix_(base, base)], owner[base], n)
    correlation = _correlation(info)
    delay_correlation, rival, is_tau = _delay_correlation(correlation, owner, kinds, delayed)
    coupling = _delay_coupling(correlation, owner, kinds, n)
    return Separation(collinearity, partner, pair, delay_correlation, rival, is_tau, coupling)
