"""One model element from the fields of a ``system`` block: the element type and what that type needs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .lti import Element, ElementError, Empty, Foptd, Integrating
from .rational import transfer_function
from .step_curve import StepResponse

__all__ = ["ELEMENT_KINDS", "build_element", "cell_element"]

ELEMENT_KINDS = ("foptd", "integrating", "none", "tf", "step_response")
"""Every element type (``system.element_type``)."""


def build_element(
    kind: str,
    *,
    name: str,
    sample_time: float,
    delay_samples: int,
    gain: float = 0.0,
    time_constant: float = 0.0,
    tf: tuple[str, str] = ("", ""),
    curve: tuple[Sequence[float], bool] | None = None,
) -> Element:
    """The element ``name`` of type ``kind``.

    Parameters
    ----------
    kind : str
        One of :data:`ELEMENT_KINDS`.
    name : str
        ``G21``, for messages.
    sample_time : float
        Ts [time unit].
    delay_samples : int
        Dead time [samples] (for ``step_response``: the curve's, its first
        coefficients must be 0).
    gain, time_constant : float
        K and tau of ``foptd``; K of ``integrating``; for ``step_response``
        the gain the model file states (ignored when 0).
    tf : (str, str)
        Numerator and denominator strings of a ``tf`` element.
    curve : (sequence of float, bool), optional
        The step-response curve ``s_1 .. s_N`` and its ramp flag.

    Returns
    -------
    Element

    Raises
    ------
    ElementError
        One line naming the element: unknown type, bad numbers, a ``tf`` that
        does not parse or is improper or unstable, a missing or short curve.
    """
    if kind == "foptd":
        if not time_constant > 0:
            raise ElementError(f"{name}: time constant {time_constant!r} must be > 0 for a foptd element")
        return Foptd(gain, time_constant, delay_samples, sample_time)
    if kind == "integrating":
        return Integrating(gain, delay_samples, sample_time)
    if kind == "none":
        return Empty(sample_time)
    if kind == "tf":
        return transfer_function(tf[0], tf[1], delay_samples=delay_samples, sample_time=sample_time, name=name)
    if kind == "step_response":
        if curve is None:
            raise ElementError(f"{name}: a step_response element needs its curve (system.model_file)")
        stated = float(gain) if gain else None
        return StepResponse(tuple(curve[0]), delay_samples, sample_time, ramp=curve[1], stated_gain=stated, name=name)
    raise ElementError(f"{name}: element type {kind!r} is not one of {', '.join(ELEMENT_KINDS)}")


def cell_element(
    fields: Mapping[str, Any], i: int, k: int, *, name: str, curve: tuple[Sequence[float], bool] | None = None
) -> Element:
    """:func:`build_element` of cell (i, k) of a block's row-major field matrices.

    Parameters
    ----------
    fields : mapping
        ``element_type``, ``gain``, ``time_constant``, ``delay`` [time unit],
        ``numerator`` and ``denominator`` (arrays of shape (n_outputs, n_inputs))
        and ``sample_time`` [time unit], as a ``system`` or ``plant`` block gives them.
    i, k : int
        Row and column, from 0.
    name : str
        The element's label, for messages.
    curve : (sequence of float, bool), optional
        The cell's step-response curve and ramp flag (``step_response`` cells).

    Returns
    -------
    Element

    Raises
    ------
    ElementError
        As :func:`build_element`.
    """
    ts = float(fields["sample_time"])
    return build_element(
        str(fields["element_type"][i, k]),
        name=name,
        sample_time=ts,
        delay_samples=int(round(float(fields["delay"][i, k]) / ts)),
        gain=float(fields["gain"][i, k]),
        time_constant=float(fields["time_constant"][i, k]),
        tf=(str(fields["numerator"][i, k]), str(fields["denominator"][i, k])),
        curve=curve,
    )
