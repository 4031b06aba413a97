"""Partial correlation of each CV's model residual with each MV (Badwe, Gudi, Patwardhan et al., JPC 19, 2009).

The model residual of CV i, ``e_i = y_i - yhat_i`` (``yhat`` the model driven
by the recorded inputs), carries ``sum_j (G_ij - Ghat_ij) u_j`` plus the
disturbance.  Its correlation with an MV points at a mismatched element;
ordinary correlation points at the wrong one because the controller makes the
MVs move together, so the paper uses the *partial* correlation of ``e_i`` with
``u_j`` controlling for the other MVs.

What the paper's text available to us does not fix, and what is assumed here:

* pre-whitening (Box-Jenkins style): ``e_i`` is whitened by a least-squares
  AR model of itself (order by AIC up to ``max_ar_order``) and every MV is
  passed through the same filter.  With no mismatch the whitened residual is
  the innovation, uncorrelated with every past input whatever the feedback,
  so a correlation at positive lags is the mismatch's alone;
* lags: ``u_j(t - l)`` for ``l = 1 .. lags`` (lag 0 is left out: in closed
  loop ``u(t)`` answers ``y(t)``, so it correlates with the residual's
  innovation without any mismatch);
* "controlling for the other MVs": for each lag of ``u_j``, both it and the
  whitened residual are regressed on the other MVs at all lags
  ``1 .. CONTROL_FACTOR x lags`` and the correlation of what is left is taken;
* the test: Fisher's z, ``atanh(r) sqrt(n - |Z| - 3)`` ~ N(0, 1) under no
  correlation, two-sided p per lag, Bonferroni over the lags: element (i, j)
  is flagged when ``lags x`` its smallest p is below ``alpha``.

The method detects and locates; it does not quantify (no dK, dtau, dD).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter
from scipy.stats import norm

from ..core.sim.model import TransferMatrix
from .outcome import PeerOutcome

__all__ = ["partial_correlation_test"]

EXTRA_LAGS = 10
"""Lags beyond the row's largest model delay searched by default (the project's delay search range)."""


CONTROL_FACTOR = 2
"""The other MVs are controlled for at lags ``1 .. CONTROL_FACTOR x lags``: a mismatched neighbour's
response (a slow first-order tail) reaches further back than the lags tested (measured on Wood-Berry,
+20 % on G11, 16,384 samples: G12 flagged in 6 of 10 seeds at 5 % with the window equal to the lags,
3 of 10 with twice or with 60 lags)."""


def _ar_whitener(e: np.ndarray, max_order: int) -> np.ndarray:
    """``A(q)`` (monic, in q^-1) of the least-squares AR model of ``e`` whose order minimises AIC."""
    n = e.size
    best, best_aic = np.array([1.0]), n * math.log(float(e @ e) / n)
    lagged = np.column_stack([e[max_order - k : n - k] for k in range(1, max_order + 1)])
    target = e[max_order:]
    for order in range(1, max_order + 1):
        coef, *_ = np.linalg.lstsq(lagged[:, :order], target, rcond=None)
        resid = target - lagged[:, :order] @ coef
        aic = target.size * math.log(float(resid @ resid) / target.size) + 2 * order
        if aic < best_aic:
            best, best_aic = np.concatenate(([1.0], -coef)), aic
    return best


def _lagged(x: np.ndarray, lags: int) -> np.ndarray:
    """Columns ``x(t - 1) .. x(t - lags)`` for ``t = lags .. N - 1``, shape (N - lags, lags) per input."""
    n = x.shape[0]
    return np.stack([x[lags - lag : n - lag] for lag in range(1, lags + 1)], axis=1)


def _residualize(target: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """What of ``target``'s columns the columns of ``basis`` leave unexplained (least squares)."""
    q, _ = np.linalg.qr(basis)
    return target - q @ (q.T @ target)


def _triangular_factor(columns: list[np.ndarray]) -> np.ndarray:
    """``R`` of the QR factorization of the columns side by side: ``R^T R`` is their Gram matrix.

    Every least-squares projection among these columns can be done on ``R``'s
    columns instead (``X = Q R`` with ``Q`` orthonormal keeps every inner
    product), a (p x p) problem instead of an (N x p) one.
    """
    return np.asarray(np.linalg.qr(np.hstack(columns), mode="r"))


def _element_p_values(e: np.ndarray, u: np.ndarray, lags: int, control: int) -> np.ndarray:
    """Bonferroni p per MV of the partial correlation of whitened ``e`` with it at lags 1..lags.

    One QR factorization of ``[1, every MV at lags 1..max(lags, control), e]``;
    each MV's test then projects the columns of its triangular factor, with the
    numbers of regressing the N samples themselves (the test checks it against that).
    """
    n_in = u.shape[1]
    longest = max(lags, control)
    lagged = _lagged(u, longest)  # (n, longest, n_in)
    target = e[longest:]
    r = _triangular_factor([np.ones((target.size, 1)), *(lagged[:, :, m] for m in range(n_in)), target[:, None]])
    own = 1 + longest * np.arange(n_in)  # first column of each MV's block
    p = np.empty(n_in)
    for j in range(n_in):
        basis = [0, *(own[m] + lag for m in range(n_in) if m != j for lag in range(control))]
        left = _residualize(r[:, [*(own[j] + np.arange(lags)), r.shape[1] - 1]], r[:, basis])
        left_u, left_e = left[:, :-1], left[:, -1]
        corr = (left_u.T @ left_e) / np.sqrt(np.sum(left_u**2, axis=0) * float(left_e @ left_e))
        dof = target.size - (len(basis) - 1) - 3
        z = np.arctanh(np.clip(corr, -0.999999, 0.999999)) * math.sqrt(max(dof, 1))
        p[j] = min(1.0, lags * float(np.min(2.0 * norm.sf(np.abs(z)))))
    return p


def _row_p_values(residual: np.ndarray, inputs: np.ndarray, *, lags: int, max_ar_order: int) -> np.ndarray:
    """Per MV, the Bonferroni p of one CV's residual after both are pre-whitened by the residual's AR model."""
    e = residual - residual.mean()
    whitener = _ar_whitener(e, max_ar_order)
    white_e = lfilter(whitener, [1.0], e)[whitener.size - 1 :]
    white_u = lfilter(whitener, [1.0], inputs, axis=0)[whitener.size - 1 :]
    return _element_p_values(white_e, white_u, lags, CONTROL_FACTOR * lags)


def partial_correlation_test(
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: TransferMatrix,
    alpha: float = 0.05,
    lags: int | None = None,
    max_ar_order: int = 20,
    start: int | None = None,
) -> dict[str, PeerOutcome]:
    """Flag the elements whose MV the CV's whitened model residual partially correlates with.

    Parameters
    ----------
    u : ndarray, shape (N, n_inputs)
        Recorded inputs [input unit].
    y : ndarray, shape (N, n_outputs)
        Recorded outputs [output unit].
    model : TransferMatrix
        The controller's model ``Ghat``.
    alpha : float
        Significance level of each element's test (Bonferroni over its lags).
    lags : int, optional
        Largest lag tested [samples]; default the model's largest delay + 1 + :data:`EXTRA_LAGS`.
    max_ar_order : int
        Largest order of the pre-whitening AR model.
    start : int, optional
        Samples dropped at the start (the model's unknown initial state); default its settling time.

    Returns
    -------
    dict
        Element name to :class:`PeerOutcome` (method ``partial_correlation``): the
        Bonferroni p-value as the score, ``mismatch`` when below ``alpha``, else
        ``ok``; no numbers.

    Raises
    ------
    ValueError
        For data of the wrong shape or too short for the lags.
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    if u.ndim != 2 or y.ndim != 2 or u.shape != (y.shape[0], model.n_inputs) or y.shape[1] != model.n_outputs:
        raise ValueError(f"u {u.shape} and y {y.shape} do not fit a {model.n_outputs} x {model.n_inputs} model")
    lags = int(model.delay_samples.max()) + 1 + EXTRA_LAGS if lags is None else lags
    first = model.settling_samples() if start is None else start
    if y.shape[0] - first < 10 * (lags * model.n_inputs + max_ar_order):
        raise ValueError(f"{y.shape[0]} samples are too few for {lags} lags of {model.n_inputs} inputs")
    residual = (y - model.element_outputs(u).sum(axis=2))[first:]
    inputs = u[first:] - u[first:].mean(axis=0)
    names = model.element_names()
    out = {}
    for i in range(model.n_outputs):
        p = _row_p_values(residual[:, i], inputs, lags=lags, max_ar_order=max_ar_order)
        for k in range(model.n_inputs):
            name = names[i * model.n_inputs + k]
            flagged = bool(p[k] < alpha)
            verdict = "mismatch" if flagged else "ok"
            out[name] = PeerOutcome(name, i, k, "partial_correlation", flagged, float(p[k]), "p_value", verdict)
    return out
