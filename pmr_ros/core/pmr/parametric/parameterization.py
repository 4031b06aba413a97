"""The parameterization of each column of a row's regression, read off the model's elements.

A FOPTD element is a ``ratio`` column (its closed form), an integrating one
(or one of any type with nothing to scale, ``K/s``) a ``delay`` column, a
``tf`` or ``step_response`` element a ``scaled`` column (:mod:`.scaled`), an
empty cell an interaction template (:class:`~.ratio.ColumnModel`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from scipy.special import ndtri  # norm.ppf's own function (the same numbers)

from ...sim.model import TransferMatrix
from ..implicit import RowLayout
from ..timescale import slowest_time_constant
from .ratio import TAU_RATIO_BOUND, TEMPLATE_TAU_FLOOR, ColumnModel
from .scaled import ScaledShape

__all__ = [
    "TEMPLATE_SHAPES",
    "absence_z",
    "bonferroni_z",
    "column_models",
    "interaction_delay_range",
    "search_candidates",
]

TEMPLATE_SHAPES = 2
"""Effectively independent template time constants counted per delay candidate in the Bonferroni bound."""


def interaction_delay_range(model: TransferMatrix, max_delay_samples: int) -> tuple[int, int]:
    """``(0, highest)`` dead time [samples] searched for an unmodeled interaction.

    Up to the model's largest delay plus the delay-mismatch range: an
    interaction is taken to be no slower to appear than a modeled element could be.
    """
    return 0, int(model.delay_samples.max()) + int(max_delay_samples)


def search_candidates(column: ColumnModel) -> int:
    """Templates an interaction's search chooses among: delays, times :data:`TEMPLATE_SHAPES` with a time constant."""
    low, high = column.delay_bounds
    return (high - low + 1) * (TEMPLATE_SHAPES if column.has_tau else 1)


def bonferroni_z(*, candidates: int, confidence_level: float) -> float:
    """The two-sided normal quantile of ``confidence_level`` shared among ``candidates`` searched templates."""
    return float(ndtri(1.0 - (1.0 - confidence_level) / (2.0 * candidates)))


def absence_z(columns: Sequence[ColumnModel], *, confidence_level: float) -> list[float]:
    """Per column: the normal quantile within which an interaction's gain is the search's chance best; inf else.

    The Bonferroni level of :func:`search_candidates` (the interaction verdict's own): a gain inside it is what
    the search over that many templates finds where the plant has no interaction.
    """
    return [
        bonferroni_z(candidates=search_candidates(c), confidence_level=confidence_level) if c.interaction else math.inf
        for c in columns
    ]


def _element_column(model: TransferMatrix, i: int, k: int, *, max_delay_samples: int) -> ColumnModel:
    """The parameterization of modeled element (i, k): FOPTD ratio, integrating delay, or any element scaled."""
    kind = str(model.element_type[i, k])
    delay = int(model.delay_samples[i, k])
    delays = (max(-max_delay_samples, -delay), max_delay_samples)
    limit = max_delay_samples < delay
    tau_bound = math.log(TAU_RATIO_BOUND)
    if kind == "foptd":
        tau = float(model.time_constant[i, k]) / model.sample_time
        return ColumnModel("ratio", math.exp(-1.0 / tau), tau, (-tau_bound, tau_bound), delays, limit)
    shape = ScaledShape(model.element(i, k)) if kind != "integrating" else None
    if shape is None or not shape.has_dynamics:  # K/s (of any type): gain and delay only
        return ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), delays, limit)
    return ColumnModel("scaled", 0.0, 1.0, (-tau_bound, tau_bound), delays, limit, scaled=shape)


def column_models(model: TransferMatrix, layout: RowLayout, *, max_delay_samples: int) -> list[ColumnModel]:
    """The parameterization of each column of a row's layout (:class:`~.ratio.ColumnModel`)."""
    i = layout.row
    differenced = bool(model.integrating_outputs[i])
    reference = max(slowest_time_constant(model) / model.sample_time, 1.0)
    interaction = interaction_delay_range(model, max_delay_samples)
    out = []
    for k in layout.columns:
        if str(model.element_type[i, k]) == "none":
            template = "pulse" if differenced else "lag"
            bounds = (math.log(TEMPLATE_TAU_FLOOR / reference), math.log(TAU_RATIO_BOUND))
            out.append(ColumnModel(template, 0.0, reference, bounds, interaction, False))
        else:
            out.append(_element_column(model, i, int(k), max_delay_samples=max_delay_samples))
    return out
