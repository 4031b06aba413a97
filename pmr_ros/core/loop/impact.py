"""Which mismatch matters for control: the configured controller on the plant as estimated vs as modelled.

For each element with a ``mismatch`` verdict the closed loop is simulated
with the controller as configured (the MPC: its model Ghat, its tuning; or the
PI loops of ``controller.kind: pi``, :mod:`.pi_loops`; either with the
configured setpoint excitation) on a plant that is Ghat with only that element replaced by its
estimate, and once with every mismatched element replaced; the integrated
squared tracking error (ISE, weighted by the MPC's output weights) and the
squared input moves (weighted by its move weights) are compared with the
same loop on the plant as modelled (Ghat itself); PI loops weigh every
controlled CV's error and every move alike.  Assumptions: the loop is
linear and noise-free; the configured setpoint excitation stands for the
operating regime; the estimates stand for the plant (their intervals are not
propagated); constraints act as configured.  A ratio of 1 means the mismatch
does not matter for control; ``inf`` means the loop goes unstable.

Routine operation, as the MPC runs it: with measured disturbances the DVs move
as the configured ``disturbance_signal`` (the run's seed) through the plant's
D elements while the MPC feeds them forward through its model ``Gd``, so a
mismatched D element (imperfect feedforward) has an impact of its own and a G
element's counts with the DVs moving; a zone CV's setpoint is not tracked, so
its error is its distance outside the zone, weighted by ``mpc.zone_weight``
(the MPC's own penalty there), not ``r - y``.  Every controller is on (no
manual stretch): the impact is that of the loop the controller closes.  PI
loops have no feedforward: their impact simulates the G elements without DVs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

import numpy as np

from ..mpc.controller import MpcTuning
from ..results import Diagnosis, ImpactResult
from ..sim.closed_loop import LoopConfig, RunPlan, simulate
from ..sim.excitation import ExcitationSettings, PrbsSettings
from ..sim.model import TransferMatrix
from ..sim.operation import DisturbanceSignalSettings, ManualSettings, setpoint_generator
from ..sim.true_plant import OutputDisturbance
from .pi_loops import ControllerSettings, PiTuning, simulate_pi
from .update import ModelUpdate, with_changes

__all__ = [
    "ImpactSettings",
    "LoopFigures",
    "Mapper",
    "control_impact",
    "loop_figures",
    "pi_figures",
    "weighted_errors",
]

Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], Sequence[Any]]
"""``mapper(work, tasks)``: ``[work(t) for t in tasks]`` in order, here or on worker processes."""

UNSTABLE = 1e9
"""An output beyond this many times the setpoint swing counts as a loop gone unstable."""


@dataclass(frozen=True)
class ImpactSettings:
    """The ``impact`` block: how long each simulation runs.

    Attributes
    ----------
    samples : int
        Closed-loop samples per simulation; 0: the impact is not computed.
    """

    samples: int

    @property
    def active(self) -> bool:
        """Whether the impact is computed."""
        return self.samples > 0


@dataclass(frozen=True)
class LoopFigures:
    """Performance of one simulated closed loop.

    Attributes
    ----------
    ise : float
        ``sum_k sum_i Q_i (r_i(k) - y_i(k))^2`` [output unit^2 x samples, weighted].
    input_movement : float
        ``sum_k sum_j R_j (u_j(k) - u_j(k-1))^2`` [input unit^2, weighted].
    """

    ise: float
    input_movement: float

    def ratio_to(self, base: LoopFigures) -> tuple[float, float]:
        """``(ise, input_movement)`` of this loop over ``base``'s."""
        return _ratio(self.ise, base.ise), _ratio(self.input_movement, base.input_movement)


def _ratio(value: float, base: float) -> float:
    if not math.isfinite(value):
        return math.inf
    return value / base if base > 0 else (1.0 if value == 0 else math.inf)


@dataclass(frozen=True)
class _Loop:
    """A :class:`LoopConfig` of the configured controller on a given plant, noise-free.

    ``feedforward`` is the controller's DV model (None: no DVs), ``disturbance_truth``
    the plant's D elements the DVs move it through.
    """

    model: TransferMatrix
    noise_std: np.ndarray
    prbs: PrbsSettings
    excitation: ExcitationSettings
    mpc: MpcTuning
    run: RunPlan
    truth: TransferMatrix
    feedforward: TransferMatrix | None = None
    disturbance_truth: TransferMatrix | None = None
    disturbance_signal: DisturbanceSignalSettings = field(default_factory=DisturbanceSignalSettings)

    @property
    def disturbance(self) -> OutputDisturbance:
        """None: the loop is noise-free."""
        return OutputDisturbance.off(self.model.n_outputs)

    @property
    def disturbance_model(self) -> TransferMatrix | None:
        """The controller's model of the measured disturbances (its feedforward), or None."""
        return self.feedforward

    @property
    def manual(self) -> ManualSettings:
        """No manual stretch: every controller on."""
        return ManualSettings()

    def plant(self, scenario: str | None = None) -> TransferMatrix:
        return self.truth

    def disturbance_plant(self, scenario: str | None = None) -> TransferMatrix | None:
        return self.disturbance_truth


def _unstable(r: np.ndarray, y: np.ndarray) -> bool:
    swing = float(np.max(np.abs(r))) or 1.0
    return not np.all(np.isfinite(y)) or bool(np.max(np.abs(y)) > UNSTABLE * swing)


def pi_figures(loop: LoopConfig, tuning: PiTuning, plant: TransferMatrix, *, samples: int) -> LoopFigures:
    """ISE (controlled CVs) and input movement of the PI loops on ``plant``, following the configured setpoints.

    Parameters
    ----------
    loop : LoopConfig
        Its setpoint excitation (``prbs``) and seed.
    tuning : PiTuning
    plant : TransferMatrix
    samples : int
    """
    r = setpoint_generator(loop.prbs, loop.run.seed).sequence(samples)
    with np.errstate(over="ignore", invalid="ignore"):
        y, u = simulate_pi(tuning, plant, r)
    cv = tuning.outputs
    if _unstable(r[:, cv], y[:, cv]):
        return LoopFigures(math.inf, math.inf)
    moves = np.diff(u, axis=0, prepend=np.zeros((1, u.shape[1])))
    return LoopFigures(float(np.sum((r[:, cv] - y[:, cv]) ** 2)), float(np.sum(moves**2)))


def weighted_errors(tuning: MpcTuning, r: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Each CV's error as the MPC weighs it, squared: ``Q (r - y)^2``, a zone CV's ``W dist(y, zone)^2``.

    Parameters
    ----------
    tuning : MpcTuning
        Output weights ``Q``; with zones the zone CVs, their limits and ``zone_weight`` ``W``.
    r, y : ndarray, shape (samples, n_outputs)
        Setpoints and outputs [output unit].

    Returns
    -------
    ndarray, shape (samples, n_outputs)
        [output unit^2, weighted]; 0 where a zone CV is inside its zone.
    """
    n = y.shape[1]
    squared = np.broadcast_to(np.asarray(tuning.output_weight, dtype=float), (n,)) * (r - y) ** 2
    zone = tuning.zone_outputs if tuning.zones_active and tuning.zone_outputs.size else np.zeros(n, dtype=bool)
    if not zone.any():
        return squared
    low = np.broadcast_to(np.asarray(tuning.output_low, dtype=float), (n,))
    high = np.broadcast_to(np.asarray(tuning.output_high, dtype=float), (n,))
    outside = np.maximum(low - y, 0.0) + np.maximum(y - high, 0.0)
    weight = np.broadcast_to(np.asarray(tuning.zone_weight, dtype=float), (n,))
    return np.where(zone, weight * outside**2, squared)


def loop_figures(
    loop: LoopConfig,
    plant: TransferMatrix,
    *,
    samples: int,
    controller: ControllerSettings | None = None,
    disturbance_plant: TransferMatrix | None = None,
) -> LoopFigures:
    """ISE and input movement of the configured loop on ``plant`` (noise-free, from rest).

    Parameters
    ----------
    loop : LoopConfig
        The controller's model (and DV model), tuning, setpoint excitation (and dither,
        the DVs' signals) and seed.
    plant : TransferMatrix
        The plant the controller runs on.
    samples : int
        Closed-loop samples simulated.
    controller : ControllerSettings, optional
        Kind ``pi``: its loops run instead of the MPC (:func:`pi_figures`); default the MPC.
    disturbance_plant : TransferMatrix, optional
        The plant's D elements (with a DV model; default the controller's own ``Gd``).

    Notes
    -----
    ISE sums :func:`weighted_errors`: a zone CV counts only outside its zone.
    """
    if controller is not None and controller.kind == "pi" and controller.pi is not None:
        return pi_figures(loop, controller.pi, plant, samples=samples)
    feedforward = loop.disturbance_model
    quiet = _Loop(
        loop.model,
        np.zeros(loop.model.n_outputs),
        loop.prbs,
        loop.excitation,
        loop.mpc,
        loop.run,
        plant,
        feedforward,
        disturbance_plant if disturbance_plant is not None else feedforward,
        _dv_signal(loop, feedforward),
    )
    with np.errstate(over="ignore", invalid="ignore"):
        record = simulate(quiet, samples=samples)
    if _unstable(record.r, record.y):
        return LoopFigures(math.inf, math.inf)
    moves = np.diff(record.u, axis=0, prepend=np.zeros((1, record.u.shape[1])))
    ise = float(np.sum(weighted_errors(loop.mpc, record.r, record.y)))
    movement = float(np.sum(np.asarray(loop.mpc.move_weight) * moves**2))
    return LoopFigures(ise, movement)


def _dv_signal(loop: LoopConfig, feedforward: TransferMatrix | None) -> DisturbanceSignalSettings:
    """The DVs' signals of the impact's loop: the configured ones; still where none is configured for its DVs."""
    if feedforward is None:
        return DisturbanceSignalSettings()
    signal, n = loop.disturbance_signal, feedforward.n_inputs
    if signal.n_disturbances == n:
        return signal
    return DisturbanceSignalSettings(("steps",) * n, np.zeros(n), np.ones(n))


def _plants(
    loop: LoopConfig, diagnosis: Diagnosis, update: ModelUpdate, name: str
) -> tuple[TransferMatrix, TransferMatrix | None]:
    """``(G, Gd)`` of the plant as modelled with only element ``name`` (a G or a D element) as estimated."""
    change = next(c for c in update.changes if c.name == name)
    element = diagnosis.elements[name]
    model, dv_model = loop.model, loop.disturbance_model
    if element.column < model.n_inputs:
        return with_changes(model, [(element.row, element.column, change)]), dv_model
    if dv_model is None:
        raise ValueError(f"{name} is a D element, but the loop has no model of the measured disturbances")
    return model, with_changes(dv_model, [(element.row, element.column - model.n_inputs, change)])


def control_impact(
    diagnosis: Diagnosis,
    *,
    loop: LoopConfig,
    update: ModelUpdate,
    samples: int,
    controller: ControllerSettings | None = None,
    mapper: Mapper | None = None,
) -> Diagnosis:
    """The diagnosis with the control impact of each mismatched element and of all together.

    Parameters
    ----------
    diagnosis : Diagnosis
        A parametric diagnosis (the one ``update`` was made from).
    loop : LoopConfig
        The configured controller and excitation.
    update : ModelUpdate
        The corrected model and its element changes (:func:`~pmr_ros.core.loop.update.corrected_model`).
    samples : int
        Closed-loop samples per simulation.
    controller : ControllerSettings, optional
        The controller simulated (:func:`loop_figures`); default the MPC.
    mapper : callable, optional
        Runs the ``N + 2`` independent simulations (the loop as modelled, each element alone, all together):
        ``mapper(work, plants)``, e.g. a process pool's ``map`` (``work`` pickles); default one after another here.

    Returns
    -------
    Diagnosis
        A new diagnosis: ``ElementDiagnosis.impact`` set on the changed
        elements, G and (with the MPC and a DV model) D, ranked by ISE ratio
        (1 = matters most); ``Diagnosis.impact`` for all together; the input
        diagnosis is left as it is.
    """
    pi = controller is not None and controller.kind == "pi"
    acting = [
        c
        for c in update.changes
        if c.name in diagnosis.elements
        and (diagnosis.elements[c.name].column < loop.model.n_inputs or not pi)  # PI loops feed nothing forward
    ]
    if not acting:
        return diagnosis

    # the loop as modelled, each element alone, all together: independent simulations
    dv_together = loop.disturbance_model if pi else (update.disturbance_model or loop.disturbance_model)
    plants = [(loop.model, loop.disturbance_model), *(_plants(loop, diagnosis, update, c.name) for c in acting)]
    work = partial(_figures, loop=loop, samples=samples, controller=controller)
    figures: list[LoopFigures] = list((mapper or map)(work, [*plants, (update.model, dv_together)]))
    base, all_changed = figures[0], figures[-1]
    alone = dict(zip((c.name for c in acting), figures[1:-1], strict=True))
    ranked = sorted(alone, key=lambda name: -min(alone[name].ratio_to(base)[0], 1e300))
    elements = dict(diagnosis.elements)
    for name, result in alone.items():
        ise, movement = result.ratio_to(base)
        elements[name] = replace(elements[name], impact=ImpactResult(ise, movement, ranked.index(name) + 1))
    together = all_changed.ratio_to(base)
    return replace(diagnosis, elements=elements, impact=ImpactResult(*together, rank=0))


def _figures(
    plants: tuple[TransferMatrix, TransferMatrix | None],
    *,
    loop: LoopConfig,
    samples: int,
    controller: ControllerSettings | None,
) -> LoopFigures:
    """:func:`loop_figures` on ``(plant, disturbance_plant)``: one of :func:`control_impact`'s simulations."""
    plant, dv_plant = plants
    return loop_figures(loop, plant, samples=samples, controller=controller, disturbance_plant=dv_plant)
