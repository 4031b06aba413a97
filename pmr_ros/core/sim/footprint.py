"""What a closed-loop run needs before any of it is built: memory for the model, samples for the diagnosis.

The realization (:meth:`~pmr_ros.core.sim.model.TransferMatrix.state_space`) has
one state per element and one shift-register state per sample of each
input's longest delay, and keeps its state matrix dense: a 200x200 model
(40,000 elements) has 41,400 states, a 13.7 GB state matrix per copy; a plant
delay of 10^6 samples a 8 TB one.  The controller adds its prediction
matrices (``Np n_out`` rows over the states and over the ``Nc n_in`` moves)
and its condensed QP.  :func:`model_bytes` bounds the peak from above
(1.4-2x the ``tracemalloc`` peak of building a plant and its MPC, measured on
8x8 to 24x24 models), so a command can refuse in one line instead of being
killed after a minute.

:func:`samples_needed` is the shortest record the diagnosis accepts
(:func:`~pmr_ros.core.pmr.checks.check_stretches`: twice as many Welch segments
as instruments, the external signals that move: :func:`planned_instruments`):
a 64x64 model needs 33,000 samples, known before a 74 s simulation of 16,384
finds it out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..pmr.checks import unbroken_samples_needed
from ..pmr.spectra import WelchSettings
from .memory import simulation_bytes
from .model import TransferMatrix

if TYPE_CHECKING:
    from .closed_loop import LoopConfig

__all__ = [
    "PREDICTION_COPIES",
    "REALIZATION_COPIES",
    "controller_bytes",
    "impact_bytes",
    "model_bytes",
    "planned_instruments",
    "realization_bytes",
    "samples_needed",
    "states",
]

REALIZATION_COPIES = 3
"""Dense ``nx x nx`` arrays alive at once per realization (A, its one-source form's stacked feed, temporaries)."""

PREDICTION_COPIES = 2
"""Copies of the prediction matrices alive at once while the controller is built."""


def states(model: TransferMatrix) -> int:
    """States of the realization: one per element plus each input's longest delay in samples.

    With ``tf`` or ``step_response`` elements, those of :func:`~.realize.realize`
    (:func:`~.realize.state_count`).

    Examples
    --------
    >>> from pmr_ros.config import load_config
    >>> states(load_config().model)  # Wood-Berry: 4 elements, registers of 7 and 3 samples
    14
    """
    if model.has_general:  # realize's states: registers, each element's order, ramp accumulators
        from .realize import state_count

        return state_count(model.element_rows())
    present = model.present
    lengths = np.where(present, model.delay_samples, 0).max(axis=0)
    return int(present.sum()) + int(lengths.sum())


def realization_bytes(model: TransferMatrix) -> int:
    """Peak memory of building and stepping one dense realization of ``model`` [bytes]."""
    nx = states(model)
    return 8 * REALIZATION_COPIES * nx * (nx + model.n_inputs + model.n_outputs)


def controller_bytes(model: TransferMatrix, *, prediction_horizon: int, control_horizon: int) -> int:
    """Peak memory of building the MPC on ``model``: its realization, prediction matrices and QP [bytes]."""
    nx, n_out, n_in = states(model), model.n_outputs, model.n_inputs
    moves = control_horizon * n_in
    rows = prediction_horizon * n_out
    prediction = PREDICTION_COPIES * rows * (nx + n_in + moves)
    qp = 4 * moves * moves + 2 * moves * (nx + 2 * n_in + 3 * n_out)
    return realization_bytes(model) + 8 * (prediction + qp)


def model_bytes(model: TransferMatrix, plant: TransferMatrix, *, prediction_horizon: int, control_horizon: int) -> int:
    """A closed loop's fixed memory: the plant's realization and the controller on the model [bytes]."""
    controller = controller_bytes(model, prediction_horizon=prediction_horizon, control_horizon=control_horizon)
    return realization_bytes(plant) + controller


def impact_bytes(
    model: TransferMatrix, plant: TransferMatrix, *, prediction_horizon: int, control_horizon: int, samples: int
) -> int:
    """One control-impact simulation: the MPC on ``model`` steering ``plant`` for ``samples`` samples [bytes].

    The impact (:mod:`pmr_ros.core.loop.impact`) runs its simulations one
    after the other, so one bounds them all.
    """
    loop = model_bytes(model, plant, prediction_horizon=prediction_horizon, control_horizon=control_horizon)
    return loop + simulation_bytes(model, samples)


def samples_needed(
    model: TransferMatrix, welch: WelchSettings, *, dithered_inputs: int = 0, instruments: int | None = None
) -> int:
    """The fewest unbroken samples the diagnosis of ``model`` accepts with ``welch``'s segments.

    The model's settling, then ``max(4, 2 n_instruments)`` Welch segments: the
    rule of :func:`~pmr_ros.core.pmr.checks.check_stretches` itself
    (:func:`~pmr_ros.core.pmr.checks.unbroken_samples_needed`).

    Parameters
    ----------
    model : TransferMatrix
    welch : WelchSettings
    dithered_inputs : int
        Inputs whose MV dither joins the setpoints as instruments (without ``instruments``).
    instruments : int, optional
        The external signals that move in the run (:func:`planned_instruments`);
        default: every setpoint and the dithered inputs.
    """
    if instruments is None:
        instruments = model.n_outputs + int(dithered_inputs)
    return unbroken_samples_needed(model, welch, instruments=int(instruments))


def planned_instruments(config: LoopConfig) -> int:
    """The instruments a simulated run of ``config`` will have: the external signals that move in it.

    The setpoints the setpoint generator moves (a zone CV's stays at nominal;
    an amplitude of 0 moves nothing), the dithered MVs, the DVs that move
    (with a DV model) and the MVs put in manual (``run.manual_stretches``):
    what :func:`~pmr_ros.core.records.moving_instruments` will count in the record.
    """
    prbs, n_out = config.prbs, config.model.n_outputs
    size = prbs.amplitude if prbs.mode == "prbs" or prbs.step_amplitude is None else prbs.step_amplitude
    zone = np.asarray(config.mpc.zone_outputs, dtype=bool)
    zone = zone if zone.size == n_out else np.zeros(n_out, dtype=bool)
    setpoints = int(np.sum((np.broadcast_to(np.asarray(size, dtype=float), (n_out,)) > 0) & ~zone))
    dithered = int(np.sum(np.asarray(config.excitation.mv_dither_amplitude, dtype=float) > 0))
    moving_dvs = 0
    if config.disturbance_model is not None:
        moving_dvs = int(np.sum(np.asarray(config.disturbance_signal.amplitude, dtype=float) > 0))
    manual = len({mv for _, length, mv in config.manual.stretches if length > 0})
    return setpoints + dithered + moving_dvs + manual
