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
external excitation signals: every setpoint and every dither column that moves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Record", "active_dither", "instruments", "total_samples"]

STILL = 1e-12
"""A dither column whose spread is below this (relative to 1 + |mean|) does not move: not an instrument."""


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


def active_dither(stretches: Sequence[Record]) -> np.ndarray:
    """Which dither columns move somewhere in the data (bool, shape (n_inputs,)); none without dither."""
    columns = [s.dither for s in stretches if s.dither is not None]
    if not columns:
        return np.zeros(np.shape(stretches[0].u)[1] if stretches else 0, dtype=bool)
    d = np.vstack(columns)
    return np.asarray(d.std(axis=0) > STILL * (1.0 + np.abs(d.mean(axis=0))))


def instruments(stretch: Record, active: np.ndarray) -> np.ndarray:
    """The stretch's instruments: its setpoints and its active dither columns, shape (N, n_z)."""
    if not np.any(active) or stretch.dither is None:
        return np.asarray(stretch.r, dtype=float)
    return np.hstack([np.asarray(stretch.r, dtype=float), np.asarray(stretch.dither, dtype=float)[:, active]])
