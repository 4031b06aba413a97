"""The element interface every model element offers, and the FOPTD, integrating and empty elements.

An element is one cell ``G_ik`` of a model: a linear time-invariant map from
one input to one output, sampled at the model's sample time ``Ts`` with a
zero-order hold and a dead time of whole samples.  Whatever its form (FOPTD,
a rational transfer function, a step-response curve), it offers the same
methods (:class:`Element`): step and impulse response, frequency response,
steady-state gain, a discrete state-space realization, and ``scaled`` -- the
element ``rho * G(s * alpha) * exp(-dD s)`` the plant-model ratio is
parametrised with.

Sampling convention (that of DMC step-response models and of the FOPTD
elements so far): the output at sample ``k`` is measured before the move of
sample ``k`` acts, so the discrete step response is ``s_0 = 0`` and
``s_k = s(k Ts)`` for ``k >= 1``, ``s(t)`` the continuous step response
(delay included).  The sampled element is therefore always strictly proper:
``y(k)`` depends on ``u(k-1), u(k-2), ...`` -- a biproper transfer function
(lead-lag) acts one sample after the move, not in the same sample.

Frequencies are in rad/sample; times in the model's time unit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import lfilter

__all__ = ["DiscreteElement", "Element", "ElementError", "Empty", "Foptd", "Integrating", "controllable_form"]


class ElementError(ValueError):
    """An element that cannot be built: one line naming the element, the bad value and why."""


@dataclass(frozen=True)
class DiscreteElement:
    """The sampled element ``z^-delay_samples * b(z^-1) / a(z^-1)``.

    Attributes
    ----------
    numerator : ndarray
        ``b``, coefficients of ``z^0, z^-1, ...``; ``b[0] = 0`` (strictly proper).
    denominator : ndarray
        ``a``, coefficients of ``z^0, z^-1, ...``; ``a[0] = 1``.
    delay_samples : int
        Dead time in whole samples, on top of the one sample the hold adds.
    """

    numerator: np.ndarray
    denominator: np.ndarray
    delay_samples: int


class Element:
    """What every element offers; subclasses give :meth:`discrete` and :meth:`scaled`.

    Subclasses are frozen dataclasses with at least ``sample_time`` [time
    unit] and ``delay_samples`` [samples].  ``kind`` names the element type
    as ``system.element_type`` does.
    """

    kind = ""
    sample_time: float
    delay_samples: int

    @property
    def integrating(self) -> bool:
        """Whether the element has one integrator (a "ramp": no steady state)."""
        return False

    @property
    def steady_state_gain(self) -> float:
        """Steady-state gain [output unit / input unit]; an integrating element's ramp rate instead.

        The ramp rate is K of ``K/s`` [output unit / input unit / time unit].
        """
        raise NotImplementedError

    def discrete(self) -> DiscreteElement:
        """The exact zero-order-hold sampling (see the module's convention)."""
        raise NotImplementedError

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> Element:
        """The element ``rho * G(s * alpha) * exp(-dD Ts s)``: gain, speed and delay changed, shape kept.

        Parameters
        ----------
        gain_ratio : float
            ``rho``, the factor on the gain.
        time_scale : float
            ``alpha > 0``: every time constant of the element times ``alpha``
            (> 1 slower, < 1 faster); the dead time is not scaled.  For a FOPTD
            element ``tau * alpha``, so ``alpha - 1`` is its relative change of tau.
        delay_change : int
            ``dD`` [samples], added to the dead time.

        Returns
        -------
        Element
            Of the same type.

        Raises
        ------
        ElementError
            ``alpha <= 0``, or a dead time that would become negative.
        """
        raise NotImplementedError

    def _checked_scaling(self, time_scale: float, delay_change: int) -> int:
        """The new delay in samples, after checking ``alpha`` and the delay change."""
        if not (np.isfinite(time_scale) and time_scale > 0):
            raise ElementError(f"{self.kind} element: time_scale {time_scale!r} must be a finite number > 0")
        if int(delay_change) != delay_change:
            raise ElementError(f"{self.kind} element: delay_change {delay_change!r} must be whole samples")
        delay = self.delay_samples + int(delay_change)
        if delay < 0:
            raise ElementError(
                f"{self.kind} element: delay {self.delay_samples} samples changed by {delay_change} would be negative"
            )
        return delay

    def impulse_response(self, n: int) -> np.ndarray:
        """``h_1 .. h_n``, the response to a unit pulse at sample 0 (``h_0 = 0`` always), shape (n,)."""
        disc = self.discrete()
        pulse = np.zeros(n + 1)
        pulse[0] = 1.0
        h = lfilter(disc.numerator, disc.denominator, pulse)
        shifted = np.concatenate((np.zeros(disc.delay_samples), h))[: n + 1]
        return shifted[1:]

    def step_response(self, n: int) -> np.ndarray:
        """``s_1 .. s_n``, the response to a unit step at sample 0 (``s_0 = 0`` always), shape (n,)."""
        return np.cumsum(self.impulse_response(n))

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """``G(e^{j omega})`` with the delay, at ``omega`` [rad/sample], shape of ``omega`` (complex).

        An integrating element is infinite at ``omega = 0``.
        """
        omega = np.asarray(omega, dtype=float)
        disc = self.discrete()
        z_inv = np.exp(-1j * omega)
        # Horner in z^-1: sum_j b_j z^-j = polyval(b reversed, z^-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = np.polyval(disc.numerator[::-1], z_inv) / np.polyval(disc.denominator[::-1], z_inv)
        return h * z_inv**disc.delay_samples

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """A discrete realization ``x+ = A x + B u``, ``y = C x + D u``: ``(A, B, C, D)``, D = 0.

        The dynamics in controllable canonical form, fed through a shift
        register of ``delay_samples`` states; the register's states come first.
        An empty element has no state.
        """
        disc = self.discrete()
        b, a = np.trim_zeros(disc.numerator, "b"), np.trim_zeros(disc.denominator, "b")
        if b.size == 0:
            return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.zeros((1, 1))
        return _with_input_delay(*controllable_form(b, a), disc.delay_samples)

    def settle_samples(self, fraction: float = 1e-3) -> int:
        """Samples until the element's own dynamics fade to ``fraction`` (delay included).

        An integrating element's integrator does not count: its other poles do.
        """
        disc = self.discrete()
        poles = np.roots(disc.denominator) if disc.denominator.size > 1 else np.zeros(0)
        poles = poles[np.abs(poles - 1.0) > 1e-9] if self.integrating else poles
        radius = float(np.max(np.abs(poles))) if poles.size else 0.0
        fade = int(np.ceil(np.log(fraction) / np.log(radius))) if radius > 0 else 0
        return disc.delay_samples + disc.numerator.size + fade


def controllable_form(b: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of ``b(z^-1)/a(z^-1)``, ``b[0] = 0``, ``a[0] = 1``: the controllable canonical form.

    The form :func:`scipy.signal.tf2ss` gives, written out (it is the same
    for polynomials in z^-1 padded to one length), without its overhead.
    """
    n = max(b.size, a.size) - 1
    a_full, b_full = np.pad(a, (0, n + 1 - a.size)), np.pad(b, (0, n + 1 - b.size))
    A = np.zeros((n, n))
    A[0] = -a_full[1:]
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    return A, B, b_full[1:][None, :].copy(), np.zeros((1, 1))


def _with_input_delay(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, delay: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` behind a shift register of ``delay`` samples on its input (register states first)."""
    if delay == 0:
        return A, B, C, D
    n = A.shape[0]
    big_a = np.zeros((delay + n, delay + n))
    big_a[1:delay, : delay - 1] = np.eye(delay - 1)
    big_a[delay:, delay - 1] = B[:, 0]
    big_a[delay:, delay:] = A
    big_b = np.zeros((delay + n, 1))
    big_b[0, 0] = 1.0
    big_c = np.hstack([np.zeros((C.shape[0], delay - 1)), D, C])
    return big_a, big_b, big_c, np.zeros_like(D)


@dataclass(frozen=True)
class Foptd(Element):
    """``K exp(-theta s) / (tau s + 1)``, sampled ``b z^-(1+d) / (1 - a z^-1)``, ``a = exp(-Ts/tau)``, ``b = K(1-a)``.

    Attributes
    ----------
    gain : float
        K [output unit / input unit].
    time_constant : float
        tau [time unit], > 0.
    delay_samples : int
        theta / Ts [samples].
    sample_time : float
        Ts [time unit].
    """

    gain: float
    time_constant: float
    delay_samples: int
    sample_time: float
    kind = "foptd"

    @property
    def steady_state_gain(self) -> float:
        """K."""
        return float(self.gain)

    def discrete(self) -> DiscreteElement:
        """``b z^-1 / (1 - a z^-1)`` and the delay."""
        pole = float(np.exp(-self.sample_time / self.time_constant))
        return DiscreteElement(np.array([0.0, self.gain * (1.0 - pole)]), np.array([1.0, -pole]), self.delay_samples)

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> Foptd:
        """K rho, tau alpha, delay + dD (see :meth:`Element.scaled`)."""
        delay = self._checked_scaling(time_scale, delay_change)
        return replace(
            self, gain=self.gain * gain_ratio, time_constant=self.time_constant * time_scale, delay_samples=delay
        )


@dataclass(frozen=True)
class Integrating(Element):
    """``K exp(-theta s) / s``, sampled ``K Ts z^-(1+d) / (1 - z^-1)``.

    Attributes
    ----------
    gain : float
        K [output unit / input unit / time unit].
    delay_samples : int
        theta / Ts [samples].
    sample_time : float
        Ts [time unit].
    """

    gain: float
    delay_samples: int
    sample_time: float
    kind = "integrating"

    @property
    def integrating(self) -> bool:
        """True."""
        return True

    @property
    def steady_state_gain(self) -> float:
        """The ramp rate K [output unit / input unit / time unit]."""
        return float(self.gain)

    def discrete(self) -> DiscreteElement:
        """``K Ts z^-1 / (1 - z^-1)`` and the delay."""
        return DiscreteElement(np.array([0.0, self.gain * self.sample_time]), np.array([1.0, -1.0]), self.delay_samples)

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> Integrating:
        """``rho K / (alpha s)``: the ramp rate times ``rho / alpha`` (see :meth:`Element.scaled`)."""
        delay = self._checked_scaling(time_scale, delay_change)
        return replace(self, gain=self.gain * gain_ratio / time_scale, delay_samples=delay)


@dataclass(frozen=True)
class Empty(Element):
    """An empty cell: no model, the output does not depend on this input.

    Attributes
    ----------
    sample_time : float
        Ts [time unit].
    """

    sample_time: float
    delay_samples: int = 0
    kind = "none"

    @property
    def steady_state_gain(self) -> float:
        """0."""
        return 0.0

    def discrete(self) -> DiscreteElement:
        """``0``."""
        return DiscreteElement(np.zeros(1), np.ones(1), 0)

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> Empty:
        """Itself: nothing to scale."""
        return self
