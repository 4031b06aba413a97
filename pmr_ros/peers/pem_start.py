"""A data-driven starting point of a row's prediction-error fit: a finite-impulse-response estimate's delays and poles.

Started only from the controller's model, the fit of a row whose delays are a
few samples off can end far from the truth (measured: Wood-Berry in routine
operation, 32,768 samples, white noise, run 1145 of the scenario file: x_B's
row with G22's delay 2 samples longer than the model's; the fit at the model's
delays ends at 30 x the noise's cost, the coordinate-wise delay search then
moves G21's delay to compensate and stops at dK -359 %, where the fit at the
true delays reaches the noise floor).  MATLAB's ``procest``/``tfest`` do not
start from the user's guess either: they initialise from a linear estimate
(ARX / instrumental variables; ``delayest`` for the delays).  Here the linear
estimate is a finite impulse response (FIR) of the row, every input jointly,
by linear least squares (lags >= 1, so consistent in closed loop under white
noise); each column's FOPTD delay and pole are fitted to its impulse response
on a grid, and the gains and offset refitted by linear least squares with
those delays and poles.  The caller keeps whichever start fits the data better.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

__all__ = ["FIR_TAU_MULTIPLE", "MIN_SAMPLES_PER_REGRESSOR", "delay_candidates", "fir_start", "impulse_responses"]

FIR_TAU_MULTIPLE = 5.0
"""FIR lags beyond the longest delay searched, in model time constants (the response has decayed to e^-5)."""

MIN_SAMPLES_PER_REGRESSOR = 8
"""No FIR start when the cost has fewer samples than this many per FIR coefficient (too noisy to help)."""

TAU_FACTORS = np.geomspace(0.25, 4.0, 49)
"""Time constants tried for a column's pole, as multiples of the model's."""


def delay_candidates(model_delay: int, max_shift: int) -> range:
    """The delays a column's search tries: within ``max_shift`` of the model's, none negative [samples]."""
    return range(max(model_delay - max_shift, 0), model_delay + max_shift + 1)


def _lagged(signal: np.ndarray, lags: int) -> np.ndarray:
    """Columns ``signal(t - 1) .. signal(t - lags)`` from a zero past, shape (N, lags)."""
    padded = np.concatenate((np.zeros(lags), signal[:-1]))
    return np.lib.stride_tricks.sliding_window_view(padded, lags)[:, ::-1]


def impulse_responses(
    y: np.ndarray, inputs: np.ndarray, *, integrating: np.ndarray, start: int, lags: int
) -> np.ndarray | None:
    """The row's FIR by least squares: per column the coefficients of lags 1..``lags``, or None if too few samples.

    An integrating column enters as its running sum, so that its response is a pulse too.

    Returns
    -------
    ndarray, shape (m, lags), or None
        ``h[j, k - 1]``: the response of ``y`` to column j's input ``k`` samples earlier [output / input unit].
    """
    m = inputs.shape[1]
    if y.size - start < MIN_SAMPLES_PER_REGRESSOR * (m * lags + 1):
        return None
    parts = [_lagged(np.cumsum(inputs[:, j]) if integrating[j] else inputs[:, j], lags) for j in range(m)]
    regressors = np.hstack([*parts, np.ones((y.size, 1))])[start:]
    coefficients = np.linalg.lstsq(regressors, y[start:], rcond=None)[0]
    return coefficients[:-1].reshape(m, lags)


def _column(h: np.ndarray, candidates: range, pole: float | None) -> tuple[int, float]:
    """``(delay, pole)`` of the FOPTD ``b a^(k-1-d)`` (a pulse at ``1 + d`` when integrating) nearest to ``h``."""
    lag = np.arange(1, h.size + 1)
    poles = np.zeros(1) if pole is None else np.exp(np.log(pole) / TAU_FACTORS)
    best = (np.inf, candidates.start, 1.0 if pole is None else pole)
    for delay in candidates:
        after = lag - 1 - delay
        basis = np.where(after >= 0, poles[:, None] ** np.maximum(after, 0), 0.0)  # (poles, lags)
        norm = np.einsum("pk,pk->p", basis, basis)
        misfit = h @ h - (basis @ h) ** 2 / np.where(norm > 0, norm, np.inf)
        p = int(np.argmin(misfit))
        if misfit[p] < best[0]:
            best = (float(misfit[p]), delay, 1.0 if pole is None else float(poles[p]))
    return best[1], best[2]


def fir_start(
    y: np.ndarray,
    inputs: np.ndarray,
    *,
    integrating: np.ndarray,
    start: int,
    model_delays: np.ndarray,
    model_poles: np.ndarray,
    max_shift: int,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Delays and packed output-error parameters ``[b, a (FOPTD columns), c]`` from the row's FIR, or None.

    Parameters
    ----------
    y, inputs : ndarray, shapes (N,), (N, m)
        The row as :class:`~pmr_ros.peers.pem_fit.RowData` holds it [output unit, input unit].
    integrating : ndarray of bool, shape (m,)
    start : int
        First sample in the cost [samples].
    model_delays : ndarray of int, shape (m,)
        The model's delays; each column's delay is chosen within ``+/- max_shift`` of it [samples].
    model_poles : ndarray, shape (m,)
        The model's discrete poles (1 for an integrating column); the grid of each pole is around it.
    max_shift : int
        Largest delay change searched [samples].

    Returns
    -------
    (ndarray of int, ndarray) or None
        None when the record is too short for the FIR (:data:`MIN_SAMPLES_PER_REGRESSOR`).
    """
    foptd = ~integrating
    slowest = max((-1.0 / np.log(model_poles[foptd])).max(initial=0.0), 1.0)
    lags = int(np.max(model_delays)) + max_shift + 1 + int(np.ceil(FIR_TAU_MULTIPLE * slowest))
    h = impulse_responses(y, inputs, integrating=integrating, start=start, lags=lags)
    if h is None:
        return None
    chosen = [
        _column(h[j], delay_candidates(int(d), max_shift), None if integrating[j] else pole)
        for j, (d, pole) in enumerate(zip(model_delays, model_poles, strict=True))
    ]
    delays = np.array([c[0] for c in chosen], dtype=int)
    poles = np.array([c[1] for c in chosen])
    responses = [
        lfilter(np.eye(1, int(d) + 2, int(d) + 1).ravel(), [1.0, -a], inputs[:, j])
        for j, (d, a) in enumerate(zip(delays, poles, strict=True))
    ]
    regressors = np.column_stack([*responses, np.ones(y.size)])[start:]
    gains = np.linalg.lstsq(regressors, y[start:], rcond=None)[0]
    return delays, np.concatenate((gains[:-1], poles[foptd], gains[-1:]))
