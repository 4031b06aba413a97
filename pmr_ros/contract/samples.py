"""One signal message against the sample grid and the configured channels: its sample index, or why it is unusable.

Sample k has the stamp k * Ts, so a stamp's index is ``round(stamp / Ts)``;
a message is unusable with the wrong number of values, other channel names
or a non-finite value.  Shared by the aligner (:mod:`pmr_ros.contract.alignment`)
and the nodes that read one signal each.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["GRID_TOLERANCE", "AddResult", "check_signal", "sample_index", "signal_problem"]

GRID_TOLERANCE = 0.25
"""Largest distance of a stamp from the sample grid [samples] still accepted."""


def sample_index(stamp_s: float, sample_time_s: float) -> tuple[int, float]:
    """The sample index of a stamp and its distance from the grid.

    Parameters
    ----------
    stamp_s : float
        Stamp [s].
    sample_time_s : float
        Ts [s].

    Returns
    -------
    index : int
        ``round(stamp / Ts)``.
    offset : float
        ``stamp / Ts - index`` [samples], in [-0.5, 0.5].
    """
    position = stamp_s / sample_time_s
    index = int(round(position))
    return index, position - index


WRONG_WIDTH, WRONG_NAMES, NON_FINITE = "wrong number of values", "wrong channel names", "non-finite value"
BAD_STAMP, OFF_GRID, DUPLICATED, OUT_OF_ORDER = "non-finite stamp", "stamp off the grid", "duplicated", "out-of-order"
"""Kinds of rejected messages (:attr:`AddResult.rejected_as`)."""


def signal_problem(
    label: str, names: Sequence[str], values: Sequence[float] | np.ndarray, expected_names: Sequence[str]
) -> tuple[str, str] | None:
    """Why a signal message is unusable, as ``(kind, text)``, or None if it is fine.

    ``names`` may be empty (then values are taken in the configured order);
    otherwise they must equal ``expected_names``.
    """
    width = len(expected_names)
    if len(values) != width:
        return WRONG_WIDTH, (
            f"{label}: {len(values)} values {np.asarray(values, dtype=float).tolist()!r}, expected {width} "
            f"({', '.join(expected_names)}); message dropped"
        )
    if len(names) and tuple(names) != tuple(expected_names):
        return WRONG_NAMES, (
            f"{label}: channel names {list(names)!r} differ from the configured {list(expected_names)!r}; message "
            "dropped"
        )
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        bad = [f"{n}={v}" for n, v in zip(expected_names, array.tolist(), strict=True) if not np.isfinite(v)]
        return NON_FINITE, f"{label}: non-finite value {', '.join(bad)}; message dropped"
    return None


def check_signal(
    label: str, names: Sequence[str], values: Sequence[float] | np.ndarray, expected_names: Sequence[str]
) -> str | None:
    """Why a signal message is unusable (the text of :func:`signal_problem`), or None if it is fine."""
    problem = signal_problem(label, names, values, expected_names)
    return None if problem is None else problem[1]


@dataclass
class AddResult:
    """What adding one message did.

    Attributes
    ----------
    accepted : bool
    warnings : list of str
        Human-readable reasons (rejections, gaps, new stretches).
    completed : list of int
        Sample indices that became complete.
    rejected_as : str
        For a rejected message, the kind of problem (``non-finite value``,
        ``duplicated``, ...: the module's constants); else "".
    """

    accepted: bool
    warnings: list[str] = field(default_factory=list)
    completed: list[int] = field(default_factory=list)
    rejected_as: str = ""
