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


def informative_band(omega: np.ndarray, coherence: np.ndarray, coherence_min: float) -> np.ndarray:
    """The band B of eqs. (8)-(9): from the first nonzero bin up to where the coherence first drops.

    Parameters
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    coherence : ndarray, shape (F,)
        Squared coherence behind the estimate.
    coherence_min : float
        The band ends at the first bin whose coherence is below this.

    Returns
    -------
    ndarray of bool, shape (F,)
    """
    low = np.flatnonzero((omega > 0) & (coherence < coherence_min))
    end = low[0] if low.size else omega.size
    band = np.zeros(omega.size, dtype=bool)
    band[1:end] = True
    return band


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
        The informative band B (default: all but 0).  Beyond it the estimate
        is noise, which the global Hilbert transform would smear into the
        band, so the log magnitude is held at its median over the top quarter
        of B there (a FOPTD ratio's magnitude is flat at high frequency; a
        single edge bin is too noisy to hold) and only B enters the cost.

    Returns
    -------
    delay_samples : int
        ``Delta D = D - Dhat`` [samples].
    cost : ndarray, shape (2 * max + 1,)
        The normalized cost of each candidate, best = largest.
    """
    if band is None:
        band = omega > 0
    log_magnitude = np.log(np.maximum(np.abs(response), 1e-12))
    inside = np.flatnonzero(band)
    if inside.size and inside[-1] < omega.size - 1:
        top = inside[-max(3, inside.size // 4):]
        log_magnitude = log_magnitude.copy()
        log_magnitude[inside[-1] + 1:] = np.median(log_magnitude[top])
    delay_free = minimum_phase(omega, log_magnitude)
    residual = np.angle(response) - delay_free
    kappa2 = np.clip(coherence, 0.0, 0.999)
    weight = np.where(band, kappa2 / (1.0 - kappa2), 0.0)
    candidates = np.arange(-max_delay_samples, max_delay_samples + 1)
    cost = np.cos(residual[None, :] + candidates[:, None] * omega[None, :]) @ weight
    cost = cost / max(weight.sum(), 1e-300)
    return int(candidates[int(np.argmax(cost))]), cost
