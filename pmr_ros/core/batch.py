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
  each on its own :class:`~pmr_ros.core.mpc.LinearMpc` (own warm-start state),
  exactly as :func:`~pmr_ros.core.closed_loop.simulate` would.

Noise and setpoints come from the same streams as ``simulate``
(:func:`~pmr_ros.core.plant.noise_generator`, :class:`PrbsGenerator`), so a run
here equals the ``simulate`` run of the same scenario and seed up to
floating-point summation order (tested to 1e-9).
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .closed_loop import LoopConfig, RunRecord
from .foptd import SCENARIOS
from .mpc import LinearMpc, MpcStatistics
from .plant import noise_generator
from .prbs import PrbsGenerator


@dataclass(frozen=True)
class LockstepResult:
    """Records and controller statistics of a lockstep batch, in run order.

    Attributes
    ----------
    records : list of RunRecord
        ``r, u, y`` of each run.
    statistics : list of MpcStatistics
        Steps, OSQP solves and OSQP failures of each run's controller.
    """

    records: list[RunRecord]
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
    """Runs whose plants have the same state size, stacked for batched stepping."""

    runs: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    x: np.ndarray


def _plant_groups(spaces: list) -> list[_PlantGroup]:
    sizes = sorted({ss.A.shape[0] for ss in spaces})
    groups = []
    for nx in sizes:
        idx = np.array([j for j, ss in enumerate(spaces) if ss.A.shape[0] == nx])
        groups.append(
            _PlantGroup(
                runs=idx,
                A=np.stack([spaces[j].A for j in idx]),
                B=np.stack([spaces[j].B for j in idx]),
                C=np.stack([spaces[j].C for j in idx]),
                x=np.zeros((idx.size, nx)),
            )
        )
    return groups


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
    """
    runs = _check_runs(runs)
    samples = config.run.samples if samples is None else int(samples)
    if samples <= 0:
        raise ValueError(f"samples must be > 0, got {samples}")
    if not runs:
        return LockstepResult([], [])
    model = config.model
    n_out, n_in = model.n_outputs, model.n_inputs
    n_runs = len(runs)

    # Plants grouped by state size (stacked, not padded: see _mv on why the arithmetic must match).
    groups = _plant_groups([config.plant(scenario).state_space() for scenario, _ in runs])

    noise_std = np.broadcast_to(np.asarray(config.noise_std, dtype=float), (n_out,))
    # One draw of the whole stream equals ``samples`` draws of n_out (numpy Generator).
    noise = np.stack([noise_generator(seed).standard_normal((samples, n_out)) for _, seed in runs], axis=1)
    setpoints = np.stack([PrbsGenerator(config.prbs, seed).sequence(samples) for _, seed in runs], axis=1)

    # One controller per run: they hold each run's OSQP warm start and statistics.
    controllers = [LinearMpc(model, config.mpc) for _ in runs]
    mats = controllers[0].matrices
    Np, Nc = config.mpc.prediction_horizon, config.mpc.control_horizon
    neg_gradient = -mats.weighted_dynamic  # LinearMpc computes q = (-Theta'Q) @ (target - free)
    du_bound, u_min_path, u_max_path = mats.du_bound, mats.u_min_path, mats.u_max_path
    du_first = du_bound[:n_in]
    u_min, u_max = np.asarray(config.mpc.u_min, dtype=float), np.asarray(config.mpc.u_max, dtype=float)

    xm = np.zeros((n_runs, mats.A.shape[0]))
    u_prev = np.zeros((n_runs, n_in))
    y = np.empty((n_runs, n_out))
    y_rec = np.empty((samples, n_runs, n_out))
    u_rec = np.empty((samples, n_runs, n_in))
    for k in range(samples):
        for group in groups:
            y[group.runs] = _mv(group.C, group.x) + noise_std * noise[k, group.runs]
        y_rec[k] = y
        # LinearMpc.step, for every run at once and in the same floating-point operations.
        bias = y - _mv(mats.C, xm)
        target = np.tile(setpoints[k] - bias, (1, Np))
        free = _mv(mats.free_state, xm) + _mv(mats.free_input, u_prev)
        q = _mv(neg_gradient, target - free)
        u_rep = np.tile(u_prev, (1, Nc))
        moves = _mv(mats.unconstrained_gain, q)
        u_path = u_rep + _mv(mats.cumulative, moves)
        feasible = np.all(np.abs(moves) <= du_bound, axis=1) & np.all(
            (u_path >= u_min_path) & (u_path <= u_max_path), axis=1
        )
        move = moves[:, :n_in].copy()
        for j in np.flatnonzero(~feasible):
            lower = np.concatenate([u_min_path - u_rep[j], -du_bound])
            upper = np.concatenate([u_max_path - u_rep[j], du_bound])
            # The run's own controller and solver, so warm starts and counters match simulate().
            move[j] = controllers[j]._solve_constrained(q[j].copy(), lower, upper)
        u = np.clip(u_prev + np.clip(move, -du_first, du_first), u_min, u_max)
        u_rec[k] = u
        xm = _mv(mats.A, xm) + _mv(mats.B, u)
        u_prev = u
        for group in groups:
            group.x = _mv(group.A, group.x) + _mv(group.B, u[group.runs])

    for c in controllers:
        c.statistics.steps += samples
    records = [
        RunRecord(
            np.ascontiguousarray(setpoints[:, j]), np.ascontiguousarray(u_rec[:, j]), np.ascontiguousarray(y_rec[:, j])
        )
        for j in range(n_runs)
    ]
    return LockstepResult(records, [c.statistics for c in controllers])


def simulate_many(config: LoopConfig, runs: Sequence[tuple[str, int]], samples: int | None = None) -> list[RunRecord]:
    """The records of :func:`run_lockstep` (one per ``(scenario, seed)`` in ``runs``)."""
    return run_lockstep(config, runs, samples).records


def worker_context() -> multiprocessing.context.BaseContext:
    """The multiprocessing context for pools of batch runs: ``forkserver``.

    A plain fork copies a process that may already hold ROS 2 middleware
    threads (a node set run in the same process, as in the test suite or a
    shell that also diagnoses); such a child can crash in C++ code it
    inherited mid-operation.  Workers from a fork server start from a clean
    process instead.
    """
    return multiprocessing.get_context("forkserver")
