"""Can a record support a PMR estimate at all?  The checks every method runs first."""

from __future__ import annotations

import numpy as np

from .foptd import FoptdMatrix
from .spectra import WelchSettings

__all__ = ["MIN_SEGMENTS", "InsufficientData", "check_record"]

MIN_SEGMENTS = 4
"""Fewest Welch segments with which a row regression is attempted."""


class InsufficientData(ValueError):
    """The record cannot support a PMR estimate; the message says why."""


def check_record(r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, welch: WelchSettings) -> None:
    """Raise :class:`InsufficientData` if the record cannot support an estimate.

    Parameters
    ----------
    r, u, y : ndarray, shape (N, n_outputs), (N, n_inputs), (N, n_outputs)
        Setpoints, inputs and measured outputs, one row per sample.
    model : FoptdMatrix
        The controller's model (its settling time is dropped before the spectra).
    welch : WelchSettings
        The segments the spectra will average.

    Raises
    ------
    InsufficientData
        Wrong shapes, non-finite samples, too few Welch segments, a constant setpoint.
    """
    n_out, n_in = model.n_outputs, model.n_inputs
    for name, data, width in (("r", r, n_out), ("u", u, n_in), ("y", y, n_out)):
        if data.ndim != 2 or data.shape[1] != width:
            raise InsufficientData(f"{name} has shape {data.shape}, expected (samples, {width})")
        if not np.all(np.isfinite(data)):
            raise InsufficientData(f"{name} holds NaN or inf samples")
    samples = r.shape[0]
    if u.shape[0] != samples or y.shape[0] != samples:
        raise InsufficientData("r, u and y have different lengths")
    warmup = model.settling_samples()
    segments = welch.segments(samples - warmup)
    need = max(MIN_SEGMENTS, 2 * n_out)
    if segments < need:
        shortest = warmup + welch.segment_length + (need - 1) * welch.step
        raise InsufficientData(
            f"window too short: {samples} samples less {warmup} of model settling give {segments} Welch segments of "
            f"{welch.segment_length}, need {need} ({shortest} samples)"
        )
    spread = r.std(axis=0)
    for j, s in enumerate(spread):
        if s <= 1e-9 * (1.0 + abs(r[:, j].mean())):
            raise InsufficientData(f"no excitation: setpoint r{j + 1} ({model.output_names[j]}) is constant")
