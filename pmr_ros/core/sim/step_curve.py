"""The ``step_response`` element: a sampled step-response curve, as DMC-type controllers hold their models.

The curve is ``s_1 .. s_N``, the response to a unit step of the input at
sample 0, at the model's sample time, dead time included (its first
``delay_samples`` coefficients are 0).  After the curve the response stays at
``s_N`` (the last coefficients are at steady state) or, for a ramp
(integrating) output, keeps rising at the last slope ``s_N - s_(N-1)``.
The module also converts any element to such a curve (:func:`as_step_response`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.interpolate import CubicSpline

from .lti import DiscreteElement, Element, ElementError

__all__ = ["StepResponse", "as_step_response", "dead_time_samples"]


def dead_time_samples(curve: np.ndarray) -> int:
    """The number of leading coefficients that are exactly 0 (at most ``len(curve) - 1``)."""
    curve = np.asarray(curve, dtype=float)
    nonzero = np.flatnonzero(curve != 0.0)
    return int(nonzero[0]) if nonzero.size else max(curve.size - 1, 0)


@dataclass(frozen=True)
class StepResponse(Element):
    """A step-response curve with its dead time and ramp flag.

    Attributes
    ----------
    curve : tuple of float
        ``s_1 .. s_N`` [output unit / input unit], at ``k Ts``, k = 1..N.
    delay_samples : int
        Dead time [samples]: ``s_1 .. s_d`` are 0; the curve must be longer.
    sample_time : float
        Ts [time unit].
    ramp : bool
        The output is a ramp: after the curve the response rises at the last slope.
    stated_gain : float or None
        The steady-state gain (ramp: rate per time unit) as the model file
        states it, with more digits than the curve's last coefficient; None:
        taken from the curve.
    name : str
        The element's name, for messages.
    """

    curve: tuple[float, ...]
    delay_samples: int
    sample_time: float
    ramp: bool = False
    stated_gain: float | None = None
    name: str = "step_response"
    kind = "step_response"

    def __post_init__(self) -> None:
        curve = np.asarray(self.curve, dtype=float).ravel()
        object.__setattr__(self, "curve", tuple(curve.tolist()))
        n, d = curve.size, self.delay_samples
        if n == 0 or not np.all(np.isfinite(curve)):
            raise ElementError(f"{self.name}: the step-response curve must be one or more finite numbers")
        if d < 0:
            raise ElementError(f"{self.name}: delay {d} samples must be >= 0")
        if n <= d:
            raise ElementError(
                f"{self.name}: the step-response curve of {n} coefficients is shorter than its delay of {d} samples"
            )
        early = np.flatnonzero(np.abs(curve[:d]) > 1e-9 * np.max(np.abs(curve)))
        if early.size:
            k = int(early[0])
            raise ElementError(
                f"{self.name}: the step-response curve responds before its delay of {d} samples "
                f"(coefficient {k + 1} is {curve[k]:.6g})"
            )

    @cached_property
    def _curve(self) -> np.ndarray:
        return np.asarray(self.curve)

    @cached_property
    def _resampler(self) -> CubicSpline:
        """The cubic spline through ``r_0 = 0, r_1 .. r_M``, the curve after its delay.

        Built once: the diagnosis scales one element many times.
        """
        after = np.concatenate(([0.0], self._curve[self.delay_samples :]))
        return CubicSpline(np.arange(after.size), after)

    @property
    def integrating(self) -> bool:
        """The ramp flag."""
        return self.ramp

    @property
    def last_slope(self) -> float:
        """``s_N - s_(N-1)`` [output unit / input unit per sample] (``s_0 = 0``)."""
        c = self._curve
        return float(c[-1] - (c[-2] if c.size > 1 else 0.0))

    @property
    def steady_state_gain(self) -> float:
        """:attr:`stated_gain`, else ``s_N``; a ramp's rate per time unit, ``(s_N - s_(N-1)) / Ts``."""
        if self.stated_gain is not None:
            return float(self.stated_gain)
        return self.last_slope / self.sample_time if self.ramp else float(self._curve[-1])

    def step_response(self, n: int) -> np.ndarray:
        """``s_1 .. s_n``: the curve itself, held or ramped on beyond its end, shape (n,)."""
        c = self._curve
        if n <= c.size:
            return c[:n].copy()
        beyond = np.arange(1, n - c.size + 1)
        tail = c[-1] + (beyond * self.last_slope if self.ramp else 0.0 * beyond)
        return np.concatenate((c, tail))

    def impulse_response(self, n: int) -> np.ndarray:
        """``h_k = s_k - s_(k-1)``, k = 1..n, shape (n,)."""
        return np.diff(self.step_response(n), prepend=0.0)

    def discrete(self) -> DiscreteElement:
        """The finite impulse response after the delay; a ramp's last slope goes on (pole at z = 1)."""
        pulses = np.diff(self._curve[self.delay_samples :], prepend=0.0)
        if self.ramp:
            return DiscreteElement(
                np.concatenate(([0.0], np.diff(pulses, prepend=0.0))), np.array([1.0, -1.0]), self.delay_samples
            )
        return DiscreteElement(np.concatenate(([0.0], pulses)), np.ones(1), self.delay_samples)

    def scaled(self, *, gain_ratio: float = 1.0, time_scale: float = 1.0, delay_change: int = 0) -> StepResponse:
        """The curve after its delay resampled at ``t / alpha`` (cubic spline), times rho; delay + dD.

        The scaled curve has ``ceil(alpha (N - d))`` coefficients after its dead
        time, so it reaches the end of the original in scaled time (see
        :meth:`Element.scaled`).
        """
        delay = self._checked_scaling(time_scale, delay_change)
        after = np.concatenate(([0.0], self._curve[self.delay_samples :]))  # r_0 = 0 .. r_M, delay-free
        m = after.size - 1
        x = np.arange(1, max(1, int(np.ceil(time_scale * m - 1e-9))) + 1) / time_scale
        inside = self._resampler(np.minimum(x, m))
        slope = self.last_slope if self.ramp else 0.0
        values = np.where(x > m, after[-1] + (x - m) * slope, inside)
        stated = None
        if self.stated_gain is not None:
            stated = self.stated_gain * gain_ratio / (time_scale if self.ramp else 1.0)
        curve = np.concatenate((np.zeros(delay), gain_ratio * values))
        return replace(self, curve=tuple(curve), delay_samples=delay, stated_gain=stated)


def as_step_response(element: Element, n_coefficients: int, *, name: str = "step_response") -> StepResponse:
    """Any element as its step-response curve of ``n_coefficients`` (truncated there), ramp flag if integrating.

    Parameters
    ----------
    element : Element
        The element to convert.
    n_coefficients : int
        N; enough to reach steady state (see :meth:`Element.settle_samples`),
        else the curve is truncated before it.
    name : str
        The element's name, for messages.

    Returns
    -------
    StepResponse

    Raises
    ------
    ElementError
        ``n_coefficients`` not longer than the element's delay.
    """
    return StepResponse(
        tuple(element.step_response(n_coefficients)),
        element.delay_samples,
        element.sample_time,
        ramp=element.integrating,
        name=name,
    )
