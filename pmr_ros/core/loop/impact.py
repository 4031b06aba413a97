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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

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

__all__ = ["ImpactSettings", "LoopFigures", "control_impact", "loop_figures", "pi_figures"]

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
    """A :class:`LoopConfig` of the configured controller on a given plant, noise-free."""

    model: TransferMatrix
    noise_std: np.ndarray
    prbs: PrbsSettings
    excitation: ExcitationSettings
    mpc: MpcTuning
    run: RunPlan
    truth: TransferMatrix

    @property
    def disturbance(self) -> OutputDisturbance:
        """None: the loop is noise-free."""
        return OutputDisturbance.off(self.model.n_outputs)

    @property
    def disturbance_model(self) -> TransferMatrix | None:
        """None: the measured disturbances do not move in the impact's simulation."""
        return None

    @property
    def disturbance_signal(self) -> DisturbanceSignalSettings:
        """None moves."""
        return DisturbanceSignalSettings()

    @property
    def manual(self) -> ManualSettings:
        """No manual stretch: every controller on."""
        return ManualSettings()

    def plant(self, scenario: str | None = None) -> TransferMatrix:
        return self.truth

    def disturbance_plant(self, scenario: str | None = None) -> TransferMatrix | None:
        return None


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


def loop_figures(
    loop: LoopConfig, plant: TransferMatrix, *, samples: int, controller: ControllerSettings | None = None
) -> LoopFigures:
    """ISE and input movement of the configured loop on ``plant`` (noise-free, from rest).

    Parameters
    ----------
    loop : LoopConfig
        The controller's model, tuning, setpoint excitation (and dither) and seed.
    plant : TransferMatrix
        The plant the controller runs on.
    samples : int
        Closed-loop samples simulated.
    controller : ControllerSettings, optional
        Kind ``pi``: its loops run instead of the MPC (:func:`pi_figures`); default the MPC.
    """
    if controller is not None and controller.kind == "pi" and controller.pi is not None:
        return pi_figures(loop, controller.pi, plant, samples=samples)
    quiet = _Loop(loop.model, np.zeros(loop.model.n_outputs), loop.prbs, loop.excitation, loop.mpc, loop.run, plant)
    with np.errstate(over="ignore", invalid="ignore"):
        record = simulate(quiet, samples=samples)
    if _unstable(record.r, record.y):
        return LoopFigures(math.inf, math.inf)
    error = record.r - record.y
    moves = np.diff(record.u, axis=0, prepend=np.zeros((1, record.u.shape[1])))
    ise = float(np.sum(np.asarray(loop.mpc.output_weight) * error**2))
    movement = float(np.sum(np.asarray(loop.mpc.move_weight) * moves**2))
    return LoopFigures(ise, movement)


def _with_element(model: TransferMatrix, update: ModelUpdate, name: str) -> TransferMatrix:
    change = next(c for c in update.changes if c.name == name)
    i, k = divmod(model.element_names().index(name), model.n_inputs)
    return with_changes(model, [(i, k, change)])


def control_impact(
    diagnosis: Diagnosis,
    *,
    loop: LoopConfig,
    update: ModelUpdate,
    samples: int,
    controller: ControllerSettings | None = None,
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

    Returns
    -------
    Diagnosis
        A new diagnosis: ``ElementDiagnosis.impact`` set on the changed G
        elements (a D element's, the measured disturbances' model, is not
        simulated: these loops run without DVs) (ranked by ISE ratio, 1 = matters most), ``Diagnosis.impact``
        for all together; the input diagnosis is left as it is.
    """
    # the MPC acts on G: a D element (a measured disturbance's model) has no place in these loops
    acting = [c for c in update.changes if c.name in loop.model.element_names()]
    if not acting:
        return diagnosis
    base = loop_figures(loop, loop.model, samples=samples, controller=controller)
    alone = {
        c.name: loop_figures(loop, _with_element(loop.model, update, c.name), samples=samples, controller=controller)
        for c in acting
    }
    ranked = sorted(alone, key=lambda name: -min(alone[name].ratio_to(base)[0], 1e300))
    elements = dict(diagnosis.elements)
    for name, figures in alone.items():
        ise, movement = figures.ratio_to(base)
        elements[name] = replace(elements[name], impact=ImpactResult(ise, movement, ranked.index(name) + 1))
    together = loop_figures(loop, update.model, samples=samples, controller=controller).ratio_to(base)
    return replace(diagnosis, elements=elements, impact=ImpactResult(*together, rank=0))
