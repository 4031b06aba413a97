"""The sweep report's reference points: the paper's published numbers (when they apply) and shared labels."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..config import PmrConfig, load_config
from ..sweep.analysis import (
    Breakdown,
    PointSummary,
)

if TYPE_CHECKING:
    pass


PAPER_GAIN_PCT = {"G11": 10.0, "G12": 14.4, "G21": -18.0, "G22": -11.3}
"""The paper's eq. (16): baseline gain mismatch estimates [%]."""


PAPER_TAU_INDEX = {"G11": 20.85, "G12": 23.09, "G21": -37.49, "G22": -23.40}
"""The paper's eq. (17): baseline time-constant indices (-100 x slope)."""


PAPER_DELAY = {"G21": 2}
"""The paper's section 3.3: a 2-sample delay mismatch diagnosed in G21 (others not reported)."""


PAPER_BREAKDOWN_NU = {"G11": 2.25, "G21": 2.5}
"""Section 3.6: "the PMR starts to fail for G11 at about nu = 2.25 and for G12 [G21] at about 2.5"."""


PAPER_FIGURES = {
    ("G11", "gain"): 2,
    ("G11", "tau"): 3,
    ("G11", "delay"): 4,
    ("G21", "gain"): 5,
    ("G21", "tau"): 6,
    ("G21", "delay"): 7,
}


PAPER_SYSTEM = "wood_berry"
"""``system.name`` of the paper's system; the PAPER_* numbers are its published figures."""


PARAMETRIC_TARGET_SHARE = 0.90
"""The parametric method's target: at least this share of a point's seeds right on gain, tau and delay."""


SCENARIO_LABELS = {
    "none": "1 no MPM",
    "gain": "2 gain only",
    "time_constant": "3 time constant only",
    "delay": "4 delay only",
    "full": "5 full MPM",
}


QUANTITY = {
    "gain": ("gain", "gain ratio K/K̂ (M(0))"),
    "tau": ("tau", "time-constant index (-100 × slope)"),
    "delay": ("delay", "delay mismatch D - D̂ [samples]"),
}


PARAMETRIC_QUANTITY = {
    "gain": ("gain", "gain ratio K/K̂ (fitted)"),
    "tau": ("tau", "time-constant change Δτ [%] (fitted)"),
    "delay": ("delay", "delay mismatch D - D̂ [samples]"),
}


def by(summary: list[PointSummary], **match) -> list[PointSummary]:
    """The points whose attributes equal ``match`` (``method="classic", nu=1.0`` ...)."""
    return [p for p in summary if all(getattr(p, k) == v for k, v in match.items())]


def paper_comparison_applies(config: PmrConfig) -> bool:
    """Whether the paper's published numbers (``PAPER_*``) may stand beside this sweep's.

    They are figures of the Wood-Berry column under the paper's eq. (15)
    mismatch, so the configured system must be that one: named ``wood_berry``
    with the model (K, tau, theta, Ts) and the mismatch of the shipped
    ``wood_berry.yaml``, which holds the paper's values.  A Wood-Berry file
    with other time constants or mismatch is another system.
    """
    if config.model.name != PAPER_SYSTEM:
        return False
    reference = load_config()  # the shipped Wood-Berry column
    model, paper = config.model, reference.model
    if model.gain.shape != paper.gain.shape or model.sample_time != paper.sample_time:
        return False
    same_model = all(np.array_equal(getattr(model, f), getattr(paper, f)) for f in ("gain", "time_constant", "delay"))
    same_mismatch = all(
        np.array_equal(getattr(config.mismatch, f), getattr(reference.mismatch, f))
        for f in ("gain_pct", "time_constant_pct", "delay_samples")
    )
    return same_model and same_mismatch


def paper_breakdown(element_swept: str, paper: bool) -> float | None:
    """The paper's breakdown nu of the sweep of ``element_swept``; None when the paper has none or does not apply."""
    return PAPER_BREAKDOWN_NU.get(element_swept) if paper else None


def channels(values: np.ndarray | float) -> str:
    """One number when every channel has the same, else the row-major list ``[a, b, ...]``."""
    v = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
    if np.all(v == v[0]):
        return f"{v[0]:g}"
    return "[" + ", ".join(f"{x:g}" for x in v) + "]"


def fmt_nu(b: Breakdown | None) -> str:
    """A breakdown's nu as text, ``never`` without one."""
    if b is None:
        return "never"
    return f"{b.nu:g}"


def ratio_at(summary: list[PointSummary], element_swept: str, nu: float) -> float:
    """Row ratio at ``nu`` by linear interpolation of the sweep's points (it is linear in nu)."""
    pts = sorted({(p.nu, p.row_time_constant_ratio) for p in summary if p.element_swept == element_swept})
    if not pts:
        return float("nan")
    x, y = zip(*pts, strict=True)
    if len(x) == 1:
        return y[0] * nu / x[0]
    return (
        float(np.interp(nu, x, y, left=np.nan, right=np.nan))
        if x[0] <= nu <= x[-1]
        else float(y[0] + (y[-1] - y[0]) / (x[-1] - x[0]) * (nu - x[0]))
    )
