"""Rolling-window diagnosis of one long record: every window diagnosed, the trend table and the onsets.

The record (a historian export or a bag, read and cleaned once) is cut into
the windows of :func:`pmr_ros.core.monitor.window_plan`; each window's
unbroken stretches are slices of the one record (a window's own deviations
are the only copy; :mod:`.window_job`, whose names this module also gives).
Windows run on local processes (the sweep's ``forkserver`` pool,
:func:`pmr_ros.core.sim.workers.worker_context`, the record memory-mapped by
each worker: :mod:`.shipping`), in this process (``jobs=1``) or on a Dask
cluster (:mod:`pmr_ros.sweep.cluster`); the results are the same, in window
order.  Each window's entry carries its
elements in the result codec's JSON shape (:mod:`pmr_ros.core.results.codec`).
"""

from __future__ import annotations

import re
import tempfile
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..config import PmrConfig
from ..core.monitor import OnsetSettings, onset_entries, trend_onsets, trend_table, window_plan
from ..core.pmr.piecewise import PieceCache
from ..core.results import Diagnosis
from ..core.results.codec import diagnosis_to_json
from ..core.sim.workers import worker_count
from ..data import PlantData
from .refusal import ServiceError
from .shipping import ship, unship
from .window_job import WindowJob, diagnose_window, stretch_spans, window_stretches
from .window_shares import WindowShares

__all__ = [
    "Monitoring",
    "WindowJob",
    "diagnose_window",
    "monitor",
    "start_workers",
    "stretch_spans",
    "window_entry",
    "window_stretches",
]


_DATE = re.compile(r"^\d{4}-\d{2}-\d{2}")
_SECONDS = re.compile(r"^\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)\s*s\s*$")


def _clock(data: PlantData) -> Any:
    """The time of sample 0: a UTC timestamp for dated data, else its seconds (``"1000 s"``; 0 otherwise)."""
    import pandas

    if _DATE.match(data.start):
        stamp = pandas.Timestamp(data.start)
        return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")
    seconds = _SECONDS.match(data.start)
    return float(seconds.group(1)) if seconds else 0.0


def _time(origin: Any, seconds: float) -> float | str:
    """A time ``seconds`` after sample 0: ISO text when the data have a date, else seconds on the data's clock."""
    import pandas

    if isinstance(origin, float):
        return origin + float(seconds)
    return (origin + pandas.Timedelta(seconds=float(seconds))).isoformat()


def window_entry(index: int, span: tuple[int, int], diagnosis: Diagnosis, job: WindowJob) -> dict[str, Any]:
    """One window of the JSON's ``windows``: samples, times, status, data quality and elements (codec shape).

    ``end`` is the end of the last sample's period (``(last + 1) Ts`` after sample 0).
    """
    first, last = span
    ts, origin = job.data.sample_time_s, _clock(job.data)
    usable = int(np.count_nonzero(job.usable[first : last + 1]))
    coded = diagnosis_to_json(diagnosis)
    return {
        "window": index,
        "first": first,
        "last": last,
        "start": _time(origin, first * ts),
        "end": _time(origin, (last + 1) * ts),
        "status": coded["status"],
        "reason": coded["reason"],
        "samples": coded["samples"],
        "quality": {"usable_share": usable / (last - first + 1)},
        "elements": coded["elements"],
    }


@dataclass(frozen=True)
class Monitoring:
    """Every window of a record diagnosed.

    Attributes
    ----------
    plan : list of (int, int)
        Each window's first and last sample.
    diagnoses : list of Diagnosis
        One per window, in time order.
    windows : list of dict
        The JSON's ``windows`` (:func:`window_entry`).
    table : pandas.DataFrame
        The trend table (:func:`pmr_ros.core.monitor.trend_table`).
    onsets : dict
        Per element, its ``onset`` entry (:func:`pmr_ros.core.monitor.onset_entries`; times as the windows'),
        with ``lasting_mismatch_end``, the end of the window the mismatch lasts from.
    window_s : float
        Window length [s].
    wall_time_s : float
        Time the windows took [s].
    """

    plan: list[tuple[int, int]]
    diagnoses: list[Diagnosis]
    windows: list[dict[str, Any]]
    table: Any
    onsets: dict[str, dict[str, Any]]
    window_s: float
    wall_time_s: float


ONSET_SETTINGS = OnsetSettings(scale_errors=True)
"""How the monitor decides onsets: window estimates of plant data scatter more than their intervals say
(the daily operation is not white noise), so the errors are scaled up by the scatter about the best fit."""

_WORKER_JOB: WindowJob | None = None
_WORKER_PIECES: PieceCache | None = None
_WORKER_SHARES: WindowShares | None = None


def _init_worker(shipped: bytes, shares: WindowShares) -> None:
    global _WORKER_JOB, _WORKER_PIECES, _WORKER_SHARES
    job = unship(shipped)  # the record's arrays memory-mapped: not a copy per worker through the pool's pipe
    _WORKER_JOB, _WORKER_PIECES, _WORKER_SHARES = job, PieceCache(job.config.model), shares


def start_workers(*, jobs: int | None, scheduler: str | None) -> None:
    """Start the local window workers' fork server now, when the windows will run on it; do not wait for it.

    Its import of the diagnosis's modules (2 s) then runs beside what this process does meanwhile: the command
    line calls it before reading a record, :func:`monitor` before its own imports (see
    :func:`~pmr_ros.core.sim.workers.start_fork_server`).
    """
    from ..core.sim.workers import start_fork_server

    if scheduler is None and worker_count(jobs) > 1:
        start_fork_server(_init_worker)


def _work_share(share: int) -> None:
    """Windows of ``share`` (and those it takes over) in order, each result sent as it is done."""
    if _WORKER_JOB is None or _WORKER_SHARES is None:
        raise RuntimeError("_work_share runs in a pool worker that _init_worker set up")
    while (task := _WORKER_SHARES.take(share)) is not None:
        _WORKER_SHARES.put((task[0], diagnose_window(_WORKER_JOB, (task[1], task[2]), pieces=_WORKER_PIECES)))


_CLUSTER_PIECES = threading.local()
"""A Dask worker thread's pieces and the job they belong to (the scattered record: one per run).

Per thread: a worker with several threads runs windows at once, and a cache serves one window at a time."""


def cluster_window(job: WindowJob, task: tuple[int, int, int]) -> tuple[tuple[int, int, int], Diagnosis, float]:
    """One window on a Dask worker: ``(task, diagnosis, cpu_s)`` (the shape :func:`run_on_cluster` records)."""
    t0 = time.process_time()
    held = getattr(_CLUSTER_PIECES, "job", None)
    if held is None or held() is not job:  # a weak reference: a finished run's record is not kept alive
        _CLUSTER_PIECES.job, _CLUSTER_PIECES.cache = weakref.ref(job), PieceCache(job.config.model)
    diagnosis = diagnose_window(job, (task[1], task[2]), pieces=_CLUSTER_PIECES.cache)
    return task, diagnosis, time.process_time() - t0


def _run(
    job: WindowJob,
    tasks: list[tuple[int, int, int]],
    jobs: int,
    scheduler: str | None,
    record: Callable[[int, Diagnosis], None],
) -> None:
    """Every window's diagnosis, here, on a local pool or on the cluster; ``record(index, diagnosis)`` as each comes.

    A pool worker walks a contiguous share of the windows (:mod:`.window_shares`), so that its pieces serve the
    next window.
    """
    if scheduler is not None:
        from ..sweep.cluster import run_on_cluster

        run_on_cluster(
            job, tasks, scheduler, work=cluster_window, record=lambda task, diagnosis, _cpu: record(task[0], diagnosis)
        )
    elif jobs == 1:
        pieces = PieceCache(job.config.model)
        for task in tasks:
            record(task[0], diagnose_window(job, (task[1], task[2]), pieces=pieces))
    else:
        from ..core.sim.workers import worker_context, worker_pool

        shares = WindowShares(tasks, jobs, worker_context())
        with (
            tempfile.TemporaryDirectory(prefix="pmr_ros_record_") as folder,
            worker_pool(jobs, _init_worker, (ship(job, Path(folder)), shares)) as pool,
        ):
            running = [pool.submit(_work_share, share) for share in range(jobs)]  # one share per worker
            for index, diagnosis in shares.results(running):
                record(index, diagnosis)


def _diagnoses(
    job: WindowJob,
    tasks: list[tuple[int, int, int]],
    jobs: int,
    scheduler: str | None,
    windows_done: Callable[[int, int], None] | None,
) -> list[Diagnosis]:
    """Every window's diagnosis (:func:`_run`), in window order; ``windows_done(done, total)`` before and as each comes.

    Told ``(0, total)`` first: a progress bar's clock then starts with the run, not with its first window.
    """
    found: dict[int, Diagnosis] = {}
    if windows_done is not None:
        windows_done(0, len(tasks))

    def record(index: int, diagnosis: Diagnosis) -> None:
        found[index] = diagnosis
        if windows_done is not None:
            windows_done(len(found), len(tasks))

    _run(job, tasks, jobs, scheduler, record)
    return [found[index] for index in range(len(tasks))]


def _window_seconds(window: int | float | str, ts: float) -> float:
    from ..core.monitor import parse_span

    span = parse_span(window, option="window")
    return span.value if span.seconds else span.value * ts


def _onsets(table: Any, windows: Sequence[dict[str, Any]], window_s: float) -> dict[str, dict[str, Any]]:
    """Each element's onset entry; times in the windows' form (ISO text or seconds)."""
    import pandas

    entries = onset_entries(trend_onsets(table, window=window_s, time="end", settings=ONSET_SETTINGS))
    dated = bool(windows) and isinstance(windows[0]["end"], str)

    def shown(value: Any) -> Any:
        if value is None or not dated:
            return value
        return pandas.Timestamp(value, unit="s", tz="UTC").isoformat()

    for entry in entries.values():
        lasting = entry["lasting_mismatch_window"]
        entry["lasting_mismatch_end"] = None if lasting is None else windows[lasting]["end"]
        for parameter in ("gain", "tau", "delay"):
            found = entry[parameter]
            found["onset"], found["end"] = shown(found["onset"]), shown(found["end"])
            if found["interval"] is not None:
                found["interval"] = [shown(t) for t in found["interval"]]
    return entries


def _plan(data: PlantData, window: int | float | str, step: int | float | str) -> list[tuple[int, int]]:
    try:
        return window_plan(n_samples=data.samples, window=window, step=step, times=data.time_s)
    except ValueError as exc:
        raise ServiceError(f"--{exc}") from None


def monitor(
    data: PlantData,
    config: PmrConfig,
    *,
    window: int | float | str,
    step: int | float | str,
    jobs: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str], None] | None = None,
    windows_done: Callable[[int, int], None] | None = None,
) -> Monitoring:
    """Diagnose every window of ``data``, lay the results out as a trend table and find each element's onsets.

    Parameters
    ----------
    data : PlantData
        The whole record, read and cleaned once.
    config : PmrConfig
        The controller's model and the PMR settings.
    window, step : int, float or str
        Window length and the step between window ends: samples (``20160``) or
        clock time (``"14d"``, ``"1d"``, ``"6h"``; :func:`~pmr_ros.core.monitor.window_plan`).
    jobs : int, optional
        Local worker processes (default: the cores; 1: in this process).
    scheduler : str, optional
        A Dask scheduler's address: the windows run on its cluster instead.
    progress : callable, optional
        Told, in one line, what is about to run.
    windows_done : callable, optional
        ``windows_done(done, total)`` from ``(0, total)`` on, as each window's diagnosis comes (a progress bar's).

    Returns
    -------
    Monitoring

    Raises
    ------
    ServiceError
        A window longer than the data, a step of zero, a length that is not one (one line).
        A local worker process that ended before its windows were done (killed, out of memory).
    ClusterError
        ``scheduler`` cannot be used.
    """
    plan = _plan(data, window, step)
    job = WindowJob(config, data, data.usable)
    tasks = [(index, first, last) for index, (first, last) in enumerate(plan)]
    jobs = worker_count(jobs, tasks=len(tasks))
    start_workers(jobs=jobs, scheduler=scheduler)
    import pandas  # noqa: F401  (the trend table's, loaded here while a fork server loads the workers' modules)

    if progress is not None:
        where = f"the Dask cluster at {scheduler}" if scheduler else f"{jobs} process(es)"
        progress(f"diagnosing {len(tasks)} windows on {where}")
    start = time.perf_counter()
    diagnoses = _diagnoses(job, tasks, jobs, scheduler, windows_done)
    # the JSON entries after the run: built while the workers ran, one run's peak memory was 897 MB, not 770
    windows = [window_entry(i, span, d, job) for i, (span, d) in enumerate(zip(plan, diagnoses, strict=True))]
    table, window_s = trend_table(windows), _window_seconds(window, data.sample_time_s)
    onsets = _onsets(table, windows, window_s)
    return Monitoring(plan, diagnoses, windows, table, onsets, window_s, time.perf_counter() - start)
