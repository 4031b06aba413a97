"""The ``prbs`` block: its settings, and the check that every PRBS channel has its own primitive polynomial."""

from __future__ import annotations

from typing import Any

from ..core.sim.excitation import ExcitationSettings, PrbsSettings, primitive_polynomial_count
from ..core.sim.model import TransferMatrix

__all__ = ["check_prbs_channels", "prbs_settings"]


def prbs_settings(v: Any) -> PrbsSettings:
    """The ``prbs`` block's settings from the checked values ``v`` (``v['prbs.<key>']``)."""
    keys = (
        "register_length",
        "clock_period",
        "amplitude",
        "nominal",
        "mode",
        "step_interval_samples",
        "step_amplitude",
    )
    return PrbsSettings(**{key: v[f"prbs.{key}"] for key in keys})


def check_prbs_channels(v: Any, model: TransferMatrix, excitation: ExcitationSettings) -> None:
    """Every PRBS channel (setpoints, then dithered inputs) needs its own primitive polynomial."""
    degree = v["prbs.register_length"]
    channels = model.n_outputs + (model.n_inputs if excitation.active else 0)
    available = primitive_polynomial_count(degree)
    if channels > available:
        raise v.error(
            "prbs.register_length",
            degree,
            f"has {available} primitive polynomials, fewer than the {channels} PRBS channels "
            f"({model.n_outputs} setpoints{f' + {model.n_inputs} dithered inputs' if excitation.active else ''}); "
            "choose a longer register",
        )
