"""Closing the loop after a verdict: the control impact, the corrected model, judging a live update.

``impact`` which mismatch matters for control (``pi_loops`` the PI controller it may
simulate), ``update`` the corrected model, ``adaptation`` whether a live model switch made control better or worse.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "AdaptSettings": "adaptation",
    "Adaptation": "adaptation",
    "ControllerSettings": "pi_loops",
    "ElementChange": "update",
    "ImpactSettings": "impact",
    "Judgement": "adaptation",
    "LoopFigures": "impact",
    "MismatchSize": "adaptation",
    "ModelUpdate": "update",
    "PiLoop": "pi_loops",
    "PiTuning": "pi_loops",
    "TrackingFigures": "adaptation",
    "control_impact": "impact",
    "corrected_model": "update",
    "judge_update": "adaptation",
    "loop_figures": "impact",
    "mismatch_size": "adaptation",
    "pi_figures": "impact",
    "simulate_pi": "pi_loops",
    "tracking_figures": "adaptation",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "AdaptSettings",
    "Adaptation",
    "ControllerSettings",
    "ElementChange",
    "ImpactSettings",
    "Judgement",
    "LoopFigures",
    "MismatchSize",
    "ModelUpdate",
    "PiLoop",
    "PiTuning",
    "TrackingFigures",
    "control_impact",
    "corrected_model",
    "judge_update",
    "loop_figures",
    "mismatch_size",
    "pi_figures",
    "simulate_pi",
    "tracking_figures",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .adaptation import (
        Adaptation,
        AdaptSettings,
        Judgement,
        MismatchSize,
        TrackingFigures,
        judge_update,
        mismatch_size,
        tracking_figures,
    )
    from .impact import ImpactSettings, LoopFigures, control_impact, loop_figures, pi_figures
    from .pi_loops import ControllerSettings, PiLoop, PiTuning, simulate_pi
    from .update import ElementChange, ModelUpdate, corrected_model
