"""Can the data support a PMR estimate at all?  The checks every method runs first."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..records import InstrumentSet, Record, moving_instruments
from ..sim.model import TransferMatrix
from .spectra import WelchSettings

__all__ = [
    "MIN_SEGMENTS",
    "InsufficientData",
    "check_record",
    "check_stretches",
    "segments_needed",
    "unbroken_samples_needed",
    "welch_segments",
]

MIN_SEGMENTS = 4
"""Fewest Welch segments with which a row regression is attempted."""


class InsufficientData(ValueError):
    """The record cannot support a PMR estimate; the message says why."""


def _check_shapes(stretch: Record, model: TransferMatrix, where: str) -> None:
    n_out, n_in = model.n_outputs, model.n_inputs
    arrays = [("r", stretch.r, n_out), ("u", stretch.u, n_in), ("y", stretch.y, n_out)]
    if stretch.dither is not None:
        arrays.append(("dither", stretch.dither, n_in))
    if stretch.manual is not None:
        arrays.append(("manual", stretch.manual, n_in))
    for name, data, width in arrays:
        data = np.asarray(data)
        if data.ndim != 2 or data.shape[1] != width:
            raise InsufficientData(f"{name}{where} has shape {data.shape}, expected (samples, {width})")
        if not np.all(np.isfinite(data)):
            raise InsufficientData(f"{name}{where} holds NaN or inf samples")
        if data.shape[0] != stretch.samples:
            raise InsufficientData(
                f"r, u, y and {name}{where} have different lengths ({data.shape[0]}, not {stretch.samples})"
            )


def segments_needed(instruments: int) -> int:
    """Fewest Welch segments a diagnosis with ``instruments`` instruments accepts: ``max(4, 2 n_instruments)``.

    Each row regresses the output on the instruments bin by bin; fewer
    segments than twice the instruments leave the cross-spectral matrices
    too noisy to invert.

    Examples
    --------
    >>> segments_needed(2), segments_needed(64)
    (4, 128)
    """
    return max(MIN_SEGMENTS, 2 * int(instruments))


def welch_segments(lengths: Sequence[int], *, model: TransferMatrix, welch: WelchSettings) -> int:
    """Welch segments stretches of ``lengths`` samples give once the model's settling is dropped from each."""
    warmup = model.settling_samples()
    return sum(welch.segments(int(n) - warmup) for n in lengths)


def unbroken_samples_needed(model: TransferMatrix, welch: WelchSettings, *, instruments: int) -> int:
    """The fewest unbroken samples that pass :func:`check_stretches`: the settling, then :func:`segments_needed`.

    Parameters
    ----------
    model : TransferMatrix
        The controller's model (its settling is dropped first).
    welch : WelchSettings
    instruments : int
        Setpoints plus the inputs whose MV dither is active.
    """
    need = segments_needed(instruments)
    return model.settling_samples() + welch.segment_length + (need - 1) * welch.step


def check_stretches(
    stretches: Sequence[Record], *, model: TransferMatrix, welch: WelchSettings, moving: InstrumentSet | None = None
) -> None:
    """Raise :class:`InsufficientData` if the stretches cannot support an estimate.

    Parameters
    ----------
    stretches : sequence of Record
        Unbroken stretches of data (one for a gap-free record).
    model : TransferMatrix
        The controller's model (its settling time is dropped from each stretch).
    welch : WelchSettings
        The segments the spectra will average (those that fit inside a stretch).
    moving : InstrumentSet, optional
        The stretches' :func:`~pmr_ros.core.records.moving_instruments` when the caller has them already
        (they are computed otherwise).

    Raises
    ------
    InsufficientData
        Wrong shapes, non-finite samples, too few Welch segments in all, nothing external that moves.
    """
    if not stretches:
        raise InsufficientData("no data")
    for j, stretch in enumerate(stretches):
        _check_shapes(stretch, model, "" if len(stretches) == 1 else f" of stretch {j + 1}")
    if moving is None:
        moving = moving_instruments(stretches)
    if moving.count == 0:
        raise InsufficientData(
            "no excitation: nothing external moves in this record (every setpoint constant, no MV dither, no MV "
            "moved in manual, no measured disturbance that moves): add MV dither (excitation.mv_dither_amplitude), "
            "a setpoint change or manual moves of an MV"
        )
    warmup = model.settling_samples()
    segments = welch_segments([s.samples for s in stretches], model=model, welch=welch)
    # every instrument that moves counts (a constant setpoint is none): the instrument spectra need 2 n_z segments
    n_z = moving.count
    need = segments_needed(n_z)
    if segments < need:
        shortest = unbroken_samples_needed(model, welch, instruments=n_z)
        samples = sum(s.samples for s in stretches)
        where = "" if len(stretches) == 1 else f" in {len(stretches)} stretches"
        raise InsufficientData(
            f"window too short: {samples} samples{where}, less {warmup} of model settling each, give {segments} Welch "
            f"segments of {welch.segment_length}, need {need} ({shortest} unbroken samples)"
        )


def check_record(r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: TransferMatrix, welch: WelchSettings) -> None:
    """:func:`check_stretches` of one gap-free record ``r, u, y``.

    Raises
    ------
    InsufficientData
        As :func:`check_stretches`.
    """
    check_stretches([Record(np.asarray(r), np.asarray(u), np.asarray(y))], model=model, welch=welch)
