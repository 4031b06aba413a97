"""Which regressors a row's data can carry (:func:`row_layout`), and in words what is missing when too few.

Every input when there are at least as many instruments as inputs; else only
the modeled elements (the empty cells then cannot be tested for an unmodeled
interaction); else none -- the row is not identifiable, and the reason says
which inputs nothing external moves and what to add (dither on them, or a
change of a constant setpoint).  An input that does not move at all is left
out of its rows with its own reason.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..records import InstrumentSet
from ..sim.model import TransferMatrix

__all__ = ["RowLayout", "input_label", "row_layout"]


@dataclass(frozen=True)
class RowLayout:
    """Which inputs enter one output row's regression, and what the data cannot tell.

    Attributes
    ----------
    row : int
        Output row i.
    columns : ndarray of int
        Inputs whose regressors enter the regression, in input order.
    reasons : tuple of str
        Why the row cannot be diagnosed at all (then ``columns`` is empty).
    untested : str
        Why the row's empty cells outside ``columns`` cannot be tested ('' when all are).
    still : tuple of (int, str)
        Inputs left out because they do not move at all in the data, each with its elements' reason.
    """

    row: int
    columns: np.ndarray
    reasons: tuple[str, ...] = ()
    untested: str = ""
    still: tuple[tuple[int, str], ...] = ()

    def missing(self, k: int) -> str | None:
        """The reason input ``k`` is left out because it does not move, or None."""
        return dict(self.still).get(k)


def input_label(model: TransferMatrix, k: int) -> str:
    """``u2 (reflux)`` for an MV, ``the measured disturbance feed_rate`` for a DV column of an augmented model."""
    name = model.input_names[k]
    first_dv = model.n_inputs - model.n_disturbances
    if k >= first_dv:
        return f"the measured disturbance {name}"
    return name if name == f"u{k + 1}" else f"u{k + 1} ({name})"


def _missing_excitation(model: TransferMatrix, candidates: np.ndarray, dithered: np.ndarray, need: int) -> str:
    """``add MV dither (excitation.mv_dither_amplitude) on at least 2 of u2, u4, u5``."""
    free = [model.input_names[k] for k in candidates if not dithered[k]]
    where = (
        ", ".join(free) if 0 < len(free) <= need else f"at least {need} of {', '.join(free)}" if free else "more inputs"
    )
    return f"add MV dither (excitation.mv_dither_amplitude) on {where}"


def _setpoint_to_move(model: TransferMatrix, i: int, moving: InstrumentSet) -> str | None:
    """The constant setpoint whose change would add an instrument: row ``i``'s own, else the first; None if all move."""
    constant = [j for j in range(model.n_outputs) if not moving.setpoints[j]]
    if not constant:
        return None
    j = i if i in constant else constant[0]
    name = model.output_names[j]
    return name if name == f"y{j + 1}" else f"y{j + 1} ({name})"


def _unmoved(model: TransferMatrix, i: int, candidates: np.ndarray, moving: InstrumentSet, need: int) -> str:
    """What moves too few of row ``i``'s ``candidates`` apart, and what to add: ``nothing external moves u2 ...``."""
    free = [k for k in candidates if not moving.direct[k]]
    labels = ", ".join(input_label(model, k) for k in free)
    shared = int(moving.setpoints.sum())
    if shared == 0:
        head = f"nothing external moves {labels} in this record"
    else:
        head = f"nothing external moves {labels} apart from the {shared} moving setpoint{'s' if shared > 1 else ''}"
    add = _missing_excitation(model, candidates, moving.direct, need)
    setpoint = _setpoint_to_move(model, i, moving)
    return f"{head}: {add}" + (f" or a setpoint change on {setpoint}" if setpoint else "")


def _still_reason(model: TransferMatrix, k: int) -> str:
    """Why the elements of an input that never moves cannot be judged."""
    if k >= model.n_inputs - model.n_disturbances:
        return f"{input_label(model, k)} does not move in this record: its elements cannot be judged until it does"
    return (
        f"{input_label(model, k)} does not move at all in this record (held, saturated or out of service): "
        f"add MV dither on {model.input_names[k]} or move it in manual"
    )


def row_layout(
    model: TransferMatrix,
    i: int,
    *,
    n_instruments: int,
    dithered: np.ndarray,
    test_empty: bool = True,
    moving: InstrumentSet | None = None,
    still: np.ndarray | None = None,
) -> RowLayout:
    """The regressors row ``i`` can carry with ``n_instruments`` instruments.

    Parameters
    ----------
    model : TransferMatrix
    i : int
        Output row.
    n_instruments : int
        The instruments that move (setpoints, dither columns, manual MVs).
    dithered : ndarray of bool, shape (n_in,)
        Inputs whose dither is an instrument.
    test_empty : bool
        Whether the empty cells are to be tested (given regressors) when the instruments allow.
    moving : InstrumentSet, optional
        Which instruments move: the reasons then say which inputs nothing external moves.
    still : ndarray of bool, shape (n_in,), optional
        Inputs that do not move at all (default ``moving.still``): left out of
        the row, their elements inconclusive with the reason.
    """
    n_in = model.n_inputs
    if still is None and moving is not None and moving.still is not None:
        still = moving.still
    idle = np.zeros(n_in, dtype=bool) if still is None else np.asarray(still, dtype=bool)
    present = np.flatnonzero(model.present[i] & ~idle)
    gone = tuple((int(k), _still_reason(model, int(k))) for k in np.flatnonzero(idle))
    name = model.output_names[i]
    count = f"{n_instruments} instrument{'s' if n_instruments != 1 else ''}"
    everything = np.flatnonzero(~idle)
    if n_instruments >= everything.size and test_empty:
        return RowLayout(i, everything, still=gone)
    if n_instruments >= present.size:
        untested = f"not tested: row {name} has {count} for {everything.size} inputs; " + _missing_excitation(
            model, everything, dithered, everything.size - n_instruments
        )
        return RowLayout(i, present, untested=untested, still=gone)
    need = present.size - n_instruments
    tail = (
        _missing_excitation(model, present, dithered, need)
        if moving is None
        else _unmoved(model, i, present, moving, need)
    )
    reason = f"row {name} not identifiable: {present.size} modeled inputs but {count}; " + tail
    return RowLayout(i, np.empty(0, dtype=int), reasons=(reason,), still=gone)
