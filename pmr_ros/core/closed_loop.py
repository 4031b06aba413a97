"""Batch closed-loop simulation: PRBS setpoints, constrained MPC on Ghat, plant G."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .foptd import FoptdMatrix
from .mpc import LinearMpc, MpcTuning
from .plant import FoptdPlant
from .prbs import PrbsGenerator, PrbsSettings


class RunPlan(Protocol):
    """The run settings a simulation reads (``pmr_ros.config.RunSettings`` is one)."""

    samples: int
    seed: int
    scenario: str


class LoopConfig(Protocol):
    """What a closed-loop simulation needs; :class:`pmr_ros.config.PmrConfig` is one.

    The core names only this shape, so it never depends on how a
    configuration is read.
    """

    model: FoptdMatrix
    noise_std: np.ndarray
    prbs: PrbsSettings
    mpc: MpcTuning
    run: RunPlan

    def plant(self, scenario: str | None = None) -> FoptdMatrix:
        """The true plant under ``scenario``."""
        ...


@dataclass(frozen=True)
class RunRecord:
    """Sampled signals of a closed-loop run, row k = sample k.

    Attributes
    ----------
    r : ndarray, shape (N, n_outputs)
        Setpoints [output unit].
    u : ndarray, shape (N, n_inputs)
        Inputs applied over sample k [input unit].
    y : ndarray, shape (N, n_outputs)
        Measured outputs at sample k [output unit].
    """

    r: np.ndarray
    u: np.ndarray
    y: np.ndarray

    @property
    def samples(self) -> int:
        """Samples in the record."""
        return self.r.shape[0]


def simulate(
    config: LoopConfig, samples: int | None = None, seed: int | None = None, scenario: str | None = None
) -> RunRecord:
    """Run the closed loop in batch.

    At each sample k: the setpoint r(k) is read, the plant is measured (y(k)),
    the MPC computes u(k) from y(k) and r(k), and the plant is advanced with
    u(k).  The ROS node set follows the same order, so both give the same data.

    Parameters
    ----------
    config : LoopConfig
    samples, seed, scenario : optional
        Override ``config.run``.
    """
    samples = config.run.samples if samples is None else samples
    seed = config.run.seed if seed is None else seed
    plant = FoptdPlant(config.plant(scenario), config.noise_std, seed)
    controller = LinearMpc(config.model, config.mpc)
    prbs = PrbsGenerator(config.prbs, seed)
    r = prbs.sequence(samples)
    u = np.empty((samples, config.model.n_inputs))
    y = np.empty((samples, config.model.n_outputs))
    for k in range(samples):
        y[k] = plant.measure()
        u[k] = controller.step(y[k], r[k])
        plant.advance(u[k])
    return RunRecord(r, u, y)
