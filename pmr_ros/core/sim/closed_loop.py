"""Batch closed-loop simulation: PRBS setpoints, constrained MPC on Ghat, plant G."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..mpc.controller import LinearMpc, MpcTuning
from ..records import Record
from .excitation import ExcitationSettings, PrbsGenerator, PrbsSettings, dither_generator
from .model import TransferMatrix
from .true_plant import FoptdPlant, OutputDisturbance

__all__ = ["LoopConfig", "RunPlan", "simulate"]


class RunPlan(Protocol):
    """The run settings a simulation reads (``pmr_ros.config.RunSettings`` is one).

    Members are read-only properties, so frozen dataclasses satisfy the protocol.
    """

    @property
    def samples(self) -> int:
        """Samples to run."""
        ...

    @property
    def seed(self) -> int:
        """Seed of the noise and PRBS generators."""
        ...

    @property
    def scenario(self) -> str:
        """Mismatch scenario of the plant."""
        ...


class LoopConfig(Protocol):
    """What a closed-loop simulation needs; :class:`pmr_ros.config.PmrConfig` is one.

    The core names only this shape, so it never depends on how a
    configuration is read.  Members are read-only properties, so frozen
    dataclasses satisfy the protocol.
    """

    @property
    def model(self) -> TransferMatrix:
        """The controller's model Ghat."""
        ...

    @property
    def noise_std(self) -> np.ndarray:
        """Standard deviation of the measurement noise per output."""
        ...

    @property
    def disturbance(self) -> OutputDisturbance:
        """The unmeasured coloured output disturbance (inactive: none)."""
        ...

    @property
    def prbs(self) -> PrbsSettings:
        """Setpoint excitation."""
        ...

    @property
    def excitation(self) -> ExcitationSettings:
        """MV dither."""
        ...

    @property
    def mpc(self) -> MpcTuning:
        """Controller tuning."""
        ...

    @property
    def run(self) -> RunPlan:
        """Length, seed and scenario of the run."""
        ...

    def plant(self, scenario: str | None = None) -> TransferMatrix:
        """The true plant under ``scenario``."""
        ...


def simulate(
    config: LoopConfig, samples: int | None = None, seed: int | None = None, scenario: str | None = None
) -> Record:
    """Run the closed loop in batch.

    At each sample k: the setpoint r(k) is read, the plant is measured (y(k)),
    the MPC computes u(k) from y(k) and r(k) (plus the MV dither, if any),
    and the plant is advanced with u(k).  The ROS node set follows the same
    order, so both give the same data.

    Parameters
    ----------
    config : LoopConfig
    samples, seed, scenario : optional
        Override ``config.run``.
    """
    samples = config.run.samples if samples is None else samples
    seed = config.run.seed if seed is None else seed
    plant = FoptdPlant(config.plant(scenario), config.noise_std, seed, disturbance=config.disturbance)
    controller = LinearMpc(config.model, config.mpc)
    r = PrbsGenerator(config.prbs, seed).sequence(samples)
    d = dither_generator(config.excitation, config.prbs, seed).sequence(samples) if config.excitation.active else None
    u = np.empty((samples, config.model.n_inputs))
    y = np.empty((samples, config.model.n_outputs))
    for k in range(samples):
        y[k] = plant.measure()
        u[k] = controller.step(y[k], r[k], dither=None if d is None else d[k])
        plant.advance(u[k])
    return Record(r, u, y, d)
