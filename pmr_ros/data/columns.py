"""Which columns of a historian export are r, u, y (and dither, DVs, modes): the ``data`` block or the default naming.

A CV without a setpoint column (a zone CV) has the name ``""`` among the
setpoint columns: nothing is read for it.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..config import DataSettings
from ..config.data import ZONE
from ..core.sim.model import TransferMatrix
from .bad_data import DataError

__all__ = ["SIGNAL_PARAMETERS", "ColumnMap", "column_map"]

SIGNAL_PARAMETERS = {
    "r": "data.setpoint_columns",
    "u": "data.input_columns",
    "y": "data.output_columns",
    "dither": "data.dither_columns",
    "dv": "data.disturbance_columns",
}
"""The parameter that names each signal's columns."""


@dataclass(frozen=True)
class ColumnMap:
    """The columns of each signal, in channel order.

    Attributes
    ----------
    time : str
        The time-stamp column.
    signals : dict
        ``r``, ``u``, ``y`` (and ``dither``, ``dv`` when logged) to their columns;
        ``""`` for a CV without a setpoint column.
    modes : tuple of str
        The controller-mode columns: one per MV, one for all, or none.
    modes_parameter : str
        The parameter that named them (``data.mode_columns`` or ``data.mode_column``).
    """

    time: str
    signals: dict[str, tuple[str, ...]]
    modes: tuple[str, ...] = ()
    modes_parameter: str = "data.mode_columns"

    @property
    def mode(self) -> str:
        """The mode columns in words (``""`` when there is none)."""
        return ", ".join(self.modes)

    @property
    def value_columns(self) -> list[str]:
        """Every signal column read, r then u then y then dither then DVs."""
        return [c for columns in self.signals.values() for c in columns if c]

    @property
    def all(self) -> list[str]:
        """Every column read: time, signals, modes."""
        return [self.time, *self.value_columns, *self.modes]

    def origin(self, column: str) -> str:
        """How the configuration names ``column`` (for messages)."""
        if column == self.time:
            return "data.time_column"
        if column in self.modes:
            one = len(self.modes) == 1 and self.modes_parameter == "data.mode_column"
            return self.modes_parameter if one else f"{self.modes_parameter}[{self.modes.index(column)}]"
        for signal, columns in self.signals.items():
            if column in columns:
                return f"{SIGNAL_PARAMETERS[signal]}[{columns.index(column)}]"
        return "data"

    def check(self, available: Sequence[str], path: str | Path) -> None:
        """Raise :class:`DataError` for the first wanted column the file lacks (with the nearest one it has).

        Raises
        ------
        DataError
            A column is missing or named twice.
        """
        seen: set[str] = set()
        for column in self.all:
            if column in seen:
                raise DataError(
                    path, f"column {column!r}", f"is named twice in the configuration ({self.origin(column)})"
                )
            seen.add(column)
            if column not in available:
                near = difflib.get_close_matches(column, list(available), n=1, cutoff=0.6)
                hint = f"; did you mean {near[0]!r}?" if near else f"; the file has {_listing(available)}"
                raise DataError(path, f"column {column!r} ({self.origin(column)})", f"not in the file{hint}")


def _listing(columns: Sequence[str], shown: int = 8) -> str:
    names = ", ".join(repr(c) for c in list(columns)[:shown])
    return names + (f" and {len(columns) - shown} more" if len(columns) > shown else "")


def column_map(settings: DataSettings, model: TransferMatrix, *, output_modes: Sequence[str] = ()) -> ColumnMap:
    """The columns of r, u, y, dither, DVs and modes: those the ``data`` block names, else ``r_<output>`` etc.

    Parameters
    ----------
    settings : DataSettings
    model : TransferMatrix
        The controller's model (its channel names give the default naming).
    output_modes : sequence of str, optional
        Each CV's ``mpc.output_mode``; a ``zone`` CV has no setpoint column by default.
    """
    zone = [i < len(output_modes) and output_modes[i] == ZONE for i in range(len(model.output_names))]
    signals = {
        "r": settings.setpoint_columns
        or tuple("" if zone[i] else f"r_{name}" for i, name in enumerate(model.output_names)),
        "u": settings.input_columns or tuple(f"u_{name}" for name in model.input_names),
        "y": settings.output_columns or tuple(f"y_{name}" for name in model.output_names),
    }
    if settings.dither_columns:
        signals["dither"] = settings.dither_columns
    if settings.disturbance_columns:
        signals["dv"] = settings.disturbance_columns
    return ColumnMap(settings.time_column, signals, settings.modes, settings.modes_parameter)
