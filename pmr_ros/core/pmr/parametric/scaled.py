"""The plant-model ratio of an element of any type: ``rho Ghat(s alpha) exp(-dD s)`` over ``Ghat``.

A ``tf`` or ``step_response`` element (any :class:`~pmr_ros.core.sim.lti.Element`)
has no time constant of its own; the plant is modelled as the model element
made faster or slower as a whole, with its gain and delay changed,

    G(s) = rho Ghat(s alpha) exp(-dD Ts s),

through :meth:`~pmr_ros.core.sim.lti.Element.scaled` (a ``tf`` element scales
its coefficients, a ``step_response`` element resamples its curve).  Its
coefficient in the row's regression is ``lin shape(w; s) z^-dD`` with
``alpha = exp(s)`` and the shape

    shape(w; s) = n(alpha) Ghat_alpha(e^jw) / Ghat(e^jw),

``Ghat_alpha`` the sampled ``Ghat(s alpha)``.  ``n = 1`` for a stable element
(both have the same steady-state gain, so the shape is 1 at w = 0 and ``lin``
is ``rho``); ``n = alpha`` for an integrating one (``Ghat(s alpha)`` divides
the ramp rate by alpha: with ``n`` the shape keeps it, ``lin`` is the
ramp-rate ratio and alpha scales only the element's other dynamics).  For a
FOPTD element this is exactly :func:`~.ratio.ratio_shape` with
``tau = tauhat alpha`` -- the FOPTD columns keep that closed form.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...sim.lti import Element
from ...sim.realize import element_outputs

__all__ = ["DERIVATIVE_STEP", "ScaledShape"]

DERIVATIVE_STEP = 1e-5
"""Step in ``s = log alpha`` of the central difference that gives ``d shape / d s``.

Its truncation error (relative ~ step^2 = 1e-10) and round-off (~1e-16 / step
= 1e-11) are both far below what a fit or its covariance reads."""

KEPT_RATIOS = 512
"""Most shapes one element keeps (per frequency grid and alpha) before it forgets them all."""

_BASES: dict[bytes, np.ndarray] = {}
"""``exp(-j w k)``, k = 0, 1, ..., per frequency grid: the DFT of a long finite impulse response as one product."""

_BASIS_GRIDS = 4
"""Most frequency grids :data:`_BASES` keeps."""

_BASIS_SIZE = 1 << 21
"""Largest basis kept (frequencies x coefficients; 32 MB): beyond it Horner's rule (rare calls on every bin)."""


def _response(element: Element, omega: np.ndarray) -> np.ndarray:
    """``b(e^jw) / a(e^jw)`` of the sampled element, its whole-sample delay left out (it cancels in the ratio).

    A step-response curve's numerator has as many coefficients as the curve:
    Horner's rule would loop over them in Python; one matrix product with
    the grid's ``exp(-j w k)`` does not.
    """
    disc = element.discrete()
    b, a = disc.numerator, disc.denominator
    if b.size <= 16 or omega.size * b.size > _BASIS_SIZE:
        z_inv = np.exp(-1j * omega)
        with np.errstate(divide="ignore", invalid="ignore"):  # an integrator is infinite at omega 0
            return np.polyval(b[::-1], z_inv) / np.polyval(a[::-1], z_inv)
    key = omega.tobytes()
    basis = _BASES.get(key)
    if basis is None or basis.shape[1] < b.size:
        if len(_BASES) >= _BASIS_GRIDS:
            _BASES.clear()
        size = min(max(b.size, 2 * (0 if basis is None else basis.shape[1])), _BASIS_SIZE // omega.size)
        basis = _BASES[key] = np.exp(-1j * np.outer(omega, np.arange(size)))
    with np.errstate(divide="ignore", invalid="ignore"):  # an integrator is infinite at omega 0
        return (basis[:, : b.size] @ b) / (basis[:, : a.size] @ a)


_NO_DYNAMICS = 1e-9
"""A shape that moves less than this when alpha changes by half: the element has no dynamics to scale (``K/s``)."""


@dataclass(frozen=True, eq=False)
class ScaledShape:
    """The shape of one element's ratio over ``s = log alpha`` (see the module docstring).

    Attributes
    ----------
    element : Element
        The model element ``Ghat``.
    """

    element: Element
    _model: dict[bytes, np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)
    _ratios: dict[tuple[bytes, float], np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)

    def _normalization(self, alpha: np.ndarray | float) -> np.ndarray | float:
        return alpha if self.element.integrating else 1.0

    def _model_response(self, omega: np.ndarray) -> np.ndarray:
        """``Ghat(e^jw)`` without its delay, kept per frequency grid (the fit asks for the same bins many times)."""
        key = omega.tobytes()
        if key not in self._model:
            self._model[key] = _response(self.element, omega)
        return self._model[key]

    def ratio(self, omega: np.ndarray, alpha: float) -> np.ndarray:
        """``shape(w)`` at ``alpha`` and ``omega`` [rad/sample], shape of ``omega``; 1 at w = 0.

        Kept per frequency grid and alpha (the delay search refits the other
        columns at the same alpha many times); at most :data:`KEPT_RATIOS` of them.
        """
        omega = np.asarray(omega, dtype=float)
        key = (omega.tobytes(), float(alpha))
        if key not in self._ratios:
            if len(self._ratios) >= KEPT_RATIOS:
                self._ratios.clear()
            scaled = _response(self.element.scaled(time_scale=float(alpha)), omega)
            with np.errstate(divide="ignore", invalid="ignore"):
                out = self._normalization(alpha) * scaled / self._model_response(omega)
            self._ratios[key] = np.where(omega == 0.0, 1.0, out)
        return self._ratios[key]

    def shapes(self, z_inv: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shapes at ``z_inv = exp(-jw)`` for each ``s`` and their derivative in ``s``, each shape (len(s), F).

        The derivative is a central difference of :data:`DERIVATIVE_STEP`.
        """
        omega = np.abs(np.angle(np.asarray(z_inv)))
        s = np.atleast_1d(np.asarray(s, dtype=float))
        shape = np.array([self.ratio(omega, float(np.exp(v))) for v in s]).reshape(s.size, omega.size)
        up = np.array([self.ratio(omega, float(np.exp(v + DERIVATIVE_STEP))) for v in s])
        down = np.array([self.ratio(omega, float(np.exp(v - DERIVATIVE_STEP))) for v in s])
        return shape, (up - down).reshape(s.size, omega.size) / (2.0 * DERIVATIVE_STEP)

    def response(self, u: np.ndarray, s: float) -> np.ndarray:
        """``n(alpha) Ghat_alpha u``: the shape applied to the regressor ``Ghat u``, computed from the input ``u``.

        Started as the row's regressors start (:func:`~pmr_ros.core.sim.realize.element_outputs`:
        at steady state for ``u[0]``, an integrating element at zero), so it
        stays stable where ``1 / Ghat`` would not be (a zero outside the unit circle).

        Parameters
        ----------
        u : ndarray, shape (N,)
            The element's input.
        s : float
            ``log alpha``.

        Returns
        -------
        ndarray, shape (N,)
        """
        alpha = float(np.exp(s))
        scaled = self.element.scaled(time_scale=alpha)
        out = element_outputs([[scaled]], np.asarray(u, dtype=float)[:, None])[:, 0, 0]
        return self._normalization(alpha) * out

    @property
    def has_dynamics(self) -> bool:
        """Whether alpha changes the shape at all (``K/s`` and a pure ramp curve have nothing to scale)."""
        omega = np.linspace(0.05, np.pi, 16)
        return bool(np.max(np.abs(self.ratio(omega, 1.5) - 1.0)) > _NO_DYNAMICS)
