"""The system's units (``system.output_units``, ``input_units``, ``disturbance_units``, ``time_unit``) for the reports.

Every table, figure axis and JSON field that shows an absolute value names
its unit from here: a CV's and an MV's unit, a gain's (output unit per input
unit; per time unit for an integrating element) and the model's time unit.
A unit the configuration does not give is left out ("" in the JSON).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..config.schema import Shape, parameter

__all__ = ["Units", "units_of"]

NO_TIME_UNIT = "none"
"""``system.time_unit`` when the configuration does not say."""


@dataclass(frozen=True)
class Units:
    """The system's units.

    Attributes
    ----------
    outputs, inputs, disturbances : tuple of str
        One per CV, MV, DV; "" where none is given.
    time : str
        ``s``, ``min``, ``h``, or "" (not given).
    """

    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    disturbances: tuple[str, ...] = ()
    time: str = ""

    def gain(self, row: int, column: int, *, integrating: bool = False) -> str:
        """The unit of element ``(row, column)``'s gain (``degC/%``, ``degC/%/min``); "" unless both are known.

        A column past the inputs is a measured disturbance's (a D element).
        """
        source = self.inputs[column] if column < len(self.inputs) else self.disturbances[column - len(self.inputs)]
        out = self.outputs[row]
        if not out or not source:
            return ""
        return f"{_factor(out)}/{_factor(source)}" + (f"/{self.time}" if integrating and self.time else "")

    def time_text(self, value: float) -> str:
        """``1 min``, or ``1 (model time unit)`` when the time unit is not given."""
        return f"{value:g} {self.time}" if self.time else f"{value:g} (model time unit)"

    def to_json(
        self, output_names: tuple[str, ...], input_names: tuple[str, ...], disturbance_names: tuple[str, ...] = ()
    ) -> dict[str, Any]:
        """``{"time": "min", "outputs": {"x_D": "mol %"}, "inputs": {...}}`` (DVs under ``disturbances``)."""
        out: dict[str, Any] = {
            "time": self.time,
            "outputs": dict(zip(output_names, self.outputs, strict=True)),
            "inputs": dict(zip(input_names, self.inputs, strict=True)),
        }
        if disturbance_names:
            out["disturbances"] = dict(zip(disturbance_names, self.disturbances, strict=True))
        return out


def _factor(unit: str) -> str:
    """A unit as one factor of a quotient: ``(lb/min)``, ``(mol %)``; ``degC`` as it is."""
    return f"({unit})" if any(c in unit for c in "/ *") else unit


def _labels(name: str, raw: Any, *, source: str, shape: Shape, count: int) -> tuple[str, ...]:
    checked = parameter(name).check(raw, source=source, shape=shape)
    return tuple(checked) if checked else ("",) * count


def units_of(config: Any) -> Units:
    """The units of a :class:`~pmr_ros.config.PmrConfig` (its ``system`` block)."""
    system = config.parameters.get("system", {})
    model = config.model
    dvs = config.disturbance_model.input_names if config.disturbance_model is not None else ()
    shape = Shape(model.n_outputs, model.n_inputs, len(dvs))
    read = {"source": config.source, "shape": shape}
    time = str(system.get("time_unit", NO_TIME_UNIT))
    return Units(
        outputs=_labels("system.output_units", system.get("output_units", []), count=model.n_outputs, **read),
        inputs=_labels("system.input_units", system.get("input_units", []), count=model.n_inputs, **read),
        disturbances=_labels("system.disturbance_units", system.get("disturbance_units", []), count=len(dvs), **read),
        time="" if time == NO_TIME_UNIT else time,
    )
