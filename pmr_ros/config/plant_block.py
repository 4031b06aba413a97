"""The ``plant`` block's fields beyond its elements: its declared defaults, and the system's fields it may repeat.

The block has the same fields as ``system``.  Its element type defaults to
``foptd`` as declared; its sample time and channel names, when given, must be
the system's (the plant is simulated on the model's channels at the model's
sample time), so a copy of a ``system`` block is a valid ``plant`` block.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..core.sim.model import TransferMatrix
from .errors import ConfigError
from .schema import parameter

__all__ = ["plant_block"]

SHARED = ("sample_time", "output_names", "input_names", "disturbance_names")
"""Fields the plant block may repeat from the system block, equal to it."""


def plant_block(
    block: dict[str, Any],
    model: TransferMatrix,
    *,
    error: Callable[[str, Any, str], ConfigError],
    disturbance_names: tuple[str, ...] = (),
) -> None:
    """Lay the block's declared defaults under it and check its repeated system fields, in place.

    Parameters
    ----------
    block : dict
        The ``plant`` block as given (changed: defaults added).
    model : TransferMatrix
        The system's model.
    error : callable
        ``error(name, value, reason)`` -> the :class:`ConfigError` to raise.
    disturbance_names : tuple of str
        The system's DVs, when the block's DV elements are read (their defaults laid under them too).

    Raises
    ------
    ConfigError
        A repeated field that differs from the system's.
    """
    keys: tuple[str, ...] = ("name", "element_type", "numerator", "denominator", "model_file")
    if disturbance_names:
        keys += (
            "disturbance_time_constant",
            "disturbance_delay",
            "disturbance_element_type",
            "disturbance_numerator",
            "disturbance_denominator",
        )
    for key in keys:
        block.setdefault(key, parameter(f"plant.{key}").default)
    system: dict[str, Any] = {
        "sample_time": model.sample_time,
        "output_names": model.output_names,
        "input_names": model.input_names,
        "disturbance_names": disturbance_names,
    }
    for key in SHARED:
        if key not in block:
            continue
        given = block[key]
        if key == "sample_time":
            same = _number(given) == float(system[key])
        else:
            same = isinstance(given, list | tuple) and list(given) == list(system[key])
        if not same:
            raise error(
                f"plant.{key}",
                given,
                f"must be system.{key} ({system[key]!r}): the plant is simulated on the model's channels at its "
                "sample time",
            )


def _number(value: Any) -> float | None:
    try:
        return float(value)
    except (TypeError, ValueError):
        return None
