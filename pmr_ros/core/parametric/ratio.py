"""The FOPTD-ratio model of one output row and its weighted least-squares problem.

The ratio of two ZOH-sampled FOPTD elements has a known form,

    G_PMR(z) = rho * (1 - a)/(1 - ahat) * (1 - ahat z^-1)/(1 - a z^-1) * z^-dD

with ``rho = K / Khat``, ``a = exp(-Ts / tau)``, ``ahat = exp(-Ts / tauhat)`` and
``dD = D - Dhat`` whole samples.  For each output row the parameters of all its
elements are fitted together to the implicit regression's equations (eq. 13),

    e(w) = S_{r y_i}(w) - sum_k S_{r yhat_ik}(w) G_PMR_ik(w)

At the true parameters ``e = S_{r v}``, the cross-spectrum of the setpoints with
the output's noise, whose covariance is ``S_rr(w) Phi_v(w) / M``: ``Phi_v`` the
noise spectrum (from the fit's own residual) and ``M`` the equivalent number of
Welch segments.  Weighting by its inverse is weighting the PMR estimate by its
inverse variance -- a bin where an element is not excited (the filtering
effect) gets no say on that element -- without ever dividing by a vanishing
spectrum.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..spectra import RecordSpectra

__all__ = ["NOISE_SMOOTHING_BINS", "RowProblem", "noise_spectrum", "ratio_shape", "row_ratio", "whitened_row"]

NOISE_SMOOTHING_BINS = 9
"""Width of the moving average over frequency applied to the noise spectrum."""

GAIN_RATIO_BOUND = 10.0
"""The fit keeps ``|K / Khat|`` below this."""

TAU_RATIO_BOUND = 20.0
"""... and ``tau / tauhat`` within a factor of this either way."""


def ratio_shape(z_inv: np.ndarray, pole_model: float, pole_plant: np.ndarray | float, delay: int) -> np.ndarray:
    """Normalized FOPTD-ratio shape at ``z_inv = exp(-j w)``: 1 at w = 0.

    Parameters
    ----------
    z_inv : ndarray of complex
        ``exp(-j w)`` at the frequencies of interest.
    pole_model, pole_plant : float
        ``ahat`` and ``a``.
    delay : int
        ``dD`` [samples].
    """
    return (1 - pole_plant) / (1 - pole_model) * (1 - pole_model * z_inv) / (1 - pole_plant * z_inv) * z_inv**delay


def row_ratio(
    omega: np.ndarray, *, gain_ratio: np.ndarray, pole_model: np.ndarray, pole_plant: np.ndarray, delays: np.ndarray
) -> np.ndarray:
    """The fitted PMR of every element of a row, shape (F, n_in)."""
    z_inv = np.exp(-1j * omega)
    columns = [
        gain_ratio[k] * ratio_shape(z_inv, pole_model[k], pole_plant[k], int(delays[k])) for k in range(gain_ratio.size)
    ]
    return np.stack(columns, axis=1)


def whitened_row(spectra: RecordSpectra, i: int, noise: np.ndarray, bins: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Equation data of row i whitened to unit-variance real components.

    Parameters
    ----------
    spectra : RecordSpectra
    i : int
        Output row.
    noise : ndarray, shape (F,)
        The row's noise spectrum ``Phi_v``.
    bins : ndarray of int
        Frequency bins that enter the fit.

    Returns
    -------
    b : ndarray, shape (F', n_r)
    A : ndarray, shape (F', n_r, n_in)
        With ``e = b - A theta`` of unit variance.
    """
    rr = spectra.rr[bins]
    chol = np.linalg.cholesky(rr + 1e-12 * np.trace(rr, axis1=1, axis2=2).real[:, None, None] * np.eye(rr.shape[1]))
    scale = np.sqrt(2.0 * spectra.equivalent_segments / noise[bins])
    # a real (DC) bin has its whole variance in the real part: half the factor 2
    scale = np.where(spectra.omega[bins] == 0.0, scale / np.sqrt(2.0), scale)
    b = np.linalg.solve(chol, spectra.ry[bins][:, :, i][:, :, None])[:, :, 0] * scale[:, None]
    A = np.linalg.solve(chol, spectra.ryhat[bins][:, :, i, :]) * scale[:, None, None]
    return b, A


def noise_spectrum(spectra: RecordSpectra, i: int, theta: np.ndarray) -> np.ndarray:
    """Spectrum of ``v_i = y_i - sum_k theta_k yhat_ik`` for a PMR row ``theta`` (F, n_in).

    Smoothed over :data:`NOISE_SMOOTHING_BINS` bins: a per-bin estimate has only
    the equivalent number of segments as degrees of freedom, and weights that
    noisy would over-weight the bins where the noise happens to come out low
    (measured: intervals 5 % too narrow without smoothing).
    """
    cross = np.einsum("fk,fk->f", theta.conj(), spectra.yhat_y[:, i, :]).real
    quad = np.einsum("fk,fkm,fm->f", theta.conj(), spectra.yhat_yhat[:, i], theta).real
    phi = np.maximum(spectra.yy[:, i] - 2.0 * cross + quad, 1e-6 * spectra.yy[:, i] + 1e-300)
    half = NOISE_SMOOTHING_BINS // 2
    padded = np.pad(phi, half, mode="reflect")
    return np.convolve(padded, np.ones(NOISE_SMOOTHING_BINS) / NOISE_SMOOTHING_BINS, mode="valid")


class RowProblem:
    """Weighted least squares of one row's ``(rho_k, log tau_k/tauhat_k)`` for given integer delays.

    Parameters
    ----------
    b, A : ndarray
        Whitened equation data (:func:`whitened_row`).
    z_inv : ndarray of complex, shape (F',)
        ``exp(-j w)`` at the fitted bins.
    pole_model : ndarray, shape (n_in,)
        ``ahat`` of the row's elements.
    sample_time : float
        Ts [time unit].
    tau_model : ndarray, shape (n_in,)
        ``tauhat`` of the row's elements [time unit].
    """

    def __init__(
        self,
        b: np.ndarray,
        A: np.ndarray,
        *,
        z_inv: np.ndarray,
        pole_model: np.ndarray,
        sample_time: float,
        tau_model: np.ndarray,
    ) -> None:
        self.b, self.A, self.z_inv = b, A, z_inv
        self.pole_model, self.ts, self.tau_model = pole_model, sample_time, tau_model
        self.n = A.shape[2]
        self._last: tuple[bytes, tuple[int, ...], tuple[np.ndarray, np.ndarray]] | None = None

    def residual_and_jacobian(self, x: np.ndarray, delays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whitened residual (real and imaginary parts stacked) and its Jacobian at ``x``."""
        # least_squares asks for the residual and the Jacobian at the same x in turn: compute both once
        key = (x.tobytes(), tuple(int(d) for d in delays))
        if self._last is not None and self._last[:2] == key:
            return self._last[2]
        result = self._evaluate(x, delays)
        self._last = (*key, result)
        return result

    def _evaluate(self, x: np.ndarray, delays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.n
        rho, s = x[:n], x[n:]
        tau = self.tau_model * np.exp(s)
        a = np.exp(-self.ts / tau)
        e = self.b.copy()
        jac = np.empty((self.b.shape[0], self.b.shape[1], 2 * n), dtype=complex)
        z_inv = self.z_inv
        for k in range(n):
            shape = ratio_shape(z_inv, self.pole_model[k], a[k], int(delays[k]))
            contribution = self.A[:, :, k] * shape[:, None]
            e -= rho[k] * contribution
            jac[:, :, k] = -contribution
            ah = self.pole_model[k]
            dshape_da = (1 - ah * z_inv) * z_inv ** int(delays[k]) / (1 - ah) * (z_inv - 1) / (1 - a[k] * z_inv) ** 2
            jac[:, :, n + k] = -rho[k] * self.A[:, :, k] * (dshape_da * a[k] * self.ts / tau[k])[:, None]
        r = np.concatenate([e.real.ravel(), e.imag.ravel()])
        J = np.concatenate([jac.real.reshape(-1, 2 * n), jac.imag.reshape(-1, 2 * n)])
        return r, J

    def fit(self, x0: np.ndarray, delays: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """Fit from ``x0`` with the delays held: ``(x, cost, Jacobian)``, cost = squared residual norm."""
        bound = np.log(TAU_RATIO_BOUND)
        lower = np.r_[np.full(self.n, -GAIN_RATIO_BOUND), np.full(self.n, -bound)]
        upper = np.r_[np.full(self.n, GAIN_RATIO_BOUND), np.full(self.n, bound)]
        x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
        result = least_squares(
            lambda x: self.residual_and_jacobian(x, delays)[0],
            x0,
            jac=lambda x: self.residual_and_jacobian(x, delays)[1],
            bounds=(lower, upper),
            method="trf",
            x_scale="jac",
        )
        r, J = self.residual_and_jacobian(result.x, delays)
        return result.x, float(r @ r), J
