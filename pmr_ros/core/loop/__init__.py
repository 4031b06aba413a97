"""Closing the loop after a verdict: the control impact, the corrected model, judging a live update.

``impact`` which mismatch matters for control, ``update`` the corrected model,
``adaptation`` whether a live model switch made control better or worse.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "AdaptSettings": "adaptation",
    "Adaptation": "adaptation",
    "ElementChange": "update",
    "ImpactSettings": "impact",
    "Judgement": "adaptation",
    "LoopFigures": "impact",
    "MismatchSize": "adaptation",
    "ModelUpdate": "update",
    "TrackingFigures": "adaptation",
    "control_impact": "impact",
    "corrected_model": "update",
    "judge_update": "adaptation",
    "loop_figures": "impact",
    "mismatch_size": "adaptation",
    "tracking_figures": "adaptation",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "AdaptSettings",
    "Adaptation",
    "ElementChange",
    "ImpactSettings",
    "Judgement",
    "LoopFigures",
    "MismatchSize",
    "ModelUpdate",
    "TrackingFigures",
    "control_impact",
    "corrected_model",
    "judge_update",
    "loop_figures",
    "mismatch_size",
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
    from .impact import ImpactSettings, LoopFigures, control_impact, loop_figures
    from .update import ElementChange, ModelUpdate, corrected_model
