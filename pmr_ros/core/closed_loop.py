"""Batch closed-loop simulation: PRBS setpoints, constrained MPC on Ghat, plant G."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .model import TransferMatrix
from .mpc import LinearMpc, MpcTuning
from .plant import FoptdPlant, OutputDisturbance
from .prbs import ExcitationSettings, PrbsGenerator, PrbsSettings, dither_generator


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
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs (``u`` includes it);
        None when the loop had none.
    """

    r: np.ndarray
    u: np.ndarray
    y: np.ndarray
    dither: np.ndarray | None = None

    @property
    def samples(self) -> int:
        """Samples in the record."""
        return self.r.shape[0]


def simulate(
    config: LoopConfig, samples: int | None = None, seed: int | None = None, scenario: str | None = None
) -> RunRecord:
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
    return RunRecord(r, u, y, d)
