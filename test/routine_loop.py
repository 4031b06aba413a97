"""A small closed loop of routine operation for the diagnosis tests: constant setpoints, dither, DVs, manual moves.

The configured Wood-Berry MPC (:class:`~pmr_ros.core.mpc.controller.LinearMpc` on
the model) runs a plant ``[G, Gd]`` whose last inputs are measured
disturbances moving as random steps; MVs may be dithered (a random binary
signal held a few samples) and put in manual (the operator sets ``u`` by random
steps; the controller tracks the operator's value, as an MPC does with an MV
out of service, so it resumes without a bump).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pmr_ros.config import PmrConfig
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.records import Record
from pmr_ros.core.sim.augment import augmented_model
from pmr_ros.core.sim.model import TransferMatrix


@dataclass(frozen=True)
class Routine:
    """What moves in a routine run.

    Attributes
    ----------
    dither : ndarray, shape (n_inputs,)
        Amplitude of each MV's dither (0: none) [input unit].
    dv_amplitude : float
        Size of the DVs' random steps [DV unit].
    manual : tuple of (start, length, mv)
        Manual stretches: the operator moves MV ``mv`` by random steps.
    manual_amplitude : float
        Size of the operator's steps [input unit].
    setpoint_steps : float
        Size of rare setpoint steps (0: constant setpoints) [output unit].
    """

    dither: np.ndarray
    dv_amplitude: float = 0.0
    manual: tuple[tuple[int, int, int], ...] = ()
    manual_amplitude: float = 0.0
    setpoint_steps: float = 0.0


def _held_steps(rng: np.random.Generator, samples: int, columns: int, mean_hold: float) -> np.ndarray:
    """Random levels N(0, 1) held for exponential intervals of ``mean_hold`` samples."""
    out = np.empty((samples, columns))
    for c in range(columns):
        k = 0
        while k < samples:
            hold = max(1, int(rng.exponential(mean_hold)))
            out[k : k + hold, c] = rng.standard_normal()
            k += hold
    return out


def _binary(rng: np.random.Generator, samples: int, columns: int, hold: int) -> np.ndarray:
    """A random binary signal +/-1 that may switch every ``hold`` samples."""
    levels = rng.choice([-1.0, 1.0], size=(samples // hold + 1, columns))
    return np.repeat(levels, hold, axis=0)[:samples]


def routine_run(
    config: PmrConfig,
    plant: TransferMatrix,
    routine: Routine,
    *,
    samples: int,
    seed: int,
    disturbances: TransferMatrix | None = None,
) -> Record:
    """Run the configured MPC on ``[plant, disturbances]`` under ``routine``; the record with dv and manual."""
    rng = np.random.default_rng(seed)
    n_out, n_in = plant.n_outputs, plant.n_inputs
    truth = augmented_model(plant, disturbances).state_space()
    n_dv = 0 if disturbances is None else disturbances.n_inputs
    dv = routine.dv_amplitude * _held_steps(rng, samples, n_dv, 60.0)
    d = routine.dither * _binary(rng, samples, n_in, 8)
    r = (
        routine.setpoint_steps * _held_steps(rng, samples, n_out, 500.0)
        if routine.setpoint_steps
        else np.zeros((samples, n_out))
    )
    manual = np.zeros((samples, n_in), dtype=bool)
    operator = np.zeros((samples, n_in))
    for start, length, mv in routine.manual:
        manual[start : start + length, mv] = True
        operator[start : start + length, mv] = routine.manual_amplitude * _held_steps(rng, length, 1, 30.0)[:, 0]
    controller = LinearMpc(config.model, config.mpc)
    noise = rng.standard_normal((samples, n_out)) * np.asarray(config.noise_std)
    x = np.zeros(truth.A.shape[0])
    u = np.empty((samples, n_in))
    y = np.empty((samples, n_out))
    for k in range(samples):
        y[k] = truth.C @ x + noise[k]
        before = controller._x.copy()
        u[k] = controller.step(y[k], r[k], dither=d[k])
        if manual[k].any():
            # tracking: the controller's last move and its model follow the input the plant got (test-only access)
            u[k] = np.where(manual[k], operator[k], u[k])
            controller._u_prev = np.where(manual[k], operator[k], controller._u_prev)
            controller._x = controller.advance_model(before, u[k])
        x = truth.advance(x, np.concatenate([u[k], dv[k]]))
    return Record(r, u, y, dither=d, dv=dv if n_dv else None, manual=manual if routine.manual else None)
