"""Keep the MPC stable while a time constant grows.

The configured Wood-Berry MPC (Np = 40, Nc = 8) is stable up to about
nu = 3 of the G11 sweep; beyond, its unconstrained loop has a pole outside the
unit circle even without mismatch (the horizon no longer covers the slow
element's response) and the constrained loop ends in a saturated limit cycle.
So for each nu the prediction horizon is lengthened, in steps, until the loop
of every scenario is stable with margin; the weights and the control horizon
stay as configured.  At nu = 1 the configured tuning is kept, so the baseline
equals a plain ``pmr-ros run``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ..core.mpc import stability as mpc_stability
from ..core.mpc.controller import LinearMpc, MpcTuning
from ..core.sim.model import TransferMatrix

STABILITY_LIMIT = 0.999
"""Largest accepted closed-loop spectral radius: the slowest mode decays (1/e) within
1000 samples, well inside a record; slow but stable modes are the plant's own business."""

HORIZON_STEP = 10
"""Samples added to the prediction horizon per search step."""


def loop_spectral_radius(
    model: TransferMatrix, plant: TransferMatrix, tuning: MpcTuning, controller: LinearMpc | None = None
) -> float:
    """Spectral radius of the unconstrained closed loop of the MPC on ``model`` and ``plant``.

    With no limit active the MPC is linear in (plant state, model state,
    previous input, disturbance estimates); the loop is stable iff every
    eigenvalue of the joint state matrix that shows in u and y lies inside
    the unit circle (:func:`pmr_ros.core.mpc.stability.loop_spectral_radius`).

    Parameters
    ----------
    model : TransferMatrix
        The controller's model ``Ghat``.
    plant : TransferMatrix
        The true plant ``G``.
    tuning : MpcTuning
    controller : LinearMpc, optional
        A controller already built for ``model`` and ``tuning`` (saves the build).

    Returns
    -------
    float
        Largest eigenvalue magnitude [-]; < 1 means stable.
    """
    return mpc_stability.loop_spectral_radius(controller or LinearMpc(model, tuning), plant)


@dataclass(frozen=True)
class StableTuning:
    """The tuning chosen for one sweep point.

    Attributes
    ----------
    tuning : MpcTuning
    spectral_radius : float
        Worst (over the plants) unconstrained closed-loop spectral radius.
    stable : bool
        ``spectral_radius < STABILITY_LIMIT``; False when no horizon up to the
        search limit reached it (the least unstable one is returned).
    """

    tuning: MpcTuning
    spectral_radius: float
    stable: bool


def stable_tuning(
    model: TransferMatrix, plants: list[TransferMatrix], tuning: MpcTuning, limit: float = STABILITY_LIMIT
) -> StableTuning:
    """The configured tuning with the shortest prediction horizon that keeps every loop stable.

    Tries ``Np, Np + 10, Np + 20, ...`` up to about four times the slowest
    time constant plus the largest delay (a step response's settling time).

    Parameters
    ----------
    model : TransferMatrix
        The controller's model.
    plants : list of TransferMatrix
        The plants the controller must stabilise (one per mismatch scenario).
    tuning : MpcTuning
        The configured tuning; only ``prediction_horizon`` changes.
    limit : float
        Largest accepted spectral radius.
    """
    settle = int(math.ceil(4.0 * model.slowest_time_constant / model.sample_time)) + int(model.delay_samples.max())
    # a tf or step_response element has no time constant: its own settling to exp(-4), as 4 tau of a FOPTD one
    settle = max([settle, *(e.settle_samples(math.exp(-4.0)) for row in model.general for e in row if e)])
    best: StableTuning | None = None
    horizon = tuning.prediction_horizon
    while True:
        candidate = replace(tuning, prediction_horizon=horizon)
        controller = LinearMpc(model, candidate)
        radius = max(loop_spectral_radius(model, plant, candidate, controller) for plant in plants)
        if best is None or radius < best.spectral_radius:
            best = StableTuning(candidate, radius, radius < limit)
        if radius < limit or horizon >= max(settle, tuning.prediction_horizon):
            return best if radius >= limit else StableTuning(candidate, radius, True)
        horizon += HORIZON_STEP
