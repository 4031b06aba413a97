"""Batch closed-loop simulation: PRBS setpoints, constrained MPC on Ghat, plant G.

And routine operation: measured disturbances moving the plant ``[G, Gd]`` and
fed forward by the MPC, CV zones, operator-like setpoint steps and manual
stretches (:mod:`pmr_ros.core.sim.operation`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..mpc.controller import LinearMpc, MpcStatistics, MpcTuning
from ..records import Record
from .augment import augmented_model
from .excitation import ExcitationSettings, PrbsSettings, dither_generator
from .model import TransferMatrix
from .operation import DisturbanceSignalSettings, ManualOperator, ManualSettings, setpoint_generator
from .true_plant import FoptdPlant, OutputDisturbance

__all__ = ["LoopConfig", "RunPlan", "routine_features", "simulate", "simulate_with_statistics"]


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

    @property
    def disturbance_model(self) -> TransferMatrix | None:
        """The controller's model of the measured disturbances (feedforward), or None."""
        ...

    @property
    def disturbance_signal(self) -> DisturbanceSignalSettings:
        """How the simulated measured disturbances move."""
        ...

    @property
    def manual(self) -> ManualSettings:
        """The manual stretches."""
        ...

    def plant(self, scenario: str | None = None) -> TransferMatrix:
        """The true plant under ``scenario``."""
        ...

    def disturbance_plant(self, scenario: str | None = None) -> TransferMatrix | None:
        """The true measured-disturbance elements under ``scenario``, or None without DVs."""
        ...


def routine_features(config: LoopConfig) -> list[str]:
    """The routine-operation features ``config`` switches on (DVs, zones, setpoint steps, manual stretches).

    :func:`~pmr_ros.core.sim.batch.run_lockstep` runs such a configuration run by run with :func:`simulate`.
    """
    features = []
    if config.disturbance_model is not None:
        features.append("measured disturbances")
    if config.mpc.zones_active:
        features.append("CV zones or limits")
    if config.prbs.mode != "prbs":
        features.append("setpoint steps")
    if config.manual.active:
        features.append("manual stretches")
    return features


def simulate(
    config: LoopConfig, samples: int | None = None, seed: int | None = None, scenario: str | None = None
) -> Record:
    """Run the closed loop in batch.

    At each sample k: the setpoint r(k) and the measured disturbances v(k) are
    read, the plant is measured (y(k)), the MPC computes u(k) from y(k), r(k)
    and v(k) (plus the MV dither, if any; an MV in manual takes the operator's
    value instead), and the plant ``[G, Gd]`` is advanced with ``[u(k); v(k)]``.
    The ROS node set follows the same order, so both give the same data.

    Parameters
    ----------
    config : LoopConfig
    samples, seed, scenario : optional
        Override ``config.run``.

    Returns
    -------
    Record
        ``dv`` with the DVs, ``manual`` with the manual stretches, when there are any.
    """
    return simulate_with_statistics(config, samples, seed, scenario)[0]


def simulate_with_statistics(
    config: LoopConfig, samples: int | None = None, seed: int | None = None, scenario: str | None = None
) -> tuple[Record, MpcStatistics]:
    """:func:`simulate`, and its controller's statistics (steps, QP solves, fallbacks, failures)."""
    samples = config.run.samples if samples is None else samples
    seed = config.run.seed if seed is None else seed
    dv_model = config.disturbance_model
    truth, dv_truth = config.plant(scenario), config.disturbance_plant(scenario) if dv_model is not None else None
    plant = FoptdPlant(
        truth if dv_truth is None else augmented_model(truth, dv_truth),
        config.noise_std,
        seed,
        disturbance=config.disturbance,
    )
    controller = LinearMpc(config.model, config.mpc, disturbance_model=dv_model)
    moving = ~config.mpc.zone_outputs if config.mpc.zone_outputs.size else None
    r = setpoint_generator(config.prbs, seed, moving=moving).sequence(samples)
    d = dither_generator(config.excitation, config.prbs, seed).sequence(samples) if config.excitation.active else None
    v = None if dv_model is None else config.disturbance_signal.generator(seed).sequence(samples)
    operator = manual = None
    if config.manual.active:
        tuning = config.mpc
        operator = ManualOperator(config.manual, config.model.n_inputs, seed, u_min=tuning.u_min, u_max=tuning.u_max)
        manual = np.zeros((samples, config.model.n_inputs), dtype=bool)
        within = min(samples, operator.manual.shape[0])
        manual[:within] = operator.manual[:within]
        if d is not None:
            d = np.where(manual, 0.0, d)  # a controller that is off adds no dither
    u = np.empty((samples, config.model.n_inputs))
    y = np.empty((samples, config.model.n_outputs))
    for k in range(samples):
        y[k] = plant.measure()
        given = None if operator is None else operator.inputs(k, u[k - 1] if k else np.zeros(u.shape[1]))
        vk = None if v is None else v[k]
        u[k] = controller.step(y[k], r[k], dither=None if d is None else d[k], disturbance=vk, manual_input=given)
        plant.advance(u[k] if vk is None else np.concatenate((u[k], vk)))
    return Record(r, u, y, d, dv=v, manual=manual), controller.statistics
