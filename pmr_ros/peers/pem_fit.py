"""Prediction-error fit of one output row as a MISO FOPTD model, with an optional ARMA noise model.

The row is ``y(t) = c + sum_j G_j(q) u_j(t) + H(q) e(t)`` with, per column j,
the exact zero-order-hold FOPTD ``G_j = b_j q^-(1 + d_j) / (1 - a_j q^-1)``
(``a_j = 1`` for an integrating element) and whole-sample delays ``d_j``.
Output error (OE) takes ``H = 1``; Box-Jenkins (BJ) takes
``H = C(q)/D(q)`` of orders ``(nc, nd)``, fitted jointly.  The one-step
prediction error ``eps = (D/C)(y - c - sum G_j u_j)`` is minimised by
:func:`scipy.optimize.least_squares` with its analytic Jacobian; the delays
are searched coordinate-wise on a grid around the model's, each candidate
refitted from the best parameters so far, starting from the model or from a
finite-impulse-response estimate of the row, whichever fits better
(:mod:`pmr_ros.peers.pem_start`).  The asymptotic covariance is
``sigma^2 (J^T J)^-1`` (Ljung 1999, eq. 9.18), conditional on the delays, as
MATLAB's ``procest``/``tfest`` report it.

Parameters are packed as ``[b (m), a (FOPTD columns), c, C (nc), D (nd)]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import solve_toeplitz
from scipy.optimize import least_squares
from scipy.signal import lfilter
from scipy.special import expit

from .pem_start import delay_candidates, fir_start

__all__ = ["RowData", "RowFit", "fit_row"]

MAX_SWEEPS = 4
"""Coordinate sweeps over the delays at most (the search stops earlier when a sweep changes none)."""

SEARCH_TOLERANCE = 1e-8
"""Relative tolerance of the fits that only rank delay candidates (cost differences that matter are ~1/N of it)."""

POLE_MARGIN = 1e-9
"""FOPTD poles and ARMA coefficients of order 1 are kept this far inside (0, 1) and (-1, 1)."""


@dataclass(frozen=True)
class RowData:
    """One output row and the inputs of its modeled elements.

    Attributes
    ----------
    y : ndarray, shape (N,)
        The output [output unit].
    inputs : ndarray, shape (N, m)
        The inputs of the row's modeled elements [input unit]; a FOPTD
        column is taken relative to its first sample (its steady state then
        joins the offset ``c``).
    integrating : ndarray of bool, shape (m,)
        Which columns are integrating (pole fixed at 1).
    start : int
        First sample in the cost: the transients of the unknown initial
        states are left out [samples].
    noise_orders : (int, int)
        ``(nc, nd)`` of ``H = C/D``; ``(0, 0)`` is output error.
    """

    y: np.ndarray
    inputs: np.ndarray
    integrating: np.ndarray
    start: int
    noise_orders: tuple[int, int] = (0, 0)

    @property
    def columns(self) -> int:
        """Modeled elements m in the row."""
        return int(self.inputs.shape[1])

    @property
    def foptd(self) -> np.ndarray:
        """Indices of the columns with a free pole."""
        return np.flatnonzero(~self.integrating)


@dataclass(frozen=True)
class RowFit:
    """A fitted row.

    Attributes
    ----------
    delays : ndarray of int, shape (m,)
        Chosen delays [samples].
    theta : ndarray
        Packed parameters (module docstring).
    covariance : ndarray
        Their asymptotic covariance.
    cost : float
        Sum of squared prediction errors over the cost's samples.
    sigma2 : float
        Prediction-error variance, ``cost / (samples - parameters)``.
    samples : int
        Samples in the cost.
    profiles : tuple of dict
        Per column: candidate delay -> cost of the best fit with it (the last sweep).
    """

    delays: np.ndarray
    theta: np.ndarray
    covariance: np.ndarray
    cost: float
    sigma2: float
    samples: int
    profiles: tuple[dict[int, float], ...] = field(default=())


def _unpack(theta: np.ndarray, data: RowData) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """``(b, a, c, C, D)``: ``a`` per column (1 for integrating), C and D monic polynomials in q^-1."""
    m, nf = data.columns, data.foptd.size
    nc, nd = data.noise_orders
    a = np.ones(m)
    a[data.foptd] = theta[m : m + nf]
    c_poly = np.concatenate(([1.0], theta[m + nf + 1 : m + nf + 1 + nc]))
    d_poly = np.concatenate(([1.0], theta[m + nf + 1 + nc : m + nf + 1 + nc + nd]))
    return theta[:m], a, float(theta[m + nf]), c_poly, d_poly


def _delayed(signal: np.ndarray, delay: int, pole: float) -> np.ndarray:
    """``q^-(1 + delay) / (1 - pole q^-1)`` applied to ``signal`` from a zero state."""
    num = np.zeros(delay + 2)
    num[-1] = 1.0
    return lfilter(num, [1.0, -pole], signal)


def _residual_jacobian(theta: np.ndarray, data: RowData, delays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Prediction errors and their Jacobian over the cost's samples."""
    b, a, c, c_poly, d_poly = _unpack(theta, data)
    m, nf = data.columns, data.foptd.size
    n = data.y.size
    model_part = np.zeros((n, m + nf + 1))  # d(model output)/d(b, a, c)
    x = np.zeros(n)
    for j in range(m):
        g = _delayed(data.inputs[:, j], int(delays[j]), a[j])
        x += b[j] * g
        model_part[:, j] = g
    for slot, j in enumerate(data.foptd):
        model_part[:, m + slot] = b[j] * lfilter([0.0, 1.0], [1.0, -a[j]], model_part[:, j])
    model_part[:, m + nf] = 1.0
    w = data.y - c - x
    nc, nd = data.noise_orders
    if nc == 0 and nd == 0:
        return w[data.start :], -model_part[data.start :]
    eps = lfilter(d_poly, c_poly, w)
    jac = np.empty((n, theta.size))
    jac[:, : m + nf + 1] = -lfilter(d_poly, c_poly, model_part, axis=0)
    for k in range(1, nc + 1):
        jac[:, m + nf + k] = -lfilter(np.eye(1, k + 1, k).ravel(), c_poly, eps)
    for k in range(1, nd + 1):
        jac[:, m + nf + nc + k] = lfilter(np.eye(1, k + 1, k).ravel(), c_poly, w)
    return eps[data.start :], jac[data.start :]


def _bounded(data: RowData) -> np.ndarray:
    """Which packed parameters live in an interval: FOPTD poles in (0, 1), first-order ARMA coefficients in (-1, 1)."""
    m, nf = data.columns, data.foptd.size
    nc, nd = data.noise_orders
    kind = np.zeros(m + nf + 1 + nc + nd, dtype=int)
    kind[m : m + nf] = 1
    if nc <= 1 and nd <= 1:  # first order: the bound keeps C minimum-phase and D stable
        kind[m + nf + 1 :] = 2
    return kind


def _natural(free: np.ndarray, kind: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Packed parameters from the unbounded ones the solver moves, and the derivative of each.

    A pole is ``1 / (1 + exp(-s))``, a first-order ARMA coefficient ``tanh(s)``:
    Levenberg-Marquardt (MINPACK) then needs no bounds, and is several times
    faster than the bounded trust-region solver on these tall problems.
    """
    theta, slope = free.copy(), np.ones_like(free)
    pole = kind == 1
    theta[pole] = expit(free[pole])
    slope[pole] = theta[pole] * (1.0 - theta[pole])
    arma = kind == 2
    theta[arma] = np.tanh(free[arma])
    slope[arma] = 1.0 - theta[arma] ** 2
    return theta, slope


def _free(theta: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_natural` (parameters clipped just inside their intervals)."""
    free = theta.copy()
    pole = kind == 1
    a = np.clip(theta[pole], POLE_MARGIN, 1.0 - POLE_MARGIN)
    free[pole] = np.log(a / (1.0 - a))
    arma = kind == 2
    free[arma] = np.arctanh(np.clip(theta[arma], -1.0 + POLE_MARGIN, 1.0 - POLE_MARGIN))
    return free


def _fit_delays(data: RowData, delays: np.ndarray, theta0: np.ndarray, *, tol: float = 1e-12) -> RowFit:
    """The least-squares fit of the continuous parameters with the delays fixed."""
    kind = _bounded(data)
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def both(free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = free.tobytes()
        if key not in cache:
            cache.clear()
            theta, slope = _natural(free, kind)
            eps, jac = _residual_jacobian(theta, data, delays)
            cache[key] = eps, jac * slope
        return cache[key]

    sol = least_squares(
        lambda f: both(f)[0], _free(theta0, kind), jac=lambda f: both(f)[1], method="lm",
        ftol=tol, xtol=tol, gtol=tol, max_nfev=400,
    )  # fmt: skip
    theta = _natural(sol.x, kind)[0]
    eps, jac = _residual_jacobian(theta, data, delays)
    cost = float(eps @ eps)
    sigma2 = cost / max(eps.size - theta.size, 1)
    covariance = sigma2 * np.linalg.pinv(jac.T @ jac)
    return RowFit(delays.copy(), theta, covariance, cost, sigma2, eps.size)


def _noise_start(data: RowData, oe: RowFit) -> np.ndarray:
    """Starting parameters of a Box-Jenkins fit: the output-error fit ``oe``, ``D`` from the AR fit of its residual.

    Started from white noise (``C = D = 1``) the joint fit can end in a local
    minimum where ``C`` and ``D`` cancel at the unit circle (measured: Wood-Berry
    under a disturbance of pole 0.97, gains 50-100 % off); MATLAB's ``bj``
    likewise starts from an instrumental-variable estimate and a noise model
    fitted to its residual.
    """
    nc, nd = data.noise_orders
    w = data.y - _residual_free_output(oe.theta, data, oe.delays)
    w = w[data.start :] - w[data.start :].mean()
    acf = np.array([w[: w.size - k] @ w[k:] for k in range(nd + 1)]) / w.size
    ar = solve_toeplitz(acf[:nd], acf[1 : nd + 1]) if nd else np.zeros(0)
    return np.concatenate((oe.theta, np.zeros(nc), -ar))


def _start(
    data: RowData, model_delays: np.ndarray, initial: np.ndarray, max_shift: int
) -> tuple[np.ndarray, np.ndarray]:
    """Delays and packed parameters the search starts from: the model's or the FIR estimate's, whichever fits better.

    Both are compared by their output-error fits (:mod:`pmr_ros.peers.pem_start`
    says why the model's alone is not enough); a Box-Jenkins fit then starts
    from the winner with :func:`_noise_start`.
    """
    nc, nd = data.noise_orders
    plain = RowData(data.y, data.inputs, data.integrating, data.start)
    base = initial[: initial.size - nc - nd]
    fits = [_fit_delays(plain, model_delays, base, tol=SEARCH_TOLERANCE)]
    fir = fir_start(
        data.y, data.inputs, integrating=data.integrating, start=data.start, model_delays=model_delays,
        model_poles=_unpack(initial, data)[1], max_shift=max_shift,
    )  # fmt: skip
    if fir is not None:
        fits.append(_fit_delays(plain, fir[0], fir[1], tol=SEARCH_TOLERANCE))
    oe = min(fits, key=lambda fit: fit.cost)
    return oe.delays, _noise_start(data, oe) if nc + nd else oe.theta


def _residual_free_output(theta: np.ndarray, data: RowData, delays: np.ndarray) -> np.ndarray:
    """The model output ``c + sum G_j u_j`` of an output-error parameter vector."""
    eps, _ = _residual_jacobian(theta, RowData(data.y, data.inputs, data.integrating, 0), delays)
    return data.y - eps


def fit_row(data: RowData, *, model_delays: np.ndarray, initial: np.ndarray, max_shift: int) -> RowFit:
    """Fit a row, searching each column's delay over ``model_delay +/- max_shift`` coordinate-wise.

    Parameters
    ----------
    data : RowData
    model_delays : ndarray of int, shape (m,)
        The model's delays: the search's centre and starting point [samples].
    initial : ndarray
        Packed starting parameters (the model's, white noise).
    max_shift : int
        Largest delay change searched [samples].

    Returns
    -------
    RowFit
        The best fit found, with each column's delay profile from the last sweep.
    """
    model_delays = np.asarray(model_delays, dtype=int)
    delays, initial = _start(data, model_delays, initial, max_shift)
    best = _fit_delays(data, delays, initial)
    profiles: list[dict[int, float]] = [{} for _ in range(data.columns)]
    for _ in range(MAX_SWEEPS):
        changed = False
        for j in range(data.columns):
            profile = {int(best.delays[j]): best.cost}
            champion = best
            for delay in delay_candidates(int(model_delays[j]), max_shift):
                if delay == best.delays[j]:
                    continue
                trial = best.delays.copy()
                trial[j] = delay
                fit = _fit_delays(data, trial, best.theta, tol=SEARCH_TOLERANCE)
                profile[delay] = fit.cost
                if fit.cost < champion.cost:
                    champion = fit
            changed |= champion is not best
            best = champion
            profiles[j] = profile
        if not changed:
            break
    best = _fit_delays(data, best.delays, best.theta)  # polish the winner to full precision
    return RowFit(best.delays, best.theta, best.covariance, best.cost, best.sigma2, best.samples, tuple(profiles))
