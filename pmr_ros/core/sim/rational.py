"""The ``tf`` element: a rational transfer function with dead time, from MATLAB-style coefficient strings.

``num(s) / den(s) * exp(-theta s)``, coefficients in descending powers of s
as MATLAB's ``tf`` takes them (``"12.8"`` / ``"16.7, 1"``; ``"-0.5, 1"`` /
``"20, 12, 1"``).  It must be proper (numerator degree <= denominator degree)
and stable or with exactly one integrator (a pole at s = 0, the rest in the
open left half-plane).  Sampled exactly with a zero-order hold
(:func:`scipy.signal.cont2discrete`) under the convention of :mod:`.lti`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.signal import cont2discrete

from .lti import DiscreteElement, Element, ElementError

__all__ = ["TransferFunction", "parse_coefficients", "transfer_function"]

_SEPARATORS = re.compile(r"[,;\s]+")


def parse_coefficients(text: str, *, element: str, field: str) -> tuple[float, ...]:
    """Polynomial coefficients in descending powers of s from a string such as ``"20, 12, 1"``.

    Commas, semicolons or blanks separate the numbers; square brackets around
    them are allowed (``"[20 12 1]"``).

    Parameters
    ----------
    text : str
        The coefficients.
    element : str
        The element's name (``G21``), for the message.
    field : str
        ``numerator`` or ``denominator``, for the message.

    Returns
    -------
    tuple of float

    Raises
    ------
    ElementError
        One line naming the element, the field and the string.

    Examples
    --------
    >>> parse_coefficients("[20 12, 1]", element="G11", field="denominator")
    (20.0, 12.0, 1.0)
    """
    hint = "coefficients in descending powers of s, such as '16.7, 1'"
    if not isinstance(text, str):
        raise ElementError(f"{element}: {field} {text!r} must be a string of {hint}")
    body = text.strip().removeprefix("[").removesuffix("]").strip()
    tokens = [t for t in _SEPARATORS.split(body) if t]
    if not tokens:
        raise ElementError(f"{element}: {field} {text!r} is empty: give {hint}")
    values = []
    for token in tokens:
        try:
            value = float(token)
        except ValueError:
            raise ElementError(
                f"{element}: {field} {text!r} does not parse: {token!r} is not a number ({hint})"
            ) from None
        if not np.isfinite(value):
            raise ElementError(f"{element}: {field} {text!r} does not parse: {token!r} is not finite")
        values.append(value)
    return tuple(values)


def _strip(numerator: np.ndarray, denominator: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leading zeros off both, and common factors ``s`` (trailing zeros of both) cancelled."""
    num, den = np.trim_zeros(numerator, "f"), np.trim_zeros(denominator, "f")
    while num.size > 1 and den.size > 1 and num[-1] == 0 and den[-1] == 0:
        num, den = num[:-1], den[:-1]
    return num, den


def _check_poles(den: np.ndarray, name: str) -> int:
    """The number of integrators (0 or 1); :class:`ElementError` for an unstable or doubly integrating one."""
    integrators = den.size - np.trim_zeros(den, "b").size
    if integrators > 1:
        raise ElementError(f"{name}: denominator has {integrators} poles at s = 0: at most one integrator is allowed")
    rest = np.roots(np.trim_zeros(den, "b"))
    bad = rest[rest.real >= -1e-12 * np.maximum(1.0, np.abs(rest))]
    if bad.size:
        pole = complex(bad[np.argmax(bad.real)])
        where = "on the imaginary axis" if abs(pole.real) <= 1e-12 * max(1.0, abs(pole)) else "in the right half-plane"
        raise ElementError(
            f"{name}: unstable: pole at s = {pole.real:.6g}{pole.imag:+.6g}j {where} "
            "(allowed: poles with negative real part and at most one integrator)"
        )
    return integrators


@dataclass(frozen=True)
class TransferFunction(Element):
    """``num(s)/den(s) exp(-theta s)``, proper, stable or with one integrator; build with :func:`transfer_function`.

    Attributes
    ----------
    numerator, denominator : tuple of float
        Coefficients in descending powers of s (leading zeros and common
        factors s removed).
    delay_samples : int
        theta / Ts [samples].
    sample_time : float
        Ts [time unit].
    name : str
        The element's name, for messages.
    """

    numerator: tuple[float, ...]
    denominator: tuple[float, ...]
    delay_samples: int
    sample_time: float
    name: str = "tf"
    kind = "tf"

    def __post_init__(self) -> None:
        num, den = _strip(np.array(self.numerator, dtype=float), np.array(self.denominator, dtype=float))
        if den.size == 0:
            raise ElementError(f"{self.name}: denominator is zero")
        if num.size == 0:
            raise ElementError(f"{self.name}: numerator is zero: use element_type none for an empty cell")
        if num.size > den.size:
            raise ElementError(
                f"{self.name}: improper: numerator degree {num.size - 1} > denominator degree {den.size - 1} "
                "(a proper transfer function is needed)"
            )
        _check_poles(den, self.name)
        if self.delay_samples < 0:
            raise ElementError(f"{self.name}: delay {self.delay_samples} samples must be >= 0")
        object.__setattr__(self, "numerator", tuple(float(v) for v in num))
        object.__setattr__(self, "denominator", tuple(float(v) for v in den))

    @property
    def integrating(self) -> bool:
        """Whether the denominator has a pole at s = 0."""
        return self.denominator[-1] == 0.0

    @property
    def steady_state_gain(self) -> float:
        """``num(0)/den(0)``; with an integrator, the ramp rate ``num(0) / (den(s)/s)(0)`` per time unit."""
        den = self.denominator[:-1] if self.integrating else self.denominator
        return self.numerator[-1] / den[-1]

    def discrete(self) -> DiscreteElement:
        """ZOH sampling; a biproper element's direct term ``D`` acts one sample later (``D z^-1``)."""
        return self._sampled

    @cached_property
    def _sampled(self) -> DiscreteElement:
        num_d, den_d, _ = cont2discrete((self.numerator, self.denominator), self.sample_time, method="zoh")
        num_d, den_d = np.atleast_2d(num_d)[0], np.asarray(den_d, dtype=float)
        num_d = np.pad(num_d, (den_d.size - num_d.size, 0))
        # strictly proper: no direct term (the conversion's round-off would leave one of ~1e-17)
        direct = num_d[0] / den_d[0] if len(self.numerator) == len(self.denominator) else 0.0
        b = np.concatenate((num_d - direct * den_d, [0.0])) + np.concatenate(([0.0], direct * den_d))
        return DiscreteElement(b / den_d[0], den_d / den_d[0], self.delay_samples)

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> TransferFunction:
        """``rho num(alpha s) / den(alpha s)`` and the delay + dD (see :meth:`Element.scaled`)."""
        delay = self._checked_scaling(time_scale, delay_change)
        num, den = np.array(self.numerator), np.array(self.denominator)
        num = num * time_scale ** np.arange(num.size - 1, -1, -1) * gain_ratio
        den = den * time_scale ** np.arange(den.size - 1, -1, -1)
        return replace(self, numerator=tuple(num), denominator=tuple(den), delay_samples=delay)


def transfer_function(
    numerator: str, denominator: str, *, delay_samples: int, sample_time: float, name: str = "tf"
) -> TransferFunction:
    """The ``tf`` element from its coefficient strings (``system.numerator``, ``system.denominator``).

    Parameters
    ----------
    numerator, denominator : str
        Coefficients in descending powers of s (``"-0.5, 1"``, ``"20, 12, 1"``).
    delay_samples : int
        Dead time [samples].
    sample_time : float
        Ts [time unit].
    name : str
        The element's name (``G12``), for messages.

    Returns
    -------
    TransferFunction

    Raises
    ------
    ElementError
        A string that does not parse, an improper or unstable transfer function (one line).

    Examples
    --------
    >>> g = transfer_function("-0.5, 1", "20, 12, 1", delay_samples=2, sample_time=1.0)
    >>> g.steady_state_gain
    1.0
    """
    num = parse_coefficients(numerator, element=name, field="numerator")
    den = parse_coefficients(denominator, element=name, field="denominator")
    return TransferFunction(num, den, delay_samples, sample_time, name)
