"""The time scale of a model element of any type, as the diagnosis sizes its segments and templates by it.

A FOPTD element's is its time constant.  A ``tf`` or ``step_response``
element has none of its own; its *equivalent time constant* is the one a
FOPTD element settling as fast would have: a third of the time its step
response (dead time excluded) takes to come within ``exp(-3)`` (5 %) of its
end and stay there -- exactly tau for a FOPTD element, about the sum of the
lags for a lag chain, the lag of a lead-lag.  An integrating element's is
that of its slope (the impulse response): 0 for ``K/s``.
"""

from __future__ import annotations

import math

import numpy as np

from ..sim.lti import Element, Foptd
from ..sim.model import TransferMatrix

__all__ = ["SETTLED", "equivalent_time_constant", "row_time_constants", "slowest_time_constant"]

SETTLED = math.exp(-3.0)
"""Settled: within this fraction of the final value (3 time constants of a first-order lag)."""


def equivalent_time_constant(element: Element) -> float:
    """The element's time constant, or its equivalent (module docstring) [time unit]; 0 without dynamics.

    Examples
    --------
    >>> from pmr_ros.core.sim.rational import transfer_function
    >>> lag = transfer_function("1", "10, 1", delay_samples=2, sample_time=1.0)
    >>> round(equivalent_time_constant(lag), 1)
    10.0
    """
    if isinstance(element, Foptd):
        return float(element.time_constant)
    n = element.settle_samples(1e-4) + 1
    curve = element.impulse_response(n) if element.integrating else element.step_response(n)
    curve = curve[element.delay_samples :]
    final = float(curve[-1])
    if curve.size == 0 or final == 0.0:
        return 0.0
    excess = np.abs(curve - final) - SETTLED * abs(final)
    outside = np.flatnonzero(excess > 0.0)
    if outside.size == 0:
        return 0.0
    # curve[j] is the response at (j + 1) Ts; it settles between the last sample outside the band and the next
    j = int(outside[-1])
    within = excess[j] / (excess[j] - excess[j + 1]) if j + 1 < curve.size else 0.0
    return (j + 1 + within) * element.sample_time / 3.0


def slowest_time_constant(model: TransferMatrix) -> float:
    """The largest time constant, or equivalent, of the model's elements [time unit]; 0 when none has one."""
    general = [equivalent_time_constant(e) for row in model.general for e in row if e is not None]
    return max(model.slowest_time_constant, *general, 0.0)


def row_time_constants(model: TransferMatrix, i: int) -> np.ndarray:
    """The time constants, or equivalents, of row ``i``'s FOPTD, ``tf`` and ``step_response`` elements that have one."""
    taus = []
    for k in range(model.n_inputs):
        kind = model.element_type[i, k]
        if kind == "foptd":
            taus.append(float(model.time_constant[i, k]))
        elif kind in ("tf", "step_response"):
            taus.append(equivalent_time_constant(model.element(i, k)))
    return np.array([t for t in taus if t > 0.0])
