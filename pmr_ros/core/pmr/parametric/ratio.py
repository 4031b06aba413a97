"""The parametric model of one output row's coefficients and its weighted least-squares problem.

The ratio of two ZOH-sampled FOPTD elements has a known form,

    G_PMR(z) = rho * (1 - a)/(1 - ahat) * (1 - ahat z^-1)/(1 - a z^-1) * z^-dD

with ``rho = K / Khat``, ``a = exp(-Ts / tau)``, ``ahat = exp(-Ts / tauhat)`` and
``dD = D - Dhat`` whole samples.  The other coefficients of a row
(:class:`ColumnModel`) are special cases of the same shape:

* an integrating element: ``K Ts z^-(1+D) / (1 - z^-1)`` over its model is
  ``rho z^-dD`` -- gain and delay, no time constant;
* an empty cell in a row that does not integrate: the plant's interaction
  relative to the reference ``u_k(t-1)`` (:mod:`pmr_ros.core.pmr.spectra`), a
  first-order template ``gamma (1 - a)/(1 - a z^-1) z^-D`` -- the ratio shape
  with ``ahat = 0``, fitted for gain gamma, time constant and dead time;
* an empty cell in an integrating (differenced) row: an integrating
  interaction, ``gamma z^-D`` relative to its reference ``Ts u_k(t-1)``;
* a ``tf`` or ``step_response`` element: ``rho Ghat(s alpha) e^{-dD s}`` over
  its model, ``alpha = exp(s)`` the element made faster or slower as a whole
  (:mod:`.scaled`; for a FOPTD element that is the ratio above with ``tau = tauhat alpha``).

Each is unbiased for the same reason: at the true parameters the row's
equations hold exactly in expectation, ``S_{z y_i} = sum_k S_{z x_ik} theta_ik``,
whatever the regressor is, and an interaction that is absent has gamma = 0.

For each output row the parameters of all its coefficients are fitted
together to the implicit regression's equations (eq. 13),

    e(w) = S_{z y_i}(w) - sum_k S_{z x_ik}(w) theta_ik(w)

At the true parameters ``e = S_{z v}``, the cross-spectrum of the instruments
with the output's noise, whose covariance is ``S_zz(w) Phi_v(w) / M``:
``Phi_v`` the noise spectrum (from the fit's own residual) and ``M`` the
equivalent number of Welch segments.  Weighting by its inverse is weighting
the PMR estimate by its inverse variance -- a bin where an element is not
excited (the filtering effect) gets no say on that element -- without ever
dividing by a vanishing spectrum.

The whitened equations ``b - A theta`` of a bin are kept in information form
(:class:`RowSystem`: ``M = A^H A``, ``v = A^H b``, ``beta = |b|^2``): the
squared residual is ``beta - 2 Re theta^H v + theta^H M theta``, the same
number, at a cost that grows with the number of inputs and not with the
number of instruments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.signal import lfilter, lfilter_zi

from ..products import hermitian_product
from ..spectra import RowSpectra
from .scaled import ScaledShape

__all__ = [
    "GAIN_RATIO_BOUND",
    "NOISE_SMOOTHING_BINS",
    "TAU_RATIO_BOUND",
    "ColumnModel",
    "RowSystem",
    "bin_scale",
    "column_moments",
    "noise_spectrum",
    "ratio_shape",
    "row_system",
    "whitened_regressors",
]

NOISE_SMOOTHING_BINS = 9
"""Width of the moving average over frequency applied to the noise spectrum."""

GAIN_RATIO_BOUND = 10.0
"""The fit keeps ``|K / Khat|`` below this."""

TAU_RATIO_BOUND = 20.0
"""... and ``tau / tauhat`` within a factor of this either way."""

TEMPLATE_TAU_FLOOR = 0.05
"""The shortest time constant of an interaction's template [samples]: a pure gain and delay."""


def ratio_shape(z_inv: np.ndarray, pole_model: float, pole_plant: np.ndarray | float, delay: int) -> np.ndarray:
    """Normalized FOPTD-ratio shape at ``z_inv = exp(-j w)``: 1 at w = 0.

    Parameters
    ----------
    z_inv : ndarray of complex
        ``exp(-j w)`` at the frequencies of interest.
    pole_model, pole_plant : float
        ``ahat`` and ``a`` (``ahat = 0``: a first-order template of unit gain).
    delay : int
        ``dD`` [samples].
    """
    return (1 - pole_plant) / (1 - pole_model) * (1 - pole_model * z_inv) / (1 - pole_plant * z_inv) * z_inv**delay


@dataclass(frozen=True)
class ColumnModel:
    """How one coefficient of a row is parameterized: ``lin * shape(w; s) * z^-d``.

    Attributes
    ----------
    kind : str
        ``ratio`` (FOPTD element), ``delay`` (integrating element, or one of
        another type with no dynamics to scale), ``scaled`` (a ``tf`` or
        ``step_response`` element: ``s = log alpha``, :mod:`.scaled`), ``lag``
        (empty cell, first-order template), ``pulse`` (empty cell of an integrating row).
    pole_model : float
        ``ahat`` of a ratio; 0 for a template or a scaled element.
    tau_reference : float
        ``tau = tau_reference exp(s)`` [samples]: the model's tau, or the
        template's reference (1 for a scaled element: ``exp(s)`` is alpha).
    s_bounds : (float, float)
        Bounds of ``s`` (unused without a time constant).
    delay_bounds : (int, int)
        Whole-sample delays searched: ``dD`` of an element, ``D`` of an interaction.
    low_is_limit : bool
        Whether the lower delay bound is a search limit (else a physical bound).
    scaled : ScaledShape or None
        The model element's shape over alpha, for kind ``scaled``.
    """

    kind: str
    pole_model: float
    tau_reference: float
    s_bounds: tuple[float, float]
    delay_bounds: tuple[int, int]
    low_is_limit: bool
    scaled: ScaledShape | None = None

    @property
    def has_tau(self) -> bool:
        """Whether the coefficient has a time constant (for a scaled element: a dynamics scale alpha) to fit."""
        return self.kind in ("ratio", "lag", "scaled")

    @property
    def interaction(self) -> bool:
        """Whether this is an empty cell's interaction (its linear parameter is the gain gamma)."""
        return self.kind in ("lag", "pulse")

    def pole(self, s: float) -> float:
        """``a = exp(-Ts / tau)`` for ``tau = tau_reference exp(s)`` (Ts = 1 sample)."""
        return math.exp(-1.0 / (self.tau_reference * math.exp(s)))

    def response(self, x: np.ndarray, *, lin: float, s: float, delay: int) -> np.ndarray:
        """The coefficient ``lin * shape(q; s) * q^-delay`` applied to ``x`` in the time domain.

        The same filter as :meth:`shapes` (times ``lin`` and the delay) gives in
        the frequency domain; started at steady state for ``x[0]``.  A negative
        delay is an advance: the last samples repeat the last value.  A scaled
        column reads the element's *input* ``u_k`` instead of its regressor
        ``Ghat u_k`` (:meth:`.scaled.ScaledShape.response`: ``1 / Ghat`` need not be stable).

        Parameters
        ----------
        x : ndarray, shape (N,) or (N, q)
            Signal(s), one per column, along axis 0 (a scaled column: its input, shape (N,)).
        lin : float
            The linear parameter (``rho`` or ``gamma``).
        s : float
            ``log(tau / tau_reference)`` (ignored without a time constant).
        delay : int
            [samples].

        Returns
        -------
        ndarray, shape of ``x``

        Examples
        --------
        >>> column = ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-2, 2), False)
        >>> column.response(np.arange(5.0), lin=2.0, s=0.0, delay=1).tolist()
        [0.0, 0.0, 2.0, 4.0, 6.0]
        """
        x = np.asarray(x, dtype=float)
        if self.scaled is not None:
            out = lin * self.scaled.response(x, s)
        elif self.has_tau:
            a, ah = self.pole(s), self.pole_model
            numerator = lin * (1.0 - a) / (1.0 - ah) * np.array([1.0, -ah])
            denominator = np.array([1.0, -a])
            zi = np.multiply.outer(_first_order_zi(numerator, denominator), x[0])
            out = lfilter(numerator, denominator, x, axis=0, zi=zi)[0]
        else:
            out = lin * x
        if delay > 0:
            out = np.concatenate([np.repeat(out[:1], delay, axis=0), out[:-delay]])
        elif delay < 0:
            out = np.concatenate([out[-delay:], np.repeat(out[-1:], -delay, axis=0)])
        return out

    def numerator(self, z_inv: np.ndarray) -> np.ndarray:
        """``(1 - ahat z^-1) / (1 - ahat)`` at ``z_inv`` (F,): the part of :meth:`shapes` no ``s`` changes."""
        ah = self.pole_model
        return (1 - ah * z_inv) / (1 - ah)

    def shapes(
        self, z_inv: np.ndarray, s: np.ndarray, *, numerator: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Shapes without delay and their derivative in ``s``, shape (len(s), F).

        Parameters
        ----------
        z_inv : ndarray of complex, shape (F,)
        s : ndarray, shape (G,)
        numerator : ndarray of complex, shape (F,), optional
            :meth:`numerator` of ``z_inv``, when already computed (the same numbers).
        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.scaled is not None:
            return self.scaled.shapes(z_inv, s)
        if not self.has_tau:
            return np.ones((s.size, z_inv.size), dtype=complex), np.zeros((s.size, z_inv.size), dtype=complex)
        tau, a, numerator, denominator, shape = self._first_order(z_inv, s, numerator)
        derivative = numerator * (z_inv - 1) / denominator**2 * (a / tau)  # d shape / d a * d a / d s
        return shape, derivative

    def shape(self, z_inv: np.ndarray, s: np.ndarray, *, numerator: np.ndarray | None = None) -> np.ndarray:
        """:meth:`shapes`' shapes alone (same arguments), shape (len(s), F): the same numbers without the derivative."""
        if self.scaled is not None or not self.has_tau:
            return self.shapes(z_inv, s)[0]
        return self._first_order(z_inv, np.atleast_1d(np.asarray(s, dtype=float)), numerator)[4]

    def _first_order(self, z_inv: np.ndarray, s: np.ndarray, numerator: np.ndarray | None) -> tuple[np.ndarray, ...]:
        """``(tau, a, numerator, denominator, shape)`` of a first-order column at each of ``s`` (1-D)."""
        tau = self.tau_reference * np.exp(s)[:, None]
        a = np.exp(-1.0 / tau)
        if numerator is None:
            numerator = self.numerator(z_inv)
        denominator = 1 - a * z_inv
        return tau, a, numerator, denominator, (1 - a) * numerator / denominator


@dataclass(frozen=True)
class RowSystem:
    """The whitened equations of one row in information form, over the fitted bins.

    Attributes
    ----------
    M : ndarray of complex, shape (F', n, n)
        ``A^H A`` per bin.
    v : ndarray of complex, shape (F', n)
        ``A^H b`` per bin.
    beta : ndarray, shape (F',)
        ``|b|^2`` per bin.
    z_inv : ndarray of complex, shape (F',)
        ``exp(-j w)`` at the fitted bins.
    components : int
        Real residual components the cost sums (``2 F' n_z``, as if stacked).
    """

    M: np.ndarray
    v: np.ndarray
    beta: np.ndarray
    z_inv: np.ndarray
    components: int

    def cost(self, theta: np.ndarray) -> float:
        """Weighted squared residual of coefficients ``theta`` (F', n)."""
        return self.cost_and_product(theta)[0]

    def cost_and_product(self, theta: np.ndarray) -> tuple[float, np.ndarray]:
        """:meth:`cost` of ``theta`` and the product ``M theta`` it computes (a fit's gradient needs it too)."""
        Mt = np.einsum("fkm,fm->fk", self.M, theta)
        conjugate = theta.conj()
        quad = np.einsum("fk,fk->", conjugate, Mt).real
        return float(self._beta_total - 2.0 * np.einsum("fk,fk->", conjugate, self.v).real + quad), Mt

    @cached_property
    def _beta_total(self) -> float:
        return self.beta.sum()

    def free_estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """The per-bin least-squares coefficients and each one's variance, shapes (F', n) (computed once; read only)."""
        return self._free

    @cached_property
    def _free(self) -> tuple[np.ndarray, np.ndarray]:
        try:
            inverse = np.linalg.inv(self.M)
        except np.linalg.LinAlgError:
            inverse = np.linalg.pinv(self.M, hermitian=True)
        theta = np.einsum("fkm,fm->fk", inverse, self.v)
        variance = np.maximum(np.real(np.einsum("fkk->fk", inverse)), 1e-300)
        return theta, variance


def bin_scale(noise: np.ndarray, *, bins: np.ndarray, omega: np.ndarray, equivalent_segments: float) -> np.ndarray:
    """What whitens a row's equations to unit-variance real components at each of ``bins``, shape (F',).

    ``sqrt(2 M / Phi_v)``; a real (DC) bin has its whole variance in the real part: half the factor 2.
    """
    scale = np.sqrt(2.0 * equivalent_segments / noise[bins])
    return np.where(omega[bins] == 0.0, scale / np.sqrt(2.0), scale)


def row_system(
    spectra: RowSpectra,
    factor: np.ndarray,
    *,
    columns: np.ndarray,
    noise: np.ndarray,
    bins: np.ndarray,
    omega: np.ndarray,
    equivalent_segments: float,
    whitened: np.ndarray | None = None,
) -> RowSystem:
    """The row's equations whitened to unit-variance real components, in information form.

    Parameters
    ----------
    spectra : RowSpectra
    factor : ndarray, shape (F, n_z, n_z)
        Cholesky factor of the instrument spectra (:func:`~pmr_ros.core.pmr.implicit.instrument_factor`).
    columns : ndarray of int
        The regressors that enter.
    noise : ndarray, shape (F,)
        The row's noise spectrum ``Phi_v``.
    bins : ndarray of int
        Frequency bins that enter the fit.
    omega : ndarray, shape (F,)
        All frequencies [rad/sample].
    equivalent_segments : float
    whitened : ndarray, optional
        ``L^-1 S_{z x}`` at ``bins`` and ``columns`` (:func:`whitened_regressors`) when already computed: it
        does not depend on the weights, and a row's fit whitens the same regressors four times.
    """
    L = factor[bins]
    scale = bin_scale(noise, bins=bins, omega=omega, equivalent_segments=equivalent_segments)
    b = np.linalg.solve(L, spectra.zy[bins][:, :, None])[:, :, 0] * scale[:, None]
    if whitened is None:
        whitened = whitened_regressors(spectra, factor, columns=columns, bins=bins)
    A = whitened * scale[:, None, None]
    return RowSystem(
        M=hermitian_product(A, A),
        v=hermitian_product(A, b[:, :, None])[:, :, 0],
        beta=np.sum(np.abs(b) ** 2, axis=1),
        z_inv=np.exp(-1j * omega[bins]),
        components=2 * b.size,
    )


def whitened_regressors(
    spectra: RowSpectra, factor: np.ndarray, *, columns: np.ndarray, bins: np.ndarray
) -> np.ndarray:
    """``L^-1 S_{z x}`` of the regressors ``columns`` at ``bins``, shape (F', n_z, n): row_system's A unweighted."""
    return np.linalg.solve(factor[bins], spectra.zx[bins][:, :, columns])


def column_moments(spectra: RowSpectra, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(S_xy, S_xx)`` of the regressors ``columns`` of a row: what :func:`noise_spectrum` reads of them."""
    return spectra.xy[:, columns], spectra.xx[:, columns][:, :, columns]


def noise_spectrum(
    spectra: RowSpectra,
    columns: np.ndarray,
    theta: np.ndarray,
    omega: np.ndarray,
    *,
    moments: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Spectrum of ``v_i = y_i - sum_k theta_k x_ik`` for a row's coefficients ``theta`` (F, n).

    Smoothed over :data:`NOISE_SMOOTHING_BINS` bins: a per-bin estimate has only
    the equivalent number of segments as degrees of freedom, and weights that
    noisy would over-weight the bins where the noise happens to come out low
    (measured: intervals 5 % too narrow without smoothing).  A differenced row's
    noise is smoothed with the differencing filter's known ``|1 - e^-jw|^2``
    divided out (it falls to 0 at w = 0, which a moving average would smear
    over the lowest bins).  ``moments``: ``(S_xy, S_xx)`` of ``columns`` when already gathered (the same numbers).
    """
    xy, xx = column_moments(spectra, columns) if moments is None else moments
    cross = np.einsum("fk,fk->f", theta.conj(), xy).real
    quad = np.einsum("fk,fkm,fm->f", theta.conj(), xx, theta).real
    phi = np.maximum(spectra.yy - 2.0 * cross + quad, 1e-6 * spectra.yy + 1e-300)
    shaping = 2.0 - 2.0 * np.cos(omega) if spectra.differenced else np.ones_like(omega)
    if spectra.differenced:
        phi = phi / np.maximum(shaping, 1e-300)
        phi[0] = phi[1]
    half = NOISE_SMOOTHING_BINS // 2
    padded = np.concatenate([phi[half:0:-1], phi, phi[-2 : -half - 2 : -1]])  # np.pad's reflect, without its cost
    smooth = np.convolve(padded, np.ones(NOISE_SMOOTHING_BINS) / NOISE_SMOOTHING_BINS, mode="valid")
    return np.maximum(smooth * shaping, 1e-300)


def _first_order_zi(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter_zi`` of a first-order filter ``[b0, b1] / [1, a1]``, in closed form: the same number.

    ``(b1 - a1 b0) / (1 + a1)`` is what lfilter_zi's companion system solves to; it builds and solves that
    system on every call, which cost the rolling monitor's fits a sixth of their time.  Other orders go to it.
    """
    if numerator.size == 2 and denominator.size == 2 and denominator[0] == 1.0:
        return np.array([(numerator[1] - denominator[1] * numerator[0]) / (1.0 + denominator[1])])
    return np.asarray(lfilter_zi(numerator, denominator))
