"""Delay mismatch from the PMR: discrete Hilbert transform and Hamon-Hannan cost.

The delay-free part of a PMR of FOPTD elements is minimum phase, so its phase
follows from its log magnitude (paper's eq. 8, Lindemann et al. 2001).  What
is left of the measured phase is ``-Delta D * omega``; the integer ``Delta D``
maximizing the coherence-weighted Hamon-Hannan cost (eqs. 9-10) is the delay
mismatch.
"""

from __future__ import annotations

import numpy as np


def minimum_phase(omega: np.ndarray, log_magnitude: np.ndarray) -> np.ndarray:
    """Phase [rad] of the minimum-phase response with the given log magnitude.

    The discrete Hilbert transform of eq. (8) on an even grid over [0, pi]::

        arg(w_l) = -1/(2B) sum_{k != l} log|G(w_k)| [cot((w_l - w_k)/2) + cot((w_l + w_k)/2)]

    (the minus sign makes a lag negative, as ``arg`` is used in eq. 9; the
    paper prints it without).  The end points count half, as in the trapezoid rule.

    Parameters
    ----------
    omega : ndarray, shape (F,)
        Evenly spaced frequencies from 0 to pi [rad/sample].
    log_magnitude : ndarray, shape (..., F)
        Natural log of the magnitude at ``omega``.
    """
    omega = np.asarray(omega, dtype=float)
    F = omega.size
    wl = omega[:, None]
    wk = omega[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        kernel = 1.0 / np.tan((wl - wk) / 2.0) + 1.0 / np.tan((wl + wk) / 2.0)
    kernel[~np.isfinite(kernel)] = 0.0
    np.fill_diagonal(kernel, 0.0)
    weights = np.ones(F)
    weights[0] = weights[-1] = 0.5
    B = F - 1  # intervals of width pi/B
    return -(np.asarray(log_magnitude) * weights) @ kernel.T / (2.0 * B)


def hamon_hannan_delay(
    omega: np.ndarray,
    response: np.ndarray,
    coherence: np.ndarray,
    max_delay_samples: int,
    band: np.ndarray | None = None,
) -> tuple[int, np.ndarray]:
    """Integer delay mismatch maximizing the Hamon-Hannan cost (eqs. 9-10).

    Parameters
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample], evenly spaced.
    response : ndarray of complex, shape (F,)
        The estimated PMR of one element.
    coherence : ndarray, shape (F,)
        Squared coherence kappa^2 behind the estimate, in [0, 1].
    max_delay_samples : int
        Candidates are ``-max .. +max`` samples.
    band : ndarray of bool, shape (F,), optional
        Frequencies that enter the cost (default: all but 0).

    Returns
    -------
    delay_samples : int
        ``Delta D = D - Dhat`` [samples].
    cost : ndarray, shape (2 * max + 1,)
        The normalized cost of each candidate, best = largest.
    """
    magnitude = np.maximum(np.abs(response), 1e-12)
    delay_free = minimum_phase(omega, np.log(magnitude))
    residual = np.angle(response) - delay_free
    kappa2 = np.clip(coherence, 0.0, 0.999)
    weight = kappa2 / (1.0 - kappa2)
    if band is None:
        band = omega > 0
    weight = np.where(band, weight, 0.0)
    candidates = np.arange(-max_delay_samples, max_delay_samples + 1)
    cost = np.cos(residual[None, :] + candidates[:, None] * omega[None, :]) @ weight
    cost = cost / max(weight.sum(), 1e-300)
    return int(candidates[int(np.argmax(cost))]), cost
