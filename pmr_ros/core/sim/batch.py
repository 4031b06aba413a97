"""Lockstep batch simulation: many closed-loop runs that share one controller model.

A parameter study runs the same MPC (same model ``Ghat`` and tuning) against
several plants (mismatch scenarios) and seeds.  Stepping each run on its own
costs one Python-level MPC step per sample and run; here all runs advance
together, one sample at a time, with batched numpy:

* the plants are stacked (each run its own ``A, B, C``, zero-padded to the
  largest state), so one batched matmul advances all of them;
* the MPC's unconstrained step is the same linear map for every run, so it is
  one matrix product over the batch;
* only the runs whose unconstrained optimum would violate a limit call OSQP,
  each on its own :class:`~pmr_ros.core.mpc.controller.LinearMpc` (own warm-start state),
  exactly as :func:`~pmr_ros.core.sim.closed_loop.simulate` would.

Routine operation (measured disturbances, CV zones, setpoint steps, manual
stretches: :func:`~pmr_ros.core.sim.closed_loop.routine_features`) is not
batched: a configuration with any of them runs run by run with
:func:`~pmr_ros.core.sim.closed_loop.simulate` (the same numbers, one run at a
time).

Noise, output disturbance and setpoints come from the same streams as ``simulate``
(:func:`~pmr_ros.core.sim.true_plant.noise_generator`, :class:`~pmr_ros.core.sim.true_plant.DisturbanceStream`,
:class:`PrbsGenerator`), so a run
here equals the ``simulate`` run of the same scenario and seed up to
floating-point summation order (tested to 1e-9).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..mpc.controller import LinearMpc, MpcStatistics, MpcTuning
from ..records import Record
from .closed_loop import LoopConfig, routine_features, simulate_with_statistics
from .excitation import PrbsGenerator, dither_generator
from .model import SCENARIOS, StateSpace, TransferMatrix
from .true_plant import DisturbanceStream, noise_generator

__all__ = ["LockstepResult", "run_lockstep", "simulate_many"]


@dataclass(frozen=True)
class LockstepResult:
    """Records and controller statistics of a lockstep batch, in run order.

    Attributes
    ----------
    records : list of Record
        ``r, u, y`` of each run.
    statistics : list of MpcStatistics
        Steps, OSQP solves and OSQP failures of each run's controller.
    """

    records: list[Record]
    statistics: list[MpcStatistics]


def _check_runs(runs: Sequence[tuple[str, int]]) -> list[tuple[str, int]]:
    out = []
    for run in runs:
        scenario, seed = run
        if scenario not in SCENARIOS:
            raise ValueError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}")
        if int(seed) != seed or seed < 0:
            raise ValueError(f"seed must be a whole number >= 0, got {seed!r}")
        out.append((scenario, int(seed)))
    return out


def _mv(matrix: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``matrix @ v`` for each row ``v`` of ``vectors`` (matrix shared or stacked per row).

    A stacked matmul makes numpy call BLAS gemv once per row, the same kernel
    (same summation order) as ``matrix @ v`` on one vector in ``simulate``.
    ``vectors @ matrix.T`` would call gemm, whose different rounding (1e-16)
    is enough to change OSQP's iterates and, through the closed loop, the
    record by up to 1e-3: the constrained loop is that sensitive.
    """
    return np.matmul(matrix, vectors[:, :, None])[:, :, 0]


@dataclass
class _PlantGroup:
    """Runs whose plants have the same state size, stacked for batched stepping.

    Each state is advanced as in :meth:`StateSpace.advance` (its pole and its one
    source, per run), elementwise, so the numbers equal the plant's own.
    """

    runs: np.ndarray
    pole: np.ndarray
    source: np.ndarray
    weight: np.ndarray
    C: np.ndarray
    x: np.ndarray
    rows: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        # each run's row for every state: indexing with it is np.take_along_axis(..., axis=1), without its overhead
        self.rows = np.arange(self.source.shape[0])[:, None]

    def advance(self, u: np.ndarray) -> None:
        """Hold each run's input ``u`` (rows: the group's runs) for one sample."""
        feed = np.concatenate((self.x, u), axis=1)[self.rows, self.source]
        self.x = self.pole * self.x + self.weight * feed


@dataclass
class _GeneralPlant:
    """One run whose plant has elements of higher order (states of several sources): its own sparse steps."""

    runs: np.ndarray
    space: StateSpace
    C: np.ndarray
    x: np.ndarray

    def advance(self, u: np.ndarray) -> None:
        """Hold the run's input ``u`` (one row) for one sample."""
        self.x = self.space.advance(self.x, u)


def _plant_groups(spaces: list[StateSpace]) -> list[_PlantGroup | _GeneralPlant]:
    groups: list[_PlantGroup | _GeneralPlant] = [
        _GeneralPlant(np.array([j]), ss, ss.C[None], np.zeros((1, ss.A.shape[0])))
        for j, ss in enumerate(spaces)
        if not ss.one_source
    ]
    sizes = sorted({ss.A.shape[0] for ss in spaces if ss.one_source})
    for nx in sizes:
        idx = np.array([j for j, ss in enumerate(spaces) if ss.A.shape[0] == nx and ss.one_source])
        pole, source, weight = (
            np.stack(parts) for parts in zip(*(spaces[j].one_source_form for j in idx), strict=True)
        )
        groups.append(
            _PlantGroup(
                runs=idx,
                pole=pole,
                source=source,
                weight=weight,
                C=np.stack([spaces[j].C for j in idx]),
                x=np.zeros((idx.size, nx)),
            )
        )
    return groups


class _BatchMpc:
    """:meth:`LinearMpc.step` for every run at once, in the same floating-point operations.

    One controller per run holds that run's OSQP warm start and statistics;
    the disturbance estimate and the unconstrained step, the same for every
    run, are batched; limits and clipping are the controller's own methods.
    """

    def __init__(self, model: TransferMatrix, tuning: MpcTuning, n_runs: int) -> None:
        self.controllers = [LinearMpc(model, tuning) for _ in range(n_runs)]
        self.first = self.controllers[0]
        self.mats = self.first.matrices
        self.n_in = model.n_inputs
        self.x = np.zeros((n_runs, self.mats.A.shape[0]))
        self.u_prev = np.zeros((n_runs, self.n_in))
        self.step_estimate = np.zeros((n_runs, model.n_outputs))
        self.slope = np.zeros((n_runs, self.first.estimator.n_ramps))

    def step(self, y: np.ndarray, setpoint: np.ndarray, dither: np.ndarray | None) -> np.ndarray:
        """``u(k)`` of every run from ``y(k)``, ``r(k)`` and the dither (rows: runs); advances the models."""
        mats, first = self.mats, self.first
        residual = y - _mv(mats.C, self.x)
        self.step_estimate, self.slope = first.estimator.update(residual, self.step_estimate, self.slope)
        z = np.concatenate((self.x, self.u_prev, setpoint, self.step_estimate, self.slope), axis=1)
        moves = _mv(mats.gain, z) + mats.gain_offset
        feasible = first.within_limits(moves, self.u_prev)
        move = moves[:, : self.n_in].copy()
        for j in np.flatnonzero(~feasible):
            lower, upper = first.move_bounds(self.u_prev[j])
            q = mats.gradient @ z[j] + mats.gradient_offset
            # The run's own controller and solver, so warm starts and counters match simulate().
            move[j] = self.controllers[j].solve_constrained(q, lower=lower, upper=upper)
        u, applied = first.apply_move(self.u_prev, move, dither)
        self.x = first.advance_model(self.x, applied)
        self.u_prev = u
        return applied


def _streams(
    config: LoopConfig, runs: Sequence[tuple[str, int]], samples: int
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray | None]:
    """Every run's noise, disturbance, setpoints and dither, shape (samples, runs, channels); None when inactive."""
    n_out = config.model.n_outputs
    # One draw of the whole stream equals ``samples`` draws of n_out (numpy Generator).
    noise = np.stack([noise_generator(seed).standard_normal((samples, n_out)) for _, seed in runs], axis=1)
    disturbance = None
    if config.disturbance.active:
        streams = [DisturbanceStream(config.disturbance, n_out, seed) for _, seed in runs]
        disturbance = np.stack([stream.sequence(samples) for stream in streams], axis=1)
    setpoints = np.stack([PrbsGenerator(config.prbs, seed).sequence(samples) for _, seed in runs], axis=1)
    dither = None
    if config.excitation.active:
        generators = [dither_generator(config.excitation, config.prbs, seed) for _, seed in runs]
        dither = np.stack([g.sequence(samples) for g in generators], axis=1)
    return noise, disturbance, setpoints, dither


def run_lockstep(config: LoopConfig, runs: Sequence[tuple[str, int]], samples: int | None = None) -> LockstepResult:
    """Simulate ``runs`` closed loops that share ``config.model`` and ``config.mpc``.

    Parameters
    ----------
    config : LoopConfig
        Controller model ``Ghat``, MPC tuning, mismatch, noise and PRBS.
    runs : sequence of (scenario, seed)
        The plant of each run is ``config.plant(scenario)``; ``seed`` picks its
        noise stream and PRBS phases, as in ``simulate``.
    samples : int, optional
        Closed-loop samples per run (default ``config.run.samples``).

    Returns
    -------
    LockstepResult
        With routine-operation features (DVs, zones, setpoint steps, manual stretches): ``simulate``'s, run by run.
    """
    runs = _check_runs(runs)
    samples = config.run.samples if samples is None else int(samples)
    if samples <= 0:
        raise ValueError(f"samples must be > 0, got {samples}")
    if not runs:
        return LockstepResult([], [])
    if routine_features(config):  # not batched: run by run, as simulate() does
        done = [simulate_with_statistics(config, samples, seed, scenario) for scenario, seed in runs]
        return LockstepResult([record for record, _ in done], [statistics for _, statistics in done])
    n_out, n_runs = config.model.n_outputs, len(runs)
    # Plants grouped by state size (stacked, not padded: see _mv on why the arithmetic must match).
    groups = _plant_groups([config.plant(scenario).state_space() for scenario, _ in runs])
    noise_std = np.broadcast_to(np.asarray(config.noise_std, dtype=float), (n_out,))
    noise, disturbance, setpoints, dither = _streams(config, runs, samples)
    mpc = _BatchMpc(config.model, config.mpc, n_runs)
    y = np.empty((n_runs, n_out))
    y_rec = np.empty((samples, n_runs, n_out))
    u_rec = np.empty((samples, n_runs, config.model.n_inputs))
    for k in range(samples):
        for group in groups:
            y[group.runs] = _mv(group.C, group.x) + noise_std * noise[k, group.runs]
            if disturbance is not None:
                y[group.runs] = y[group.runs] + disturbance[k, group.runs]
        y_rec[k] = y
        u = u_rec[k] = mpc.step(y, setpoints[k], None if dither is None else dither[k])
        for group in groups:
            group.advance(u[group.runs])
    for c in mpc.controllers:
        c.statistics.steps += samples
    records = [
        Record(
            np.ascontiguousarray(setpoints[:, j]),
            np.ascontiguousarray(u_rec[:, j]),
            np.ascontiguousarray(y_rec[:, j]),
            None if dither is None else np.ascontiguousarray(dither[:, j]),
        )
        for j in range(n_runs)
    ]
    return LockstepResult(records, [c.statistics for c in mpc.controllers])


def simulate_many(config: LoopConfig, runs: Sequence[tuple[str, int]], samples: int | None = None) -> list[Record]:
    """The records of :func:`run_lockstep` (one per ``(scenario, seed)`` in ``runs``)."""
    return run_lockstep(config, runs, samples).records
