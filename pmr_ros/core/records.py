"""The one record of closed-loop data, :class:`Record`: setpoints r, inputs u, outputs y (+ dither, + DVs).

A simulation returns one (:func:`pmr_ros.core.sim.closed_loop.simulate`), a bag
window and a historian export give one per unbroken stretch, and every
diagnosis reads them.

A record with gaps (a historian export with bad values, a controller switched
off, a live window across a lost sample) is several unbroken stretches; the
spectra average every Welch segment that fits inside one, across all of them
(:func:`pmr_ros.core.pmr.spectra.record_spectra`).  Each stretch carries the
setpoints r, the inputs u, the outputs y and, when the controller's outputs
were dithered, the dither d.  The instruments of the PMR regression are the
external signals that move (:class:`InstrumentSet`): every setpoint that
changes (however rarely), every MV dither column that moves, and every MV
while its controller was off (``manual``) -- a measured disturbance enters as
such an MV, always in manual (:func:`pmr_ros.core.sim.augment.augmented_record`).
A constant setpoint is simply not an instrument.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "InstrumentSet",
    "Record",
    "active_dither",
    "instruments",
    "moving_columns",
    "moving_instruments",
    "total_samples",
]

STILL = 1e-12
"""A signal whose spread is below this (relative to 1 + |mean|) does not move: not an instrument."""


@dataclass(frozen=True)
class Record:
    """Evenly sampled closed-loop data without a gap, row k = sample k.

    Attributes
    ----------
    r : ndarray, shape (N, n_outputs)
        Setpoints [output unit].
    u : ndarray, shape (N, n_inputs)
        Inputs applied over sample k, dither included [input unit].
    y : ndarray, shape (N, n_outputs)
        Measured outputs at sample k [output unit].
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs (``u`` includes it);
        None when the loop had none [input unit].
    dv : ndarray, shape (N, n_disturbances), optional
        Measured disturbances (DVs), when the data carry them [their unit].
    manual : ndarray of bool, shape (N, n_inputs), optional
        True where an MV's controller was off (the operator set ``u``): the loop
        is open for that MV, and its moves are an external signal; None when
        every controller was on throughout.

    Examples
    --------
    >>> import numpy as np
    >>> Record(np.zeros((5, 2)), np.zeros((5, 2)), np.zeros((5, 2))).samples
    5
    """

    r: np.ndarray
    u: np.ndarray
    y: np.ndarray
    dither: np.ndarray | None = None
    dv: np.ndarray | None = None
    manual: np.ndarray | None = None

    @property
    def samples(self) -> int:
        """Samples in the record."""
        return int(np.shape(self.r)[0]) if np.ndim(self.r) else 0


def total_samples(stretches: Sequence[Record]) -> int:
    """Samples in all stretches together."""
    return sum(s.samples for s in stretches)


def moving_columns(columns: np.ndarray) -> np.ndarray:
    """Which columns of ``columns`` (N, p) move: spread above :data:`STILL` relative to 1 + |mean|."""
    columns = np.asarray(columns, dtype=float)
    if columns.shape[0] == 0:
        return np.zeros(columns.shape[1], dtype=bool)
    return np.asarray(columns.std(axis=0) > STILL * (1.0 + np.abs(columns.mean(axis=0))))


def active_dither(stretches: Sequence[Record]) -> np.ndarray:
    """Which dither columns move somewhere in the data (bool, shape (n_inputs,)); none without dither."""
    columns = [s.dither for s in stretches if s.dither is not None]
    if not columns:
        return np.zeros(np.shape(stretches[0].u)[1] if stretches else 0, dtype=bool)
    return moving_columns(np.vstack(columns))


def _manual_moves(stretches: Sequence[Record]) -> np.ndarray:
    """Which inputs move while their controller is off (bool, shape (n_inputs,)); none without ``manual``."""
    n_in = np.shape(stretches[0].u)[1] if stretches else 0
    moving = np.zeros(n_in, dtype=bool)
    for k in range(n_in):
        held = [
            np.asarray(s.u, dtype=float)[np.asarray(s.manual, dtype=bool)[:, k], k]
            for s in stretches
            if s.manual is not None
        ]
        values = np.concatenate(held) if held else np.empty(0)
        moving[k] = values.size > 1 and bool(moving_columns(values[:, None])[0])
    return moving


@dataclass(frozen=True)
class InstrumentSet:
    """The external signals that move in the data: the instruments of the PMR regression, in this order.

    Attributes
    ----------
    setpoints : ndarray of bool, shape (n_outputs,)
        Setpoints that change somewhere (a step a day is enough).
    dither : ndarray of bool, shape (n_inputs,)
        MV dither columns that move.
    manual : ndarray of bool, shape (n_inputs,)
        Inputs that move while their controller is off (a DV column of an
        augmented record is always off: its own instrument).
    still : ndarray of bool, shape (n_inputs,)
        Inputs that do not move at all (held, saturated, a DV that stays put):
        not instruments, and their regressors carry nothing.
    """

    setpoints: np.ndarray
    dither: np.ndarray
    manual: np.ndarray
    still: np.ndarray | None = None

    @property
    def count(self) -> int:
        """Instruments in all."""
        return int(self.setpoints.sum() + self.dither.sum() + self.manual.sum())

    @property
    def direct(self) -> np.ndarray:
        """Inputs moved by an instrument of their own (their dither, or their moves in manual), shape (n_inputs,)."""
        return np.asarray(self.dither | self.manual)

    def labels(
        self, output_names: Sequence[str], input_names: Sequence[str], *, n_disturbances: int = 0
    ) -> tuple[str, ...]:
        """Each instrument's name, in column order: ``setpoint_y1``, ``dither_u2``, ``manual_u2``, ``dv_feed``.

        The last ``n_disturbances`` inputs are measured disturbances (``dv_``).
        Dots become underscores: the names are keys of the flat result forms, whose paths are dotted.
        """
        first_dv = len(input_names) - n_disturbances
        names = [f"setpoint_{n}" for n, on in zip(output_names, self.setpoints, strict=True) if on]
        names += [f"dither_{n}" for n, on in zip(input_names, self.dither, strict=True) if on]
        names += [
            f"{'dv' if k >= first_dv else 'manual'}_{n}"
            for k, (n, on) in enumerate(zip(input_names, self.manual, strict=True))
            if on
        ]
        return tuple(name.replace(".", "_") for name in names)

    def columns(self, stretch: Record) -> np.ndarray:
        """The stretch's instruments, shape (N, :attr:`count`).

        A manual column is the input where its controller is off and 0
        elsewhere, after removing the mean of the manual samples.  While the
        loop is open for that MV the operator, not the feedback from the noise,
        sets ``u``: those moves are uncorrelated with the noise and move the
        MV's regressors, which is all an instrument must do.  Outside manual
        ``u`` carries the feedback (noise-correlated), so it is not used:
        zero there.  The manual samples' own mean is removed so that the
        column's level does not follow the mode switching itself (a step of
        the column at each switch would be an instrument of the switching,
        which the operator may time after the noise).
        """
        parts = [np.asarray(stretch.r, dtype=float)[:, self.setpoints]]
        if stretch.dither is not None and self.dither.any():
            parts.append(np.asarray(stretch.dither, dtype=float)[:, self.dither])
        elif self.dither.any():
            parts.append(np.zeros((stretch.samples, int(self.dither.sum()))))
        if self.manual.any():
            parts.append(_manual_columns(stretch, self.manual))
        return np.hstack(parts) if parts else np.zeros((stretch.samples, 0))


def _manual_columns(stretch: Record, which: np.ndarray) -> np.ndarray:
    """``u_k`` less its manual samples' mean where input k is in manual, 0 elsewhere, for the ``which`` inputs."""
    u = np.asarray(stretch.u, dtype=float)[:, which]
    if stretch.manual is None:
        return np.zeros_like(u)
    off = np.asarray(stretch.manual, dtype=bool)[:, which]
    out = np.zeros_like(u)
    for c in range(u.shape[1]):
        if off[:, c].any():
            out[off[:, c], c] = u[off[:, c], c] - u[off[:, c], c].mean()
    return out


def moving_instruments(stretches: Sequence[Record]) -> InstrumentSet:
    """The instruments of the data: the setpoints, dither columns and manual MVs that move somewhere."""
    r = np.vstack([np.asarray(s.r, dtype=float) for s in stretches]) if stretches else np.zeros((0, 0))
    u = np.vstack([np.asarray(s.u, dtype=float) for s in stretches]) if stretches else np.zeros((0, 0))
    return InstrumentSet(moving_columns(r), active_dither(stretches), _manual_moves(stretches), ~moving_columns(u))


def instruments(stretch: Record, moving: InstrumentSet) -> np.ndarray:
    """The stretch's instruments (:meth:`InstrumentSet.columns`), shape (N, n_z)."""
    return moving.columns(stretch)
