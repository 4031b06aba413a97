"""The rolling-window plan: which samples each window of a long record covers, cut as views.

A window of ``W`` and a step of ``S`` are counted in samples, or in clock time
(``"14d"``, ``"6h"``, ``"30min"``, ``"90s"``) when the data have a time per
sample.  The last window ends at the last sample and the others step back from
it by ``S``, so the newest data are always diagnosed; the windows come out in
time order.  A window is cut from the one record as a slice (a view): a year of
data is held once, not copied per window.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Span", "parse_span", "window_plan", "window_views"]

UNITS: dict[str, float] = {"s": 1.0, "min": 60.0, "h": 3600.0, "d": 86400.0}
"""Clock units a window or step may carry, in seconds."""

_SPAN = re.compile(r"^\s*(?P<value>[-+]?[0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*(?P<unit>[a-z]*)\s*$")


@dataclass(frozen=True)
class Span:
    """A window or step length: samples, or seconds of clock time.

    Attributes
    ----------
    value : float
        The length [samples when ``seconds`` is False, else s].
    seconds : bool
        Whether the length is clock time.
    text : str
        As given (for messages).
    unit : str
        Its clock unit (a key of :data:`UNITS`), empty for samples.
    """

    value: float
    seconds: bool
    text: str
    unit: str = ""


def parse_span(value: int | float | str, *, option: str) -> Span:
    """A window or step length read from ``20160``, ``"20160"``, ``"14d"``, ``"6h"``, ``"30min"`` or ``"90s"``.

    Parameters
    ----------
    value : int, float or str
        Samples (a bare number) or clock time (a number and a unit of :data:`UNITS`).
    option : str
        The option's name for messages (``window``, ``step``).

    Returns
    -------
    Span

    Raises
    ------
    ValueError
        A length that is not a number with an optional known unit, or not positive.

    Examples
    --------
    >>> parse_span("14d", option="window").value
    1209600.0
    """
    match = _SPAN.match(str(value))
    if match is None or match["unit"] not in ("", *UNITS):
        raise ValueError(f"{option}: {value!r} is not a length (samples, or a number with a unit of {sorted(UNITS)})")
    number = float(match["value"])
    if number <= 0:
        raise ValueError(f"{option}: {value!r} must be positive")
    unit = match["unit"]
    if not unit and number != int(number):
        raise ValueError(f"{option}: {value!r} samples is not a whole number")
    return Span(number * UNITS[unit] if unit else number, bool(unit), str(value), unit)


def _clock(times: np.ndarray | Sequence[float], n_samples: int) -> np.ndarray:
    """Clock times as float seconds (datetime64 converted), checked against the number of samples."""
    array = np.asarray(times)
    if np.issubdtype(array.dtype, np.datetime64):
        array = (array - array[0]) / np.timedelta64(1, "s")
    array = np.asarray(array, dtype=float)
    if array.shape != (n_samples,):
        raise ValueError(f"times: {array.shape[0] if array.ndim else 0} stamps for {n_samples} samples")
    if np.any(np.diff(array) < 0) or not np.all(np.isfinite(array)):
        raise ValueError("times: the clock times must be finite and non-decreasing")
    return array


def _sample_plan(n_samples: int, window: Span, step: Span) -> list[tuple[int, int]]:
    """Windows counted in samples, the last one ending at the last sample."""
    length, stride = int(window.value), int(step.value)
    if length > n_samples:
        raise ValueError(f"window: {window.text} samples is longer than the data ({n_samples} samples)")
    lasts = range(n_samples - 1, length - 2, -stride)
    return [(last - length + 1, last) for last in reversed(lasts)]


def _clock_plan(times: np.ndarray, window: Span, step: Span) -> list[tuple[int, int]]:
    """Windows counted in clock time: samples stamped in ``(end - W, end]``, ends stepping back by ``S``."""
    # one sample covers one period: n samples span n periods, so a window as long as the data fits
    period = float(np.median(np.diff(times))) if times.size > 1 else 0.0
    duration = times[-1] - times[0] + period
    if window.value > duration * (1 + 1e-9):
        given = f"{duration / UNITS[window.unit]:.4g} {window.unit}"
        raise ValueError(f"window: {window.text} is longer than the data ({given})")
    ends = times[-1] - step.value * np.arange(int((duration - window.value) // step.value + 1e-9) + 1)
    ends = ends[::-1]
    lasts = np.searchsorted(times, ends, side="right") - 1
    firsts = np.searchsorted(times, ends - window.value, side="right")
    return [(int(f), int(la)) for f, la in zip(firsts, lasts, strict=True) if la >= f]


def window_plan(
    *,
    n_samples: int,
    window: int | float | str,
    step: int | float | str,
    times: np.ndarray | Sequence[float] | None = None,
) -> list[tuple[int, int]]:
    """The ``(first, last)`` sample indices (both inclusive) of every window, in time order.

    Parameters
    ----------
    n_samples : int
        Samples in the record.
    window, step : int, float or str
        Window length and the step between window ends: samples (``20160``),
        or clock time with a unit (``"14d"``, ``"1d"``, ``"6h"``, ``"30min"``,
        ``"90s"``) when ``times`` is given.
    times : array_like of float or datetime64, optional
        Clock time of each sample [s] (or date-times).  With clock time a
        window holds the samples stamped in ``(end - window, end]``; a gap in
        the record leaves fewer samples in the windows across it, and a
        window with none is left out.

    Returns
    -------
    list of (int, int)
        The last window ends at sample ``n_samples - 1``; the others step back
        by ``step``; none starts before sample 0.

    Raises
    ------
    ValueError
        One line naming the option and its value: a window longer than the
        data, a step (or window) of zero or less, a unit without clock time,
        a length that is not a number.

    Examples
    --------
    >>> window_plan(n_samples=10, window=4, step=3)
    [(0, 3), (3, 6), (6, 9)]
    """
    span, stride = parse_span(window, option="window"), parse_span(step, option="step")
    if times is None:
        for name, given in (("window", span), ("step", stride)):
            if given.seconds:
                raise ValueError(f"{name}: {given.text!r} has a clock unit but the data have no clock time")
        return _sample_plan(n_samples, span, stride)
    if span.seconds != stride.seconds:
        raise ValueError(f"step: {stride.text!r} and window {span.text!r} must both be samples or both clock time")
    if not span.seconds:
        return _sample_plan(n_samples, span, stride)
    return _clock_plan(_clock(times, n_samples), span, stride)


def window_views(data: np.ndarray, plan: Sequence[tuple[int, int]], *, axis: int = 0) -> Iterator[np.ndarray]:
    """Each window of ``data`` as a view (a basic slice along ``axis``), never a copy.

    Parameters
    ----------
    data : ndarray
        The whole record, samples along ``axis``.
    plan : sequence of (int, int)
        ``(first, last)`` inclusive sample indices, as from :func:`window_plan`.
    axis : int
        The sample axis.

    Yields
    ------
    ndarray
        ``data[..., first:last + 1, ...]``, sharing ``data``'s memory.
    """
    index: list[slice] = [slice(None)] * data.ndim
    for first, last in plan:
        index[axis] = slice(first, last + 1)
        yield data[tuple(index)]
