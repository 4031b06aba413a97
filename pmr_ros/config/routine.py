"""The settings of routine operation read from a parameter tree: DV names and signals, CV zones, manual stretches.

:func:`pmr_ros.config.build.parse_config` calls these with its checked access
to the tree; each bad value is one :class:`~pmr_ros.config.errors.ConfigError`
line naming the field and the value.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from ..core.sim.model import Mismatch, TransferMatrix
from ..core.sim.operation import DisturbanceSignalSettings, ManualSettings
from .errors import ConfigError
from .schema import parameter

__all__ = [
    "disturbance_mismatch",
    "disturbance_names",
    "disturbance_signal",
    "flat_stretches",
    "manual_settings",
    "zone_settings",
]


class _Values(Protocol):
    """The checked access to the effective tree that the config reader gives (``pmr_ros.config.build``)."""

    tree: dict[str, dict[str, Any]]

    def __getitem__(self, name: str) -> Any: ...

    def error(self, name: str, value: Any, reason: str) -> ConfigError: ...


DISTURBANCE_FIELDS = (
    "disturbance_gain",
    "disturbance_time_constant",
    "disturbance_delay",
    "disturbance_element_type",
    "disturbance_numerator",
    "disturbance_denominator",
)
"""The DV model's fields in the ``system`` and ``plant`` blocks."""


def disturbance_names(v: _Values, inputs: tuple[str, ...]) -> tuple[str, ...]:
    """``system.disturbance_names`` (unique, none an MV's name); () without DVs, then no DV field may be given."""
    names: tuple[str, ...] = v["system.disturbance_names"]
    given = v.tree.get("system", {})
    if not names:
        stray = next(
            (k for k in DISTURBANCE_FIELDS if k in given and given[k] != parameter(f"system.{k}").default), None
        )
        if stray is not None:
            raise v.error(f"system.{stray}", None, "is given without system.disturbance_names (the DVs it describes)")
        return ()
    clash = sorted(set(names) & set(inputs))
    if clash:
        raise v.error("system.disturbance_names", list(names), f"{clash[0]!r} is already an input's name")
    return names


def disturbance_mismatch(v: _Values, model: TransferMatrix) -> Mismatch:
    """The ``mismatch`` block's DV part (``disturbance_gain_pct``, ...), checked like the G part."""
    delay = v["mismatch.disturbance_delay_samples"]
    if np.any(model.delay_samples + delay < 0):
        raise v.error("mismatch.disturbance_delay_samples", delay.ravel().tolist(), "would make a plant delay negative")
    return Mismatch(
        v["mismatch.disturbance_gain_pct"], v["mismatch.disturbance_time_constant_pct"], np.rint(delay).astype(int)
    )


def disturbance_signal(v: _Values) -> DisturbanceSignalSettings:
    """The ``disturbance_signal`` block: how each simulated DV moves."""
    return DisturbanceSignalSettings(
        kind=tuple(str(k) for k in v["disturbance_signal.kind"]),
        amplitude=v["disturbance_signal.amplitude"],
        mean_interval_samples=v["disturbance_signal.mean_interval_samples"],
    )


def zone_settings(v: _Values, outputs: tuple[str, ...]) -> dict[str, Any]:
    """``mpc.output_mode``, ``output_low``, ``output_high``, ``zone_weight`` as :class:`MpcTuning` fields.

    Raises
    ------
    ConfigError
        A CV whose low limit lies above its high one.
    """
    low, high = v["mpc.output_low"], v["mpc.output_high"]
    bad = np.flatnonzero(low > high)
    if bad.size:
        i = int(bad[0])
        raise v.error(
            f"mpc.output_low[{i}] ({outputs[i]})", float(low[i]), f"must not exceed mpc.output_high[{i}] ({high[i]:g})"
        )
    return {
        "output_mode": tuple(str(m) for m in v["mpc.output_mode"]),
        "output_low": low,
        "output_high": high,
        "zone_weight": v["mpc.zone_weight"],
    }


def manual_settings(v: _Values, inputs: tuple[str, ...]) -> ManualSettings:
    """``run.manual_stretches`` with each MV resolved to its index, and the operators' move size.

    The effective tree's ``run.manual_stretches`` is rewritten in the flat form
    the nodes take (:func:`flat_stretches`), so the configuration handed to the
    node set (and recorded in a bag) is one a ROS parameter holds.

    Raises
    ------
    ConfigError
        An MV name that is no input's, or an index beyond the inputs.
    """
    stretches = []
    for j, (start, length, channel) in enumerate(v["run.manual_stretches"]):
        if isinstance(channel, str):
            if channel not in inputs:
                raise v.error(f"run.manual_stretches[{j}]", channel, f"is no input's name ({', '.join(inputs)})")
            index = inputs.index(channel)
        elif channel >= len(inputs):
            raise v.error(f"run.manual_stretches[{j}]", channel, f"is no input index (0 .. {len(inputs) - 1})")
        else:
            index = int(channel)
        stretches.append((start, length, index))
    settings = ManualSettings(tuple(stretches), v["run.manual_move_amplitude"], v["run.manual_moves"])
    v.tree.setdefault("run", {})["manual_stretches"] = flat_stretches(settings)
    return settings


def flat_stretches(settings: ManualSettings) -> list[int]:
    """The stretches as one flat integer list ``[start, length, MV index, ...]``: the form a ROS parameter holds.

    Examples
    --------
    >>> flat_stretches(ManualSettings(((300, 400, 0), (900, 300, 1))))
    [300, 400, 0, 900, 300, 1]
    """
    return [int(n) for stretch in settings.stretches for n in stretch]
