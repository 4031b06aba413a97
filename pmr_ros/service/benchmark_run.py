"""``pmr-ros benchmark``: pick the scenario runs, run every method on each (here, a pool or Dask), score, write.

What is written to ``out``: ``runs/`` (the journal, :mod:`pmr_ros.benchmark.journal`:
each run's rows the moment it is done, so that ``resume`` runs only what a
stopped benchmark left), ``results.parquet`` (one row per run, method and
element: :func:`pmr_ros.benchmark.runner.method_rows` and the run's cell),
``scores.csv`` (:func:`pmr_ros.benchmark.scoring.score`), ``roc.csv``
(:func:`pmr_ros.benchmark.scoring.roc_table`) and the markdown
report with its figures, ``benchmark.json`` (wall time); with ``export`` the dataset of
:mod:`pmr_ros.benchmark.dataset`.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..benchmark import dataset
from ..benchmark.journal import Journal, fingerprint
from ..benchmark.runner import METHODS, RunTask, run_one
from ..benchmark.scenarios import read_scenarios, run_table
from ..benchmark.units import all_units, unit_config
from ..config import PmrConfig
from ..core.records import Record
from ..outputs import write_text
from ..progress import ProgressBar
from .benchmark_files import (
    JOURNAL,
    MANIFEST,
    RESULTS,
    left_to_do,
    open_journal,
    planned_rows,
    score_and_write,
    write_results,
)
from .refusal import ServiceError

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["BenchmarkRequest", "BenchmarkSummary", "rescore", "run_benchmark", "select_runs"]


@dataclass(frozen=True)
class BenchmarkRequest:
    """What to run and where to write.

    Attributes
    ----------
    out : Path
        Folder of results.parquet and scores.csv.
    report : Path
        The markdown report; its figures go to ``figures/`` beside it.
    quick : bool
        Only the scenario file's ``quick`` runs.
    units, lengths : tuple or None
        Only these units / record lengths [samples] (None: all).
    runs_per_cell : int or None
        At most this many runs of each (unit, disturbance, length), the first by number.
    methods : tuple of str
        Of :data:`~pmr_ros.benchmark.runner.METHODS`.
    jobs : int
        Local processes (1: this one).
    scheduler : str or None
        A Dask scheduler's address: the runs go to its workers instead.
    export : Path or None
        Folder of the dataset export.
    scenarios : Path or None
        Another scenario file (default: the shipped one).
    pem_runs_per_cell : int or None
        The prediction-error peers (``pem_oe``, ``pem_bj``: 10-100x the others' time) on
        only the first this many runs of each cell (None: on every run).
    progress : bool
        A progress bar on stderr.
    resume : bool
        Keep the journal ``out/runs`` and run only the (run, method) pairs not in it.
    force : bool
        Start the journal anew even if it holds runs (without ``resume`` or ``force`` such a journal is refused).
    """

    out: Path
    report: Path
    quick: bool = False
    units: tuple[str, ...] | None = None
    lengths: tuple[int, ...] | None = None
    runs_per_cell: int | None = None
    methods: tuple[str, ...] = tuple(METHODS)
    jobs: int = 1
    scheduler: str | None = None
    export: Path | None = None
    scenarios: Path | None = None
    pem_runs_per_cell: int | None = None
    progress: bool = False
    resume: bool = False
    force: bool = False


@dataclass(frozen=True)
class BenchmarkSummary:
    """What a benchmark did: the runs it ran, the scores, its wall time [s], the runs scored.

    ``scored`` counts every run of the results; with ``resume`` it includes the runs taken from the journal.
    """

    runs: int
    scores: pd.DataFrame
    wall_s: float
    scored: int


def select_runs(scenarios: pd.DataFrame, request: BenchmarkRequest) -> pd.DataFrame:
    """The scenario lines of the runs ``request`` asks for (its quick, units, lengths and runs-per-cell rules)."""
    runs = run_table(scenarios)
    if request.quick:
        runs = runs[runs["quick"] == 1]
    if request.units is not None:
        unknown = [u for u in request.units if u not in all_units()]
        if unknown:
            raise ServiceError(f"--units: unknown unit {unknown[0]!r}; choose of {', '.join(all_units())}")
        runs = runs[runs["unit"].isin(request.units)]
    if request.lengths is not None:
        runs = runs[runs["samples"].isin(request.lengths)]
    if request.runs_per_cell is not None:
        runs = runs.groupby(["unit", "disturbance", "samples"], sort=False).head(request.runs_per_cell)
    if runs.empty:
        raise ServiceError(
            "the selection (--quick, --units, --samples, --runs-per-cell) leaves no run of the scenarios"
        )
    return scenarios[scenarios["run"].isin(runs["run"])].reset_index(drop=True)


SLOW_METHODS = ("pem_oe", "pem_bj")
"""The methods ``pem_runs_per_cell`` limits."""


def _scenarios(request: BenchmarkRequest) -> pd.DataFrame:
    """The scenario file of ``request``; a file that is none is one line naming it."""
    try:
        return read_scenarios(request.scenarios)
    except (ValueError, OSError) as exc:  # pandas' parse errors are ValueErrors
        raise ServiceError(f"--scenarios {request.scenarios}: {' '.join(str(exc).split())}") from None


def _tasks(lines: pd.DataFrame, request: BenchmarkRequest) -> list[RunTask]:
    tasks = []
    index = run_table(lines).groupby(["unit", "disturbance", "samples"]).cumcount()
    place = dict(zip(run_table(lines)["run"], index, strict=True))
    for run, truth in lines.groupby("run", sort=True):
        first = truth.iloc[0]
        methods = request.methods
        if request.pem_runs_per_cell is not None and place[run] >= request.pem_runs_per_cell:
            methods = tuple(m for m in methods if m not in SLOW_METHODS)
        tasks.append(
            RunTask(
                run=int(run), unit=str(first["unit"]), samples=int(first["samples"]),
                disturbance=bool(first["disturbance"]), seed=int(first["seed"]),
                truth=truth.reset_index(drop=True), methods=methods,
            )
        )  # fmt: skip
    # the longest records of the largest units first, so no worker idles at the end
    return sorted(tasks, key=lambda t: (-t.samples * unit_config(t.unit).model.present.sum(), t.run))


def cluster_work(_config: PmrConfig, task: RunTask) -> tuple[RunTask, list[dict], float]:
    """What a Dask worker runs: one run; its record rides back on the task (``RunTask.record``)."""
    start = time.process_time()
    done, rows, record = run_one(task)
    return replace(done, record=record), rows, time.process_time() - start


def _execute(
    tasks: list[RunTask], request: BenchmarkRequest, record: Callable[[RunTask, list[dict], Record], None]
) -> None:
    if request.scheduler is not None:
        from ..sweep.cluster import ClusterError, check_scheduler, run_on_cluster

        try:
            check_scheduler(request.scheduler)
            run_on_cluster(
                unit_config(tasks[0].unit), tasks, request.scheduler, work=cluster_work,
                record=lambda task, rows, _cpu: record(task, rows, task.record),
            )  # fmt: skip
        except ClusterError as exc:
            raise ServiceError(str(exc)) from None
    elif request.jobs <= 1 or len(tasks) == 1:
        for task in tasks:
            record(*run_one(task))
    else:
        from ..core.sim.workers import WorkerEnded, completed, worker_pool

        try:
            with worker_pool(min(request.jobs, len(tasks))) as pool:
                for result in completed(pool, run_one, tasks):
                    record(*result)
        except WorkerEnded as exc:  # the runs done by then are in the journal: one line, exit code 1
            raise ServiceError(
                f"a benchmark worker process ended before its runs were done (killed? out of memory?): {exc.done} of "
                f"{exc.total} runs done, their rows in {request.out / JOURNAL}; continue with --resume",
                code=1,
            ) from None


def rescore(request: BenchmarkRequest) -> BenchmarkSummary:
    """Score what ``request.out`` holds again and write scores.csv and the report (no run).

    What it holds: every run of its journal (``out/runs``, however many invocations and ``--resume`` s
    wrote it; results.parquet is rewritten from it), else its results.parquet.

    Raises
    ------
    ServiceError
        Neither a journal nor results.parquet in ``request.out``, or a journal of another scenario file.
    """
    import pandas as pd

    path = request.out / RESULTS
    scenarios = _scenarios(request)
    journal = Journal(request.out / JOURNAL)
    from_journal = journal.count() > 0
    if from_journal:
        try:
            journal.check(fingerprint(scenarios))
        except ValueError as exc:
            raise ServiceError(f"--report-only: {exc}") from None
        rows = journal.read()
        lines = scenarios[scenarios["run"].isin(rows["run"])].reset_index(drop=True)
        results = write_results(path, rows, lines)
    elif path.is_file():
        results = pd.read_parquet(path)
        lines = scenarios[scenarios["run"].isin(results["run"])].reset_index(drop=True)
    else:
        raise ServiceError(f"--report-only: {path} does not exist; run the benchmark first")
    manifest = request.out / MANIFEST
    # a journal may hold the runs of many invocations: the last one's wall time is not theirs
    known = manifest.is_file() and not from_journal
    wall_s = float(json.loads(manifest.read_text())["wall_s"]) if known else math.nan
    scores = score_and_write(results, lines, out=request.out, report=request.report, wall_s=wall_s)
    scored = int(results["run"].nunique())
    return BenchmarkSummary(scored, scores, wall_s, scored)


def run_benchmark(request: BenchmarkRequest) -> BenchmarkSummary:
    """Run, score and write what ``request`` asks for (see the module docstring)."""
    scenarios = _scenarios(request)
    lines = select_runs(scenarios, request)
    tasks = _tasks(lines, request)
    request.out.mkdir(parents=True, exist_ok=True)
    journal = open_journal(request.out, scenarios, resume=request.resume, force=request.force)
    todo = left_to_do(tasks, journal.done() if request.resume else set())
    if request.export is not None:
        for unit in sorted(set(lines["unit"])):
            dataset.write_model(request.export, unit, unit_config(unit).model)
        dataset.write_labels(request.export, lines, run_table(lines))
    bar = ProgressBar(len(todo), label="benchmark", stream=sys.stderr) if request.progress and todo else None
    start = time.perf_counter()

    def record(task: RunTask, task_rows: list[dict], data: Record | None) -> None:
        journal.write(task.run, task.methods, task_rows)
        if request.export is not None and data is not None:
            dataset.write_run(request.export, task.run, data, unit_config(task.unit).model)
        if bar:
            bar.update(1)

    try:
        if todo:
            _execute(todo, request, record)
    finally:  # the bar's line ended before an error's line
        if bar:
            bar.close()
    wall_s = time.perf_counter() - start
    results = write_results(request.out / RESULTS, planned_rows(journal, tasks), lines)
    write_text(request.out / MANIFEST, json.dumps({"wall_s": wall_s, "runs": len(todo)}) + "\n")
    scores = score_and_write(results, lines, out=request.out, report=request.report, wall_s=wall_s)
    return BenchmarkSummary(len(todo), scores, wall_s, int(results["run"].nunique()))
