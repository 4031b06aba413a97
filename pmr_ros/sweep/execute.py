"""Run a sweep: one lockstep batch per point, points spread over processes.

Each point (an element's time constant at one nu) rebuilds the controller's
model and the plants, picks a stable MPC tuning, simulates every (scenario,
seed) run of the point in lockstep and diagnoses each run with every method.
The main process appends each finished point's rows to the CSV at once, so an
interrupted sweep keeps them and ``resume`` skips the runs already there.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config import PmrConfig
from ..core.pmr.diagnosis import diagnose
from ..core.records import Record
from ..core.results.codec import csv_fields
from ..core.sim.batch import run_lockstep
from ..core.sim.model import TransferMatrix
from ..core.sim.workers import WorkerEnded, completed, worker_count, worker_pool
from ..progress import ProgressBar
from . import store
from .plan import SweepPlan, SweepPoint, row_time_constant_ratio
from .tuning import stable_tuning


def method_fields(
    method: str, record: Record, model: TransferMatrix, config: PmrConfig
) -> tuple[str, dict[str, dict[str, Any]]]:
    """Diagnose one run with ``method``: its status and each element's CSV fields (:func:`csv_fields`)."""
    diagnosis = diagnose(
        record.r,
        record.u,
        record.y,
        model=model,
        pmr=config.pmr,
        parametric=config.parametric,
        method=method,
        dither=record.dither,
    )
    return diagnosis.status, {name: csv_fields(e) for name, e in diagnosis.elements.items()}


@dataclass(frozen=True)
class PointTask:
    """The runs of one sweep point still to do, and what the point's MPC tuning depends on.

    Attributes
    ----------
    point : SweepPoint
    runs : tuple of (str, int)
        The (scenario, seed) runs still to do; after an interruption only some of the plan's.
    methods : tuple of str
        Diagnosis methods applied to every run.
    samples : int
        Closed-loop samples per run [sample].
    scenarios : tuple of str
        Every scenario of the plan.  The MPC tuning is chosen to stabilise the
        plants of all of them, not of ``runs`` only, so a point's tuning (and
        every number of its runs) is the same however the sweep was interrupted.
    """

    point: SweepPoint
    runs: tuple[tuple[str, int], ...]
    methods: tuple[str, ...]
    samples: int
    scenarios: tuple[str, ...]


def run_point(config: PmrConfig, task: PointTask) -> list[dict]:
    """Simulate and diagnose the runs of one sweep point; the CSV rows.

    The swept time constant changes in the controller's model and (through
    ``config.plant``) in every plant; the mismatch applies to the plants only.
    """
    point = task.point
    model = point.model(config.model)
    base = replace(config, model=model)
    chosen = stable_tuning(model, [base.plant(s) for s in task.scenarios], config.mpc)
    point_config = replace(base, mpc=chosen.tuning)
    result = run_lockstep(point_config, task.runs, task.samples)
    names = model.element_names()
    n_in = model.n_inputs
    ratio = row_time_constant_ratio(model, point.row, point.column)
    rows = []
    for (scenario, seed), record, stats in zip(task.runs, result.records, result.statistics, strict=True):
        truth = config.mismatch.for_scenario(scenario)
        common = {
            "sweep": point.sweep,
            "element_swept": point.element,
            "nu": point.nu,
            "time_constant_swept": point.time_constant,
            "row_time_constant_ratio": ratio,
            "scenario": scenario,
            "seed": seed,
            "samples": task.samples,
            "prediction_horizon": chosen.tuning.prediction_horizon,
            "control_horizon": chosen.tuning.control_horizon,
            "loop_spectral_radius": chosen.spectral_radius,
            "mpc_solves": stats.solves,
            "mpc_failures": stats.failures,
            "tracking_rms": float(np.sqrt(np.mean((record.y - record.r) ** 2))),
        }
        for method in task.methods:
            status, numbers = method_fields(method, record, model, point_config)
            for j, name in enumerate(names):
                i, k = divmod(j, n_in)
                rows.append(
                    {
                        **common,
                        "method": method,
                        "element": name,
                        "true_gain_ratio": float(truth.gain_ratio[i, k]),
                        "true_time_constant_pct": float(truth.time_constant_pct[i, k]),
                        "true_delay_samples": int(truth.delay_samples[i, k]),
                        "status": status,
                        **numbers[name],
                    }
                )
    return rows


def plan_tasks(config: PmrConfig, plan: SweepPlan, done: set[tuple]) -> list[PointTask]:
    """The points with runs not yet in ``done`` (keys of :func:`store.run_key`)."""
    tasks = []
    for point in plan.points(config.model):
        missing = tuple(
            run
            for run in plan.runs()
            if any((m, point.sweep, round(point.nu, 9), run[0], run[1]) not in done for m in plan.methods)
        )
        if missing:
            tasks.append(PointTask(point, missing, plan.methods, plan.samples, plan.scenarios))
    return tasks


_WORKER_CONFIG: PmrConfig | None = None


def _init_worker(config: PmrConfig) -> None:
    global _WORKER_CONFIG
    _WORKER_CONFIG = config


def _work(task: PointTask) -> tuple[PointTask, list[dict], float]:
    if _WORKER_CONFIG is None:
        raise RuntimeError("_work runs in a pool worker that _init_worker set up")
    return timed_point(_WORKER_CONFIG, task)


@dataclass
class SweepOutcome:
    """What :func:`execute` did."""

    points_run: int
    runs_run: int
    wall_time_s: float
    cpu_time_s: float = 0.0


def execute(
    config: PmrConfig,
    tasks: list[PointTask],
    results: Path,
    jobs: int | None = None,
    progress: bool = True,
    *,
    scheduler: str | None = None,
) -> SweepOutcome:
    """Run ``tasks`` on ``jobs`` processes, or on a Dask cluster, appending each point's rows to ``results``.

    ``jobs = 1`` runs in this process (no pool).  With ``scheduler`` (a Dask
    scheduler's address) the points run on that cluster's workers instead
    (:func:`pmr_ros.sweep.cluster.run_on_cluster`); the rows are the same.
    On Ctrl-C the pool (or the cluster's pending points) is stopped, the
    finished points stay in the CSV and KeyboardInterrupt is raised again.
    A pool worker that ends mid-point (killed, out of memory) stops the sweep
    with :class:`~pmr_ros.core.sim.workers.WorkerEnded` once the points done by
    then are in the CSV.
    """
    jobs = worker_count(jobs, tasks=len(tasks))
    bar = ProgressBar(sum(len(t.runs) for t in tasks), stream=sys.stderr) if progress else None
    # The slowest points (largest nu: longest horizons) go first, so no process idles at the end.
    ordered = sorted(tasks, key=lambda t: -t.point.nu)
    start = time.perf_counter()
    done = {"points": 0, "runs": 0, "cpu": 0.0}

    def record(task: PointTask, rows: list[dict], cpu_s: float) -> None:
        store.append_rows(results, rows)
        done["cpu"] += cpu_s
        done["points"] += 1
        done["runs"] += len(task.runs)
        if bar:
            bar.update(len(task.runs))

    try:
        if scheduler is not None:
            from .cluster import run_on_cluster

            run_on_cluster(config, ordered, scheduler, work=timed_point, record=record)
        elif jobs == 1:
            _run_here(config, ordered, record)
        else:
            _run_pool(config, ordered, jobs, record)
    except KeyboardInterrupt:
        if bar:
            bar.close()
        print(
            f"pmr-ros sweep: interrupted; {done['points']} finished points ({done['runs']} runs) are in {results}; "
            "continue with --resume",
            file=sys.stderr,
        )
        raise
    except WorkerEnded:
        if bar:
            bar.close()
        raise
    if bar:
        bar.close()
    return SweepOutcome(int(done["points"]), int(done["runs"]), time.perf_counter() - start, float(done["cpu"]))


Recorder = Callable[[PointTask, list[dict], float], None]
"""Takes a finished point: its task, CSV rows and CPU time [s]."""


def _run_here(config: PmrConfig, tasks: list[PointTask], record: Recorder) -> None:
    global _WORKER_CONFIG
    _WORKER_CONFIG = config
    for task in tasks:
        record(*_work(task))


def _run_pool(config: PmrConfig, tasks: list[PointTask], jobs: int, record: Recorder) -> None:
    with worker_pool(jobs, _init_worker, (config,)) as pool:
        for task, rows, cpu_s in completed(pool, _work, tasks):
            record(task, rows, cpu_s)


def timed_point(config: PmrConfig, task: PointTask) -> tuple[PointTask, list[dict], float]:
    """:func:`run_point` with the CPU time it took [s]: what a pool or cluster worker returns."""
    t0 = time.process_time()
    rows = run_point(config, task)
    return task, rows, time.process_time() - t0
