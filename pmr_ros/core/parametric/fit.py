"""Fitting one output row: the whole-sample delay search, the two-pass noise estimate, the profile.

:func:`fit_row` runs, for one output row of the implicit regression,

1. a coordinate search over whole-sample delays, each trial a weighted
   least-squares fit of gains and time constants (:class:`~.ratio.RowProblem`),
   weighted with the noise spectrum of the nonparametric estimate;
2. the same fit again with the noise spectrum re-estimated from the first
   fit's residual (the weights of the final fit);
3. the profile of each element's delay over its neighbours, the others held
   at their best (a neighbour that fits better is taken: the search stopped early);
4. the Gauss-Newton covariance, inflated by the Welch window's bin correlation
   and by the reduced chi-square when that exceeds one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..foptd import FoptdMatrix
from ..spectra import RecordSpectra
from .ratio import RowProblem, noise_spectrum, row_ratio, whitened_row

__all__ = ["PROFILE_HALF_WIDTH", "RowFit", "delay_bounds", "fit_row"]

PROFILE_HALF_WIDTH = 2
"""Delay candidates either side of the chosen one that enter its confidence [samples]."""

SEARCH_SWEEPS = 3
"""Most passes of the coordinate delay search over the row's elements."""

Fit = tuple[np.ndarray, float, np.ndarray]


@dataclass(frozen=True)
class RowFit:
    """The fitted parameters of one output row and their covariance.

    Attributes
    ----------
    gain_ratio : ndarray, shape (n_in,)
        ``rho_k = K / Khat``.
    log_tau_ratio : ndarray, shape (n_in,)
        ``log(tau_k / tauhat_k)``.
    delay_samples : ndarray of int, shape (n_in,)
        ``dD_k``.
    covariance : ndarray, shape (2 n_in, 2 n_in)
        Of ``(rho..., log tau ratio...)``, inflated.
    chi_square : float
        Weighted squared residual at the fit.
    dof : int
        Its degrees of freedom.
    delay_profile : tuple of dict
        Per element: ``dD -> chi_square`` with the others at their best.
    """

    gain_ratio: np.ndarray
    log_tau_ratio: np.ndarray
    delay_samples: np.ndarray
    covariance: np.ndarray
    chi_square: float
    dof: int
    delay_profile: tuple[dict[int, float], ...]


def delay_bounds(model: FoptdMatrix, i: int, max_delay_samples: int) -> list[tuple[int, int]]:
    """``(lowest, highest)`` dD of each element of row ``i``: ``+-max``, never below ``-Dhat``.

    A plant delay cannot be negative.
    """
    return [
        (max(-max_delay_samples, -int(model.delay_samples[i, k])), max_delay_samples) for k in range(model.n_inputs)
    ]


class _Trials:
    """Fits of one row with one weighting, cached by delay vector."""

    def __init__(self, problem: RowProblem) -> None:
        self.problem = problem
        self._cache: dict[tuple[int, ...], Fit] = {}

    def __call__(self, delays: np.ndarray, start: np.ndarray) -> Fit:
        key = tuple(int(v) for v in delays)
        if key not in self._cache:
            self._cache[key] = self.problem.fit(start, delays)
        return self._cache[key]


def _coordinate_search(
    trials: _Trials, delays: np.ndarray, fit: Fit, bounds: list[tuple[int, int]]
) -> tuple[np.ndarray, Fit]:
    """Move one element's delay at a time, one sample per step, while the fit improves."""
    x, cost, _ = fit
    for _sweep in range(SEARCH_SWEEPS):
        improved = False
        for k, (low, high) in enumerate(bounds):
            for step in (-1, 1):
                while low <= delays[k] + step <= high:
                    trial = delays.copy()
                    trial[k] += step
                    candidate = trials(trial, x)
                    if candidate[1] >= cost - 1e-9:
                        break
                    delays, fit, improved = trial, candidate, True
                    x, cost = candidate[0], candidate[1]
        if not improved:
            break
    return delays, fit


def _profile(
    trials: _Trials, delays: np.ndarray, fit: Fit, bounds: list[tuple[int, int]]
) -> tuple[np.ndarray, Fit, tuple[dict[int, float], ...]]:
    """Each element's delay profile, the others at their best; a better neighbour is taken."""
    profiles = []
    for k, (low, high) in enumerate(bounds):
        profile = {}
        for d in range(max(low, delays[k] - PROFILE_HALF_WIDTH), min(high, delays[k] + PROFILE_HALF_WIDTH) + 1):
            trial = delays.copy()
            trial[k] = d
            profile[d] = trials(trial, fit[0])[1]
        best = min(profile, key=profile.__getitem__)
        if best != delays[k]:
            delays = delays.copy()
            delays[k] = best
            fit = trials(delays, fit[0])
        profiles.append(profile)
    return delays, fit, tuple(profiles)


def _covariance(J: np.ndarray, *, cost: float, dof: int, bin_correlation: float) -> np.ndarray:
    """Gauss-Newton covariance inflated by the bin correlation and an excess reduced chi-square."""
    inflation = bin_correlation * max(1.0, cost / dof)
    try:
        return np.linalg.inv(J.T @ J) * inflation
    except np.linalg.LinAlgError:
        return np.full((J.shape[1], J.shape[1]), np.inf)


def fit_row(
    spectra: RecordSpectra,
    model: FoptdMatrix,
    *,
    row: int,
    theta_start: np.ndarray,
    delay_start: np.ndarray,
    max_delay_samples: int,
    bins: np.ndarray,
) -> RowFit:
    """Fit the FOPTD-ratio parameters of every element of one output row.

    Parameters
    ----------
    spectra : RecordSpectra
    model : FoptdMatrix
        The controller's model.
    row : int
        Output row i.
    theta_start : ndarray of complex, shape (F, n_in)
        A first PMR estimate of the row (the nonparametric one) for the noise spectrum.
    delay_start : ndarray of int, shape (n_in,)
        Starting delays (the classic Hamon-Hannan ones).
    max_delay_samples : int
        ``dD`` is searched over ``-max .. +max`` samples (and never below ``-Dhat``).
    bins : ndarray of int
        Frequency bins that enter the fit.

    Returns
    -------
    RowFit
    """
    pole_model = model.discretize().pole[row]
    omega = spectra.omega[bins]
    bounds = delay_bounds(model, row, max_delay_samples)
    delays = np.array([int(np.clip(d, low, high)) for d, (low, high) in zip(delay_start, bounds, strict=True)])
    n = model.n_inputs

    def trials_for(noise: np.ndarray) -> _Trials:
        b, A = whitened_row(spectra, row, noise, bins)
        return _Trials(
            RowProblem(
                b,
                A,
                z_inv=np.exp(-1j * omega),
                pole_model=pole_model,
                sample_time=model.sample_time,
                tau_model=model.time_constant[row],
            )
        )

    # pass 1: weights from the nonparametric estimate's residual, delays searched
    trials = trials_for(noise_spectrum(spectra, row, theta_start))
    delays, fit = _coordinate_search(trials, delays, trials(delays, np.r_[np.ones(n), np.zeros(n)]), bounds)
    # pass 2: weights from the first fit's residual, delays kept
    x = fit[0]
    pole_plant = np.exp(-model.sample_time / (model.time_constant[row] * np.exp(x[n:])))
    theta = row_ratio(spectra.omega, gain_ratio=x[:n], pole_model=pole_model, pole_plant=pole_plant, delays=delays)
    trials = trials_for(noise_spectrum(spectra, row, theta))
    fit = trials(delays, x)
    delays, fit, profiles = _profile(trials, delays, fit, bounds)

    x, cost, J = fit
    dof = max(1, J.shape[0] - 2 * n)
    covariance = _covariance(J, cost=cost, dof=dof, bin_correlation=spectra.settings.bin_correlation)
    return RowFit(x[:n], x[n:], delays, covariance, cost, dof, profiles)
