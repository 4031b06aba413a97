"""The controllers' modes on the sample grid: which MV was in manual, which samples had no controller on.

A mode column is one per MV or one for all (``data.mode_columns``, or the
older ``data.mode_column``).  While an MV's controller is off the operator
sets it: the sample is kept, with the MV marked manual (the loop is open for
it, :attr:`pmr_ros.core.records.Record.manual`).  A sample whose controllers
were all off, or whose mode is unknown (a missing cell, one of
``data.bad_values``), is excluded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..config import DataSettings
from .bad_data import DataError
from .clean import CleaningStep, mode_known, mode_on, runs
from .columns import ColumnMap
from .read import RawTable
from .timebase import Grid

__all__ = ["ControllerModes", "controller_modes", "mode_steps"]


@dataclass(frozen=True)
class ControllerModes:
    """The modes on the sample grid.

    Attributes
    ----------
    manual : ndarray of bool, shape (samples, n_inputs)
        The MV's controller was off (its mode known).
    all_off : ndarray of bool, shape (samples,)
        Every MV's controller was off: excluded.
    unknown : ndarray of bool, shape (samples,)
        A row's mode cell is missing or a bad value: excluded.
    """

    manual: np.ndarray
    all_off: np.ndarray
    unknown: np.ndarray


def controller_modes(
    raw: RawTable, grid: Grid, settings: DataSettings, *, columns: ColumnMap, n_inputs: int
) -> ControllerModes:
    """The modes of the rows placed on the grid (all on without a mode column).

    Parameters
    ----------
    raw : RawTable
        With ``mode`` of shape (rows, 1 or n_inputs).
    grid : Grid
        Where each row lies on the sample grid.
    settings : DataSettings
        ``mode_on_values`` and ``bad_values``.
    columns : ColumnMap
        The mode columns' names (for the message).
    n_inputs : int

    Raises
    ------
    DataError
        No row has a controller on, naming the mode column(s) and what they hold.
    """
    manual = np.zeros((grid.samples, n_inputs), dtype=bool)
    unknown = np.zeros(grid.samples, dtype=bool)
    if raw.mode is None:
        return ControllerModes(manual, np.zeros(grid.samples, dtype=bool), unknown)
    cells = np.asarray(raw.mode[grid.rows], dtype=object).reshape(len(grid.rows), -1)
    on = np.column_stack([mode_on(c, settings.mode_on_values) for c in cells.T])
    known = np.column_stack([mode_known(c, settings.bad_values) for c in cells.T])
    per_mv = np.arange(n_inputs) if cells.shape[1] == n_inputs else np.zeros(n_inputs, dtype=int)
    row_unknown = ~np.asarray(known.all(axis=1), dtype=bool)
    if not (on & known).any():
        _never_on(cells, columns, settings.mode_on_values, raw.path)
    unknown[grid.index] = row_unknown
    manual[grid.index] = (~on[:, per_mv]) & ~row_unknown[:, None]
    return ControllerModes(manual, np.asarray(manual.all(axis=1), dtype=bool), unknown)


def _never_on(cells: np.ndarray, columns: ColumnMap, on_values: Sequence[float | str], path: str) -> None:
    seen = sorted({str(v) for v in cells[:10000].ravel()})
    shown = ", ".join(repr(v) for v in seen[:5]) + (", ..." if len(seen) > 5 else "")
    names = ", ".join(repr(c) for c in columns.modes)
    where = (
        f"column {names} ({columns.origin(columns.modes[0])})"
        if len(columns.modes) == 1
        else (f"columns {names} ({columns.modes_parameter})")
    )
    raise DataError(
        path,
        where,
        f"no row has one of data.mode_on_values ({', '.join(str(v) for v in on_values)}), so no sample is "
        f"usable; the column holds {shown}: add its on-value to data.mode_on_values",
    )


def mode_steps(modes: ControllerModes, mv_columns: Sequence[str]) -> tuple[CleaningStep, ...]:
    """The cleaning summary's lines of the modes: every controller off, MVs in manual (kept), mode unknown."""
    off_runs = runs(modes.all_off)
    kept = modes.manual & ~modes.all_off[:, None]
    return (
        CleaningStep(
            "controller off -> excluded",
            int(modes.all_off.sum()),
            "samples",
            f"{len(off_runs)} period(s)" if off_runs else "",
        ),
        CleaningStep(
            "MV in manual (its controller off) -> kept, open loop for it",
            int(kept.any(axis=1).sum()),
            "samples",
            ", ".join(f"{c} {int(n)}" for c, n in zip(mv_columns, kept.sum(axis=0), strict=True) if n),
        ),
        CleaningStep("mode unknown (missing, a bad value) -> excluded", int(modes.unknown.sum()), "samples"),
    )
