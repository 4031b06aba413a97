"""The corrected model: the controller's model with every mismatched element replaced by its estimate.

Only elements whose verdict is ``mismatch`` change; ``ok`` and ``inconclusive``
elements stay as they were (a confident "no" and "cannot tell" are both
reasons to leave a model alone).  A changed element takes the parametric
estimate of all its parameters: ``K = Khat (1 + dK/100)``, ``tau = tauhat (1 +
dtau/100)`` (FOPTD only) and ``D = Dhat + dD``.  The classic method gives no
time-constant estimate (its index is a slope, not a ratio), so a corrected
model needs the parametric method.  A diagnosis with measured disturbances
(D elements, columns past the model's inputs) corrects the disturbance model
``Gd`` the same way when it is given (:attr:`ModelUpdate.disturbance_model`);
the controller's model ``G`` is what the MPC acts on.

A ``tf`` or ``step_response`` element keeps its form: the corrected element
is the element scaled, ``rho Ghat(alpha s) exp(-dD s)``
(:meth:`~pmr_ros.core.sim.lti.Element.scaled`) with ``rho = 1 + dK/100``, the
dynamics ``alpha = 1 + dtau/100`` (its time-constant change is its dynamics
change) and ``dD``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..results import Diagnosis, ElementDiagnosis, ElementModel, ParametricResult
from ..sim.lti import Element, Foptd, Integrating
from ..sim.model import TransferMatrix

__all__ = ["ElementChange", "ModelUpdate", "corrected_model", "with_changes"]


class NotCorrectable(ValueError):
    """The diagnosis cannot give a corrected model (wrong method, no verdict); the message says why."""


@dataclass(frozen=True)
class ElementChange:
    """One element of the model replaced by its estimate.

    Attributes
    ----------
    name : str
        ``G21``.
    before, after : ElementModel
        The model's element and the corrected one.
    estimate : ParametricResult
        The numbers and intervals the change rests on.
    element : Element or None
        The corrected element itself where the model's is a ``tf`` or
        ``step_response`` (the model's scaled); None for the other types.
    """

    name: str
    before: ElementModel
    after: ElementModel
    estimate: ParametricResult
    element: Element | None = None

    def comment(self) -> str:
        """One line for people: the element, what changed and why."""
        return f"{self.name}: {self.note()}"

    def note(self) -> str:
        """What changed and why (the params file's comment beside the element)."""
        p = self.estimate
        parts = []
        if p.gain_mismatch_pct is not None and p.gain_mismatch_pct_interval is not None:
            lo, hi = p.gain_mismatch_pct_interval
            parts.append(
                f"K {self.before.gain:.6g} -> {self.after.gain:.6g} "
                f"(dK {p.gain_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {p.gain_verdict})"
            )
        if (
            self.after.time_constant is not None
            and p.tau_mismatch_pct is not None
            and p.tau_mismatch_pct_interval is not None
        ):
            lo, hi = p.tau_mismatch_pct_interval
            parts.append(
                f"tau {self.before.time_constant:.6g} -> {self.after.time_constant:.6g} "
                f"(dtau {p.tau_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {p.tau_verdict})"
            )
        if self.element is not None and p.tau_mismatch_pct is not None and p.tau_mismatch_pct_interval is not None:
            lo, hi = p.tau_mismatch_pct_interval
            parts.append(
                f"dynamics x{1.0 + p.tau_mismatch_pct / 100.0:.4g} "
                f"(dalpha {p.tau_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {p.tau_verdict})"
            )
        if p.delay_mismatch_samples is not None and p.delay_confidence is not None:
            parts.append(
                f"D {self.before.delay_samples} -> {self.after.delay_samples} samples "
                f"(dD {p.delay_mismatch_samples:+d}, {100 * p.delay_confidence:.0f} % {p.delay_verdict})"
            )
        return "; ".join(parts)


@dataclass(frozen=True)
class ModelUpdate:
    """A corrected model and the changes that make it.

    Attributes
    ----------
    model : TransferMatrix
        The corrected model (the controller's where nothing changed).
    changes : tuple of ElementChange
        Row-major, only the elements that changed (G elements, then D elements).
    disturbance_model : TransferMatrix or None
        The corrected disturbance model ``Gd`` (the given one where no D
        element changed); None when none was given.
    """

    model: TransferMatrix
    changes: tuple[ElementChange, ...]
    disturbance_model: TransferMatrix | None = None

    @property
    def disturbance_changes(self) -> tuple[ElementChange, ...]:
        """The changes of D elements (the measured disturbances' model)."""
        return tuple(c for c in self.changes if c.name.startswith("D"))


def _estimated_element(element: ElementDiagnosis, cell: Element) -> tuple[ElementModel, Element | None]:
    """The corrected element: its estimated parameters; for a tf/step_response element also the element scaled."""
    p = element.parametric
    before = element.model
    if p is None or p.gain_mismatch_pct is None or p.delay_mismatch_samples is None:
        raise NotCorrectable(f"{element.name}: a mismatch verdict without a parametric estimate")
    if cell.kind in ("tf", "step_response"):
        alpha = 1.0 + (p.tau_mismatch_pct or 0.0) / 100.0
        scaled = cell.scaled(
            gain_ratio=1.0 + p.gain_mismatch_pct / 100.0,
            time_scale=alpha,
            delay_change=int(p.delay_mismatch_samples),
        )
        return ElementModel(before.kind, scaled.steady_state_gain, None, scaled.delay_samples), scaled
    tau = before.time_constant
    if tau is not None and p.tau_mismatch_pct is not None:
        tau = tau * (1.0 + p.tau_mismatch_pct / 100.0)
    gain = before.gain * (1.0 + p.gain_mismatch_pct / 100.0)
    return ElementModel(before.kind, gain, tau, before.delay_samples + int(p.delay_mismatch_samples)), None


def with_changes(model: TransferMatrix, changes: Sequence[tuple[int, int, ElementChange]]) -> TransferMatrix:
    """``model`` with the elements ``(row, column, change)`` replaced by the changes' corrected elements.

    Parameters
    ----------
    model : TransferMatrix
        The model (``G`` or ``Gd``).
    changes : sequence of (int, int, ElementChange)
        Zero-based row and column of each changed element.

    Returns
    -------
    TransferMatrix
        Of the same element types; a ``tf``/``step_response`` element replaced by :attr:`ElementChange.element`.
    """
    if not model.has_general:
        gain, tau, delay = model.gain.copy(), model.time_constant.copy(), model.delay.copy()
        for i, k, change in changes:
            gain[i, k] = change.after.gain
            if change.after.time_constant is not None:
                tau[i, k] = change.after.time_constant
            delay[i, k] = change.after.delay_samples * model.sample_time
        return replace(model, gain=gain, time_constant=np.where(np.isnan(tau), 0.0, tau), delay=delay)
    rows = model.element_rows()
    for i, k, change in changes:
        rows[i][k] = change.element if change.element is not None else _simple_element(change.after, model.sample_time)
    return model.with_elements(rows)


def _simple_element(after: ElementModel, sample_time: float) -> Element:
    """A corrected FOPTD or integrating element."""
    if after.time_constant is None:
        return Integrating(after.gain, after.delay_samples, sample_time)
    return Foptd(after.gain, after.time_constant, after.delay_samples, sample_time)


def corrected_model(
    model: TransferMatrix, diagnosis: Diagnosis, *, disturbance_model: TransferMatrix | None = None
) -> ModelUpdate:
    """The controller's model with every ``mismatch`` element replaced by its parametric estimate.

    Parameters
    ----------
    model : TransferMatrix
        The controller's model the diagnosis compared the plant with (``G``, without DVs).
    diagnosis : Diagnosis
        A parametric diagnosis with verdicts.
    disturbance_model : TransferMatrix, optional
        ``Gd``: its D elements (columns ``model.n_inputs ..`` of the
        diagnosis) are corrected too; without it a D element's mismatch is
        left out of the update.

    Returns
    -------
    ModelUpdate

    Raises
    ------
    NotCorrectable
        The diagnosis has no verdicts, or is not parametric.

    Examples
    --------
    A diagnosis without a ``mismatch`` verdict leaves the model as it is:
    ``corrected_model(model, diagnosis).changes == ()``.
    """
    if diagnosis.status != "ok":
        raise NotCorrectable(f"no verdicts to correct the model with ({diagnosis.reason})")
    if diagnosis.method != "parametric":
        raise NotCorrectable(
            "a corrected model needs the parametric method (the classic tau index is a slope, not a time constant)"
        )
    process: list[tuple[int, int, ElementChange]] = []
    disturbance: list[tuple[int, int, ElementChange]] = []
    changes, later = [], []
    for element in diagnosis:
        if element.verdict != "mismatch" or element.parametric is None:
            continue
        k = element.column
        if k >= model.n_inputs and disturbance_model is None:
            continue  # a D element without the disturbance model to correct
        target, column = (model, k) if k < model.n_inputs else (disturbance_model, k - model.n_inputs)
        after, cell = _estimated_element(element, target.element(element.row, column))  # type: ignore[union-attr]
        change = ElementChange(element.name, element.model, after, element.parametric, cell)
        if k < model.n_inputs:
            process.append((element.row, k, change))
            changes.append(change)
        else:
            disturbance.append((element.row, column, change))
            later.append(change)
    corrected_disturbances = None if disturbance_model is None else with_changes(disturbance_model, disturbance)
    return ModelUpdate(with_changes(model, process), tuple(changes + later), corrected_disturbances)
