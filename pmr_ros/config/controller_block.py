"""The ``controller`` block read from a parameter tree: what runs the plant, and the PI loops of kind ``pi``.

:func:`pmr_ros.config.build.parse_config` calls :func:`controller_settings`
with its checked access to the tree; :func:`foreign_controller` gives the
controller of data that did not come from this tool's node set.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.loop.pi_loops import ControllerSettings, PiLoop, PiTuning
from ..core.sim.model import TransferMatrix
from .routine import _Values

if TYPE_CHECKING:
    from .pmr_config import PmrConfig

__all__ = ["FOREIGN", "controller_given", "controller_settings", "foreign_controller"]

FOREIGN = (
    "control impact not computed: the data did not come from pmr-ros's node set and the configuration has no "
    "controller block (controller.kind pi with the loops' tuning, or mpc, simulates the plant's controller)"
)
"""Why a historian export or another controller's bag gets no control impact by default."""

REQUIRED_PI = ("controller.gain", "controller.integral_time")


def _pairing(v: _Values, outputs: tuple[str, ...], inputs: tuple[str, ...]) -> list[int | None]:
    """Per CV: the index of the MV that controls it, None for a CV without a loop."""
    names = v["controller.pairing"]
    if not names:
        if len(outputs) != len(inputs):
            raise v.error(
                "controller.pairing", [], f"must name the MV of each CV: the system is {len(outputs)}x{len(inputs)}"
            )
        return list(range(len(outputs)))
    pairs: list[int | None] = []
    for name in names:
        if name and name not in inputs:
            raise v.error("controller.pairing", list(names), f"{name!r} is not an input (MV) name: {list(inputs)}")
        pairs.append(inputs.index(name) if name else None)
    if all(k is None for k in pairs):  # (a name twice the columns check refuses)
        raise v.error("controller.pairing", list(names), "pairs no CV with an MV")
    return pairs


def _pi_tuning(v: _Values, given: Mapping[str, Any], outputs: tuple[str, ...], inputs: tuple[str, ...]) -> PiTuning:
    missing = [name for name in REQUIRED_PI if name.split(".", 1)[1] not in given]
    if missing:
        raise v.error(missing[0], None, "missing: controller.kind pi needs Kc and Ti of every loop")
    pairs = _pairing(v, outputs, inputs)
    gain, ti, td = v["controller.gain"], v["controller.integral_time"], v["controller.derivative_time"]
    loops = []
    for i, k in enumerate(pairs):
        if k is None:
            continue
        if ti[i] <= 0:
            raise v.error(f"controller.integral_time[{i}]", float(ti[i]), f"must be > 0 ({outputs[i]}'s loop)")
        loops.append(PiLoop(i, k, float(gain[i]), float(ti[i]), float(td[i])))
    u_min, u_max = v["controller.u_min"], v["controller.u_max"]
    if np.any(u_min >= u_max):
        raise v.error("controller.u_min", u_min.tolist(), "must be below controller.u_max")
    return PiTuning(tuple(loops), u_min, u_max)


def controller_settings(v: _Values, given: Mapping[str, Any], model: TransferMatrix) -> ControllerSettings:
    """The ``controller`` block's settings; ``given`` is the block as the file gave it, ``model`` names the channels.

    Raises
    ------
    ConfigError
        Kind ``pi`` without ``gain`` or ``integral_time``, a ``Ti`` <= 0, a
        pairing naming an unknown or repeated MV, ``u_min`` not below ``u_max``.
    """
    kind = v["controller.kind"]
    if kind != "pi":
        return ControllerSettings(kind)
    return ControllerSettings(kind, _pi_tuning(v, given, model.output_names, model.input_names))


def controller_given(config: PmrConfig) -> bool:
    """Whether the configuration's file gives a ``controller`` block (any of its parameters)."""
    return any(name.startswith("controller.") for name in config.given)


def foreign_controller(config: PmrConfig) -> PmrConfig:
    """``config`` for data not from this tool's node set: kind ``external`` unless the file gives a controller."""
    if controller_given(config):
        return config
    return replace(config, controller=ControllerSettings("external", why_external=FOREIGN))
