"""Maximal-length pseudo-random binary sequences (PRBS) for setpoint excitation.

Each channel is the m-sequence of a *different* primitive polynomial of the
same degree.  Shifted copies of one m-sequence would look uncorrelated at a
single lag but are fully coherent in the frequency domain (one is a delayed
copy of the other), which would make the implicit PMR regression singular.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np

__all__ = [
    "ExcitationSettings",
    "PrbsGenerator",
    "PrbsSettings",
    "dither_generator",
    "is_primitive",
    "m_sequence",
    "primitive_polynomial_count",
    "primitive_polynomials",
]


def _gf2_mulmod(a: int, b: int, poly: int, degree: int) -> int:
    result = 0
    top = 1 << degree
    while b:
        if b & 1:
            result ^= a
        b >>= 1
        a <<= 1
        if a & top:
            a ^= poly
    return result


def _gf2_powmod(base: int, exponent: int, poly: int, degree: int) -> int:
    result = 1
    while exponent:
        if exponent & 1:
            result = _gf2_mulmod(result, base, poly, degree)
        base = _gf2_mulmod(base, base, poly, degree)
        exponent >>= 1
    return result


def _prime_factors(n: int) -> list[int]:
    factors, p = [], 2
    while p * p <= n:
        if n % p == 0:
            factors.append(p)
            while n % p == 0:
                n //= p
        p += 1
    if n > 1:
        factors.append(n)
    return factors


def is_primitive(poly: int, degree: int) -> bool:
    """Whether the GF(2) polynomial ``poly`` (bit i = coefficient of x^i) is primitive.

    x has order exactly 2^degree - 1 modulo ``poly`` iff ``poly`` is primitive.
    """
    if poly >> degree != 1 or not poly & 1:
        return False
    order = (1 << degree) - 1
    if _gf2_powmod(2, order, poly, degree) != 1:
        return False
    return all(_gf2_powmod(2, order // q, poly, degree) != 1 for q in _prime_factors(order))


def primitive_polynomial_count(degree: int) -> int:
    """How many primitive polynomials of ``degree`` exist: ``phi(2^degree - 1) / degree``.

    Each PRBS channel of a loop (setpoints, then dither) needs its own, so this
    bounds the channels a register length can serve.
    """
    order = (1 << degree) - 1
    phi = order
    for p in _prime_factors(order):
        phi = phi // p * (p - 1)
    return phi // degree


@cache
def primitive_polynomials(degree: int, count: int) -> tuple[int, ...]:
    """The first ``count`` primitive polynomials of ``degree``, in increasing order."""
    found = []
    for poly in range((1 << degree) + 1, 1 << (degree + 1), 2):
        if is_primitive(poly, degree):
            found.append(poly)
            if len(found) == count:
                return tuple(found)
    raise ValueError(f"there are fewer than {count} primitive polynomials of degree {degree}")


@lru_cache(maxsize=64)
def m_sequence(poly: int, degree: int) -> np.ndarray:
    """One period (2^degree - 1 bits, values 0/1) of the LFSR sequence of ``poly``."""
    period = (1 << degree) - 1
    taps = poly & period  # feedback taps, without the x^degree term
    state = 1
    bits = np.empty(period, dtype=np.int8)
    for n in range(period):
        bits[n] = state & 1
        feedback = bin(state & taps).count("1") & 1
        state = (state >> 1) | (feedback << (degree - 1))
    return bits


@dataclass(frozen=True)
class PrbsSettings:
    """PRBS setpoint excitation.

    Attributes
    ----------
    register_length : int
        LFSR length n; the sequence repeats every ``2^n - 1`` bits.
    clock_period : int
        Samples each bit is held.  Its power falls to half near
        ``omega = 2.78 / clock_period`` rad/sample, so it sets the excitation band.
    amplitude : ndarray, shape (n_channels,)
        Half the peak-to-peak swing [output unit].
    nominal : ndarray, shape (n_channels,)
        Setpoint around which the PRBS switches [output unit].
    mode : str
        ``prbs`` (this PRBS) or ``steps``: operator-like setpoint changes
        (:class:`~pmr_ros.core.sim.operation.RandomSignal`), each to
        ``nominal + step_amplitude x uniform(-1, 1)`` after random exponential intervals.
    step_interval_samples : float
        ``steps``: the mean interval between changes [samples].
    step_amplitude : ndarray, shape (n_channels,), optional
        ``steps``: the largest distance from nominal [output unit]; None: ``amplitude``.
    """

    register_length: int
    clock_period: int
    amplitude: np.ndarray
    nominal: np.ndarray
    mode: str = "prbs"
    step_interval_samples: float = 480.0
    step_amplitude: np.ndarray | None = None


class PrbsGenerator:
    """Multichannel PRBS ``nominal +/- amplitude`` (setpoints, or MV dither).

    Stateless in ``k``: ``value(k)`` can be asked in any order, so a node and a
    batch run produce the same sequence.  ``seed`` picks each channel's phase.

    Parameters
    ----------
    settings : PrbsSettings
    seed : int
        Seed of the phases.
    first_channel : int
        Index of the first channel among all PRBS of the loop: channels use the
        primitive polynomials from this one on, so setpoints (0 ..) and dither
        (n_outputs ..) never share a sequence.
    stream : int
        Random stream of the phases (1 setpoints, 2 dither).
    """

    def __init__(self, settings: PrbsSettings, seed: int, *, first_channel: int = 0, stream: int = 1) -> None:
        self.settings = settings
        n_channels = len(settings.amplitude)
        degree = settings.register_length
        polys = primitive_polynomials(degree, first_channel + n_channels)[first_channel:]
        self._bits = np.stack([2.0 * m_sequence(p, degree) - 1.0 for p in polys])
        self.period_bits = (1 << degree) - 1
        rng = np.random.default_rng([int(seed), stream])
        self._phase = rng.integers(0, self.period_bits, size=n_channels)
        self._rows = np.arange(n_channels)

    @property
    def period_samples(self) -> int:
        """Samples in one period of the sequence."""
        return self.period_bits * self.settings.clock_period

    def value(self, k: int) -> np.ndarray:
        """Setpoints at sample ``k`` [output unit]."""
        col = (self._phase + k // self.settings.clock_period) % self.period_bits
        return self.settings.nominal + self.settings.amplitude * self._bits[self._rows, col]

    def values(self, k: np.ndarray) -> np.ndarray:
        """Values at the samples ``k`` (any order), shape (len(k), n_channels)."""
        bits = np.asarray(k) // self.settings.clock_period
        cols = (self._phase[:, None] + bits[None, :]) % self.period_bits
        levels = np.take_along_axis(self._bits, cols, axis=1).T
        return self.settings.nominal + self.settings.amplitude * levels

    def sequence(self, samples: int) -> np.ndarray:
        """Setpoints for samples ``0 .. samples-1``, shape (samples, n_channels)."""
        k = np.arange(samples) // self.settings.clock_period
        cols = (self._phase[:, None] + k[None, :]) % self.period_bits
        levels = np.take_along_axis(self._bits, cols, axis=1).T
        return self.settings.nominal + self.settings.amplitude * levels


@dataclass(frozen=True)
class ExcitationSettings:
    """MV dither: an independent PRBS added to each controller output (the ``excitation`` block).

    Attributes
    ----------
    mv_dither_amplitude : ndarray, shape (n_inputs,)
        Half the peak-to-peak swing per input [input unit]; 0: no dither.
    mv_dither_clock_period : int
        Samples each dither bit is held.
    """

    mv_dither_amplitude: np.ndarray
    mv_dither_clock_period: int

    @property
    def active(self) -> bool:
        """Whether any input is dithered."""
        return bool(np.any(np.asarray(self.mv_dither_amplitude) > 0))


def dither_generator(excitation: ExcitationSettings, prbs: PrbsSettings, seed: int) -> PrbsGenerator:
    """The MV dither of run ``seed``: its own m-sequences (after the setpoints'), its own phases.

    Parameters
    ----------
    excitation : ExcitationSettings
    prbs : PrbsSettings
        The setpoints' PRBS (register length; the dither takes the next polynomials).
    seed : int
    """
    amplitude = np.asarray(excitation.mv_dither_amplitude, dtype=float)
    settings = PrbsSettings(
        prbs.register_length, excitation.mv_dither_clock_period, amplitude, np.zeros_like(amplitude)
    )
    return PrbsGenerator(settings, seed, first_channel=len(prbs.amplitude), stream=2)
