"""A model as step-response curves, the common form of the model files (DMCplus ``.mdl``, CSV)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["CurveSet", "ModelFileError", "curve_gains"]


class ModelFileError(ValueError):
    """A model file that cannot be read or written: one line naming the file (and line) and why."""


@dataclass(frozen=True, eq=False)
class CurveSet:
    """Step-response curves of every output-input pair, at one sample time.

    Attributes
    ----------
    sample_time : float
        Ts [time unit of the file: minutes for DMCplus].
    output_names, input_names : tuple of str
        Dependents (CVs) and independents (MVs, feedforwards), in order.
    curves : ndarray, shape (n_outputs, n_inputs, N)
        ``s_1 .. s_N`` per pair [output unit / input unit]; all zeros: no model.
    ramp : ndarray of bool, shape (n_outputs, n_inputs)
        Ramp (integrating) flag per pair; a DMCplus file has one per output.
    gains : ndarray, shape (n_outputs, n_inputs)
        Steady-state gain as the file states it (a ramp's rate per time unit).
    output_units, input_units : tuple of str
        Engineering units ('' when the file has none); empty: none at all.
    comment : str
        The file's comment line.
    extras : object
        What a file format holds beyond the model (:class:`pmr_ros.models.mdl.MdlExtras`),
        carried so that writing the file again loses nothing; None: defaults.
    """

    sample_time: float
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    curves: np.ndarray
    ramp: np.ndarray
    gains: np.ndarray
    output_units: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    comment: str = ""
    extras: Any = field(default=None)

    @property
    def n_coefficients(self) -> int:
        """N, the coefficients per curve."""
        return int(self.curves.shape[2])

    @property
    def time_to_steady_state(self) -> float:
        """``N Ts`` [time unit]."""
        return self.n_coefficients * self.sample_time

    def units(self, names: tuple[str, ...], of: str) -> tuple[str, ...]:
        """The units of ``of`` (``outputs`` or ``inputs``), '' for each name when the file had none."""
        given = self.output_units if of == "outputs" else self.input_units
        return given if given else ("",) * len(names)

    def same_as(self, other: CurveSet) -> bool:
        """Whether both hold exactly the same model, names, units and comment (extras aside)."""
        return (
            self.sample_time == other.sample_time
            and self.output_names == other.output_names
            and self.input_names == other.input_names
            and self.curves.shape == other.curves.shape
            and bool(np.array_equal(self.curves, other.curves))
            and bool(np.array_equal(self.ramp, other.ramp))
            and bool(np.array_equal(self.gains, other.gains))
            and self.units(self.output_names, "outputs") == other.units(other.output_names, "outputs")
            and self.units(self.input_names, "inputs") == other.units(other.input_names, "inputs")
            and self.comment == other.comment
        )


def curve_gains(curves: np.ndarray, ramp: np.ndarray, sample_time: float) -> np.ndarray:
    """Gains from the curves: the last coefficient, or a ramp's last slope per time unit."""
    last = curves[..., -1]
    before = curves[..., -2] if curves.shape[-1] > 1 else np.zeros_like(last)
    return np.where(ramp, (last - before) / sample_time, last)
