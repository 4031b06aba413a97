"""Stretches of closed-loop data: the unit every diagnosis reads.

A record with gaps (a historian export with bad values, a controller switched
off, a live window across a lost sample) is several unbroken stretches; the
spectra average every Welch segment that fits inside one, across all of them
(:func:`pmr_ros.core.spectra.record_spectra`).  Each stretch carries the
setpoints r, the inputs u, the outputs y and, when the controller's outputs
were dithered, the dither d.  The instruments of the PMR regression are the
external excitation signals: every setpoint and every dither column that moves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Stretch", "active_dither", "instruments", "total_samples"]

STILL = 1e-12
"""A dither column whose spread is below this (relative to 1 + |mean|) does not move: not an instrument."""


@dataclass(frozen=True)
class Stretch:
    """An unbroken stretch of evenly sampled closed-loop data, row k = sample k.

    Attributes
    ----------
    r : ndarray, shape (N, n_outputs)
        Setpoints [output unit].
    u : ndarray, shape (N, n_inputs)
        Inputs applied (dither included) [input unit].
    y : ndarray, shape (N, n_outputs)
        Measured outputs [output unit].
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs, if any [input unit].
    """

    r: np.ndarray
    u: np.ndarray
    y: np.ndarray
    dither: np.ndarray | None = None

    @property
    def samples(self) -> int:
        """Samples in the stretch."""
        return int(np.shape(self.r)[0]) if np.ndim(self.r) else 0


def total_samples(stretches: Sequence[Stretch]) -> int:
    """Samples in all stretches together."""
    return sum(s.samples for s in stretches)


def active_dither(stretches: Sequence[Stretch]) -> np.ndarray:
    """Which dither columns move somewhere in the data (bool, shape (n_inputs,)); none without dither."""
    columns = [s.dither for s in stretches if s.dither is not None]
    if not columns:
        return np.zeros(np.shape(stretches[0].u)[1] if stretches else 0, dtype=bool)
    d = np.vstack(columns)
    return np.asarray(d.std(axis=0) > STILL * (1.0 + np.abs(d.mean(axis=0))))


def instruments(stretch: Stretch, active: np.ndarray) -> np.ndarray:
    """The stretch's instruments: its setpoints and its active dither columns, shape (N, n_z)."""
    if not np.any(active) or stretch.dither is None:
        return np.asarray(stretch.r, dtype=float)
    return np.hstack([np.asarray(stretch.r, dtype=float), np.asarray(stretch.dither, dtype=float)[:, active]])
