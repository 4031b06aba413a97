"""The typed configuration every part reads: :class:`PmrConfig` and its run, simulation and diagnostician settings.

:func:`pmr_ros.config.build.parse_config` makes one from a parameter tree.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.loop.adaptation import AdaptSettings
from ..core.loop.impact import ImpactSettings
from ..core.loop.pi_loops import ControllerSettings
from ..core.mpc.controller import MpcTuning
from ..core.pmr.classic import PmrSettings
from ..core.pmr.data_quality import QualitySettings
from ..core.pmr.parametric import ParametricSettings
from ..core.sim.excitation import ExcitationSettings, PrbsSettings
from ..core.sim.model import Mismatch, TransferMatrix
from ..core.sim.operation import DisturbanceSignalSettings, ManualSettings
from ..core.sim.true_plant import OutputDisturbance
from .data import DataSettings

__all__ = ["DiagnosticianSettings", "PmrConfig", "RunSettings", "SimulationSettings"]


@dataclass(frozen=True)
class RunSettings:
    """How long and with what seed and scenario the closed loop runs (the ``run`` block)."""

    samples: int
    seed: int
    scenario: str


@dataclass(frozen=True)
class SimulationSettings:
    """How the plant node drives the node set (the ``simulation`` block).

    Attributes
    ----------
    real_time_rate_hz : float
        0: lockstep (the plant steps on u(k)); > 0: wall-clock samples per second.
    wait_for_subscribers : int
        Subscribers of y the plant waits for before sample 0.
    startup_timeout_s : float
        Longest wait for them [s].
    discovery_settle_s : float
        Least time between the plant's start and sample 0, for DDS to discover
        the nodes already running [s].
    max_samples_ahead : int
        Lockstep flow control: how far the plant may run ahead of its slowest
        consumer's reported progress [samples].
    """

    real_time_rate_hz: float
    wait_for_subscribers: int
    startup_timeout_s: float
    discovery_settle_s: float
    max_samples_ahead: int

    @property
    def lockstep(self) -> bool:
        """Whether the plant steps on u(k) instead of a wall-clock timer."""
        return self.real_time_rate_hz == 0


@dataclass(frozen=True)
class DiagnosticianSettings:
    """The diagnostician's rolling window (the ``diagnostician`` block).

    Attributes
    ----------
    window_samples, update_period_samples, min_samples, max_lag_samples : int
        Window, update period, shortest diagnosable stretch and the lag at
        which a signal counts as stopped [samples].
    stale_timeout_s : float
        Silence of a signal after which the verdicts turn STALE [s, wall time].
    publish_period_s : float
        The latest statuses are republished this often [s, wall time].
    """

    window_samples: int
    update_period_samples: int
    min_samples: int
    max_lag_samples: int
    stale_timeout_s: float
    publish_period_s: float


@dataclass(frozen=True)
class PmrConfig:
    """Everything a run needs: the model, the simulated plant and loop, the diagnosis, the nodes.

    Attributes
    ----------
    parameters : dict
        The effective nested parameter tree (file values over declared defaults).
    source : str
        Where it came from (a file, or a node's parameters).
    data : DataSettings
        How a historian export is read and cleaned (``pmr-ros diagnose FILE.csv``).
    adapt : AdaptSettings
        When ``pmr-ros run --adapt`` rolls a model update back.
    explicit_plant : TransferMatrix or None
        The ``plant`` block: the true plant of a simulation, when given.
    disturbance_model : TransferMatrix or None
        The controller's feedforward model of the measured disturbances (DVs),
        n_outputs x n_disturbances, its input names the DV names; None without DVs.
    disturbance_mismatch : Mismatch or None
        The ``mismatch`` block's DV part (``disturbance_gain_pct``, ...); None without DVs.
    explicit_disturbance_plant : TransferMatrix or None
        The ``plant`` block's DV elements, when given.
    disturbance_signal : DisturbanceSignalSettings
        How the simulated DVs move (the ``disturbance_signal`` block).
    manual : ManualSettings
        The simulated manual stretches (``run.manual_stretches``).
    controller : ControllerSettings
        What runs the plant, for the control impact (the ``controller`` block).
    warnings : tuple of str
        Values accepted but worth a word (a time constant an integrating element ignores).
    given : frozenset of str
        The dotted names (``mpc.u_min``) the file or the command line set; the others took their declared defaults.
    """

    model: TransferMatrix
    mismatch: Mismatch
    noise_std: np.ndarray
    disturbance: OutputDisturbance
    prbs: PrbsSettings
    excitation: ExcitationSettings
    mpc: MpcTuning
    pmr: PmrSettings
    parametric: ParametricSettings
    quality: QualitySettings
    run: RunSettings
    simulation: SimulationSettings
    diagnostician: DiagnosticianSettings
    impact: ImpactSettings
    adapt: AdaptSettings
    data: DataSettings
    source: str
    parameters: dict[str, Any]
    explicit_plant: TransferMatrix | None = None
    disturbance_model: TransferMatrix | None = None
    disturbance_mismatch: Mismatch | None = None
    explicit_disturbance_plant: TransferMatrix | None = None
    disturbance_signal: DisturbanceSignalSettings = field(default_factory=DisturbanceSignalSettings)
    manual: ManualSettings = field(default_factory=ManualSettings)
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    warnings: tuple[str, ...] = ()
    given: frozenset[str] = frozenset()

    def plant(self, scenario: str | None = None) -> TransferMatrix:
        """The true plant ``G``: the ``plant`` block if given, else the model under ``scenario``'s mismatch.

        ``scenario`` defaults to the configured one; with a ``plant`` block it does not apply.
        """
        if self.explicit_plant is not None:
            return self.explicit_plant
        return self.model.with_mismatch(self.mismatch.for_scenario(scenario or self.run.scenario))

    def disturbance_plant(self, scenario: str | None = None) -> TransferMatrix | None:
        """The true DV elements ``Gd``: the ``plant`` block's, else the DV model under ``scenario``'s DV mismatch.

        None without DVs.  With a ``plant`` block that gives no DV elements they are the model's.
        """
        if self.explicit_disturbance_plant is not None or self.disturbance_model is None:
            return self.explicit_disturbance_plant
        if self.disturbance_mismatch is None or self.explicit_plant is not None:
            return self.disturbance_model
        return self.disturbance_model.with_mismatch(
            self.disturbance_mismatch.for_scenario(scenario or self.run.scenario)
        )
