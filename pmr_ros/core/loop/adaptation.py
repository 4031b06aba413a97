"""Judging a live model update: whether the corrected model made control better or worse.

After the controller switched to the corrected model, the window diagnosed
against it and the window diagnosed before are compared on two counts:

* **mismatch**: the largest mismatch a ``mismatch`` verdict stands on
  (|dK| and |dtau| in %, |dD| in samples, the gain of an unmodeled
  interaction relative to nothing: 100 %); the update made it worse when
  either grew;
* **tracking**: the measured integrated squared tracking error per sample
  (weighted by the MPC's output weights) over each window; the update made it
  worse when it rose by more than ``adapt.ise_rise_tolerance_pct`` (windows of
  the same controller differ by a few % with the excitation's content).

A worse update is rolled back to the previous model.  The figures are
measured on the plant's data, noise included, not simulated.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..results import Diagnosis, ElementModel
from ..results.codec import diagnosis_to_json

__all__ = [
    "AdaptSettings",
    "Adaptation",
    "Judgement",
    "MismatchSize",
    "TrackingFigures",
    "judge_update",
    "mismatch_size",
    "tracking_figures",
]


@dataclass(frozen=True)
class AdaptSettings:
    """The ``adapt`` block.

    Attributes
    ----------
    ise_rise_tolerance_pct : float
        A rise of the tracking error per sample beyond this after an update rolls it back [%].
    """

    ise_rise_tolerance_pct: float


@dataclass(frozen=True)
class TrackingFigures:
    """Measured control performance over a window.

    Attributes
    ----------
    ise_per_sample : float
        ``mean_k sum_i Q_i (r_i(k) - y_i(k))^2`` [output unit^2, weighted].
    input_movement_per_sample : float
        ``mean_k sum_j R_j (u_j(k) - u_j(k-1))^2`` [input unit^2, weighted].
    first_sample, last_sample : int
        The window [samples].
    """

    ise_per_sample: float
    input_movement_per_sample: float
    first_sample: int
    last_sample: int


def tracking_figures(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    output_weight: np.ndarray,
    move_weight: np.ndarray,
    first_sample: int,
) -> TrackingFigures:
    """The tracking error and input movement per sample of a window of r, u, y.

    Parameters
    ----------
    r, y : ndarray, shape (samples, n_outputs)
        Setpoints and measured outputs [output unit].
    u : ndarray, shape (samples, n_inputs)
        Applied inputs [input unit]; the first move is taken from the window's first input.
    output_weight, move_weight : ndarray
        The MPC's Q (per output) and R (per input).
    first_sample : int
        Index of the window's first sample.
    """
    error = np.sum(np.asarray(output_weight) * (r - y) ** 2, axis=1)
    moves = np.sum(np.asarray(move_weight) * np.diff(u, axis=0) ** 2, axis=1)
    return TrackingFigures(
        float(error.mean()), float(moves.mean()) if moves.size else 0.0, first_sample, first_sample + len(r) - 1
    )


@dataclass(frozen=True)
class MismatchSize:
    """The largest mismatch the ``mismatch`` verdicts of a diagnosis stand on.

    Attributes
    ----------
    percent : float
        Largest |dK| or |dtau| [%] of a mismatched property (100 for an unmodeled interaction); 0 without.
    delay_samples : int
        Largest |dD| of a mismatched delay [samples].
    elements : tuple of str
        The elements with a ``mismatch`` verdict.
    """

    percent: float
    delay_samples: int
    elements: tuple[str, ...]


def _element_size(element: Any) -> tuple[float, int]:
    p = element.parametric
    if p is None or element.verdict != "mismatch":
        return 0.0, 0
    sizes = [0.0]
    if p.gain_verdict == "mismatch" and p.gain_mismatch_pct is not None:
        sizes.append(abs(p.gain_mismatch_pct))
    if p.tau_verdict == "mismatch" and p.tau_mismatch_pct is not None:
        sizes.append(abs(p.tau_mismatch_pct))
    if p.unmodeled_verdict == "mismatch":
        sizes.append(100.0)
    delay = abs(p.delay_mismatch_samples or 0) if p.delay_verdict == "mismatch" else 0
    return max(sizes), int(delay)


def mismatch_size(diagnosis: Diagnosis) -> MismatchSize:
    """The largest mismatch of a (parametric) diagnosis; zero without a ``mismatch`` verdict."""
    sizes = {e.name: _element_size(e) for e in diagnosis}
    mismatched = tuple(e.name for e in diagnosis if e.verdict == "mismatch")
    percent = max((s[0] for s in sizes.values()), default=0.0)
    delay = max((s[1] for s in sizes.values()), default=0)
    return MismatchSize(percent, delay, mismatched)


@dataclass(frozen=True)
class Judgement:
    """Whether an update made control worse, and why.

    Attributes
    ----------
    worse : bool
    reasons : tuple of str
        One line per count on which it is worse (empty when it is not).
    """

    worse: bool
    reasons: tuple[str, ...]


def judge_update(
    before: Diagnosis,
    after: Diagnosis,
    *,
    tracking: tuple[TrackingFigures, TrackingFigures],
    settings: AdaptSettings,
) -> Judgement:
    """Whether the window after an update is worse than the one before (then the update is rolled back).

    Parameters
    ----------
    before, after : Diagnosis
        The verdicts of the window before the update (against the old model) and after (against the new one).
    tracking : pair of TrackingFigures
        The measured figures of the same two windows.
    settings : AdaptSettings
    """
    old, new = mismatch_size(before), mismatch_size(after)
    reasons = []
    if new.percent > old.percent:
        reasons.append(f"a larger mismatch: {new.percent:.1f} % after, {old.percent:.1f} % before")
    if new.delay_samples > old.delay_samples:
        reasons.append(f"a larger delay mismatch: {new.delay_samples} samples after, {old.delay_samples} before")
    ise_before, ise_after = tracking[0].ise_per_sample, tracking[1].ise_per_sample
    if ise_after > ise_before * (1.0 + settings.ise_rise_tolerance_pct / 100.0):
        rise = 100.0 * (ise_after / ise_before - 1.0)
        reasons.append(
            f"the tracking error rose by {rise:.1f} % ({ise_before:.4g} -> {ise_after:.4g} per sample; "
            f"tolerance {settings.ise_rise_tolerance_pct:g} %)"
        )
    return Judgement(bool(reasons), tuple(reasons))


def _model_dict(element: ElementModel) -> dict[str, Any]:
    return {
        "kind": element.kind,
        "gain": element.gain,
        "time_constant": element.time_constant,
        "delay_samples": element.delay_samples,
    }


@dataclass(frozen=True)
class Adaptation:
    """A live model update and its outcome, for the report.

    Attributes
    ----------
    before : Diagnosis
        The verdicts of the window before the update.
    changes : tuple of (str, ElementModel, ElementModel)
        Element name, its model before and after the update.
    switch_sample : int
        The first sample computed with the new model.
    tracking : pair of TrackingFigures
        Before and after.
    judgement : Judgement
    rolled_back : bool
        The update was undone (the controller is back on the previous model).
    rollback_sample : int or None
        The first sample computed with the previous model again.
    """

    before: Diagnosis
    changes: tuple[tuple[str, ElementModel, ElementModel], ...]
    switch_sample: int
    tracking: tuple[TrackingFigures, TrackingFigures]
    judgement: Judgement
    rolled_back: bool = False
    rollback_sample: int | None = None
    notes: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the earlier window's verdicts, the changes, the tracking figures, the judgement."""
        before, after = self.tracking
        return {
            "before": diagnosis_to_json(self.before),
            "changes": [
                {"element": name, "before": _model_dict(old), "after": _model_dict(new)}
                for name, old, new in self.changes
            ],
            "switch_sample": self.switch_sample,
            "tracking": {
                "before": before.__dict__,
                "after": after.__dict__,
                "ise_ratio": after.ise_per_sample / before.ise_per_sample if before.ise_per_sample > 0 else None,
            },
            "worse": self.judgement.worse,
            "reasons": list(self.judgement.reasons),
            "rolled_back": self.rolled_back,
            "rollback_sample": self.rollback_sample,
            "notes": list(self.notes),
        }
