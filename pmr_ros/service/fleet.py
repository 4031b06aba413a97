"""A fleet of controllers diagnosed: each entry's export diagnosed (once, or over rolling windows), one ranked summary.

A fleet file lists the controllers, each with its params file and its
historian export (paths relative to the fleet file)::

    window: 14d          # optional: every entry over rolling windows (an entry may set its own)
    step: 1d
    controllers:
      - {name: C101, params: c101.yaml, data: c101.parquet}
      - {name: C102, params: c102.yaml, data: c102.csv, window: 7d, step: 1d}

Each entry is one task (a local process, or a Dask worker with a scheduler);
it writes its own report folder and returns its summary rows only.  An entry
that fails (a missing file, bad data) is a ``failed`` row naming why; the
others run.  The rows are ranked by what matters most: the control impact
(tracking-error ratio) where the controller's diagnosis computed one, else
the size of the decided mismatch over its tolerance.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from .refusal import ServiceError

__all__ = [
    "WORKER_ENDED",
    "FleetEntry",
    "diagnose_entry",
    "failed_entry",
    "rank_rows",
    "read_fleet",
    "run_fleet",
    "run_local",
]


@dataclass(frozen=True)
class FleetEntry:
    """One controller of the fleet.

    Attributes
    ----------
    name : str
    params : Path
        Its params file (model, data block).
    data : Path
        Its historian export (.csv, .parquet).
    window, step : str or None
        Rolling windows (None: one diagnosis of the whole file).
    report : Path or None
        Where its HTML report goes (None: none).
    """

    name: str
    params: Path
    data: Path
    window: str | None = None
    step: str | None = None
    report: Path | None = None


def _entry(item: Any, index: int, folder: Path, defaults: dict[str, Any]) -> FleetEntry:
    where = f"controllers[{index}]"
    if not isinstance(item, dict):
        raise ServiceError(f"{where}: an entry is a mapping with name, params and data, not {item!r}")
    missing = [key for key in ("name", "params", "data") if not item.get(key)]
    if missing:
        raise ServiceError(f"{where}: no {', '.join(missing)}")
    window = item.get("window", defaults.get("window"))
    step = item.get("step", defaults.get("step"))
    return FleetEntry(
        str(item["name"]),
        folder / str(item["params"]),
        folder / str(item["data"]),
        None if window is None else str(window),
        None if step is None else str(step),
    )


def read_fleet(path: str | Path) -> list[FleetEntry]:
    """The entries of a fleet file (paths relative to it).

    Raises
    ------
    ServiceError
        One line: the file missing or not YAML, no ``controllers`` list, an entry without name, params or
        data, two entries of one name.
    """
    import yaml

    path = Path(path)
    try:
        tree = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ServiceError(f"--fleet {path}: cannot read: {exc.strerror or exc}") from None
    except yaml.YAMLError as exc:
        raise ServiceError(f"--fleet {path}: not YAML: {' '.join(str(exc).split())}") from None
    items = tree.get("controllers") if isinstance(tree, dict) else tree
    if not isinstance(items, list) or not items:
        raise ServiceError(f"--fleet {path}: no 'controllers' list (entries with name, params, data)")
    defaults = tree if isinstance(tree, dict) else {}
    entries = [_entry(item, i, path.parent, defaults) for i, item in enumerate(items)]
    names = [e.name for e in entries]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ServiceError(f"--fleet {path}: controller {twice[0]!r} is listed twice")
    return entries


def _size_over_tolerance(element: dict[str, Any], settings: dict[str, Any]) -> float:
    """The largest decided mismatch over its tolerance (dD over half a sample); 0 without a mismatch."""
    part = element.get("parametric") or {}
    pairs = [
        (part.get("gain_mismatch_pct"), settings.get("gain_tolerance_pct"), part.get("gain_verdict")),
        (part.get("tau_mismatch_pct"), settings.get("tau_tolerance_pct"), part.get("tau_verdict")),
        (part.get("delay_mismatch_samples"), 0.5, part.get("delay_verdict")),
    ]
    sizes = [abs(float(v)) / float(t) for v, t, verdict in pairs if verdict == "mismatch" and v is not None and t]
    return max(sizes, default=0.0)


def _first_onset(onset: dict[str, Any] | None) -> Any:
    """The earliest step or drift of the element's parameters (``parameter kind time``), or None."""
    found = [
        (entry["onset"], parameter, entry["kind"])
        for parameter, entry in (onset or {}).items()
        if isinstance(entry, dict) and entry.get("kind") in ("step", "drift")
    ]
    if not found:
        return None
    when, parameter, kind = min(found, key=lambda item: str(item[0]))
    return f"{parameter} {kind} from {when}"


def summary_rows(name: str, report: dict[str, Any], folder: str | None) -> list[dict[str, Any]]:
    """One row per modeled element of a controller's report: verdict, onset, impact and size over tolerance."""
    settings = (report.get("settings") or {}).get("parametric") or {}
    rows = []
    for element, found in (report.get("elements") or {}).items():
        if (found.get("model") or {}).get("kind") == "none":
            continue
        impact = found.get("impact") or {}
        rows.append(
            {
                "controller": name,
                "element": element,
                "verdict": found.get("verdict"),
                "onset": _first_onset(found.get("onset")),
                "ise_ratio": impact.get("ise_ratio"),
                "size_over_tolerance": _size_over_tolerance(found, settings),
                "report": folder,
                "reason": None,
            }
        )
    return rows


def rank_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows ordered by what matters most, each with its ``rank`` (1 first).

    Mismatches first: those with a control impact by their tracking-error
    ratio (largest first), then those without by their size over tolerance;
    then inconclusive, ok and failed rows.
    """

    def key(row: dict[str, Any]) -> tuple[int, float]:
        if row["verdict"] == "mismatch" and row.get("ise_ratio") is not None:
            return 0, -float(row["ise_ratio"])
        if row["verdict"] == "mismatch":
            return 1, -float(row.get("size_over_tolerance") or 0.0)
        return {"inconclusive": 2, "ok": 3}.get(str(row["verdict"]), 4), 0.0

    ordered = sorted(rows, key=key)
    return [{**row, "rank": i + 1} for i, row in enumerate(ordered)]


def _write_pages(entry: FleetEntry, report: dict[str, Any], page: Any, table: Any) -> None:
    """The controller's report folder: the (last window's) page, and the trend page over its windows."""
    from ..report import write_json
    from ..report.html import write_html_report

    if entry.report is None:
        return
    write_html_report(entry.report, page)
    write_json(report, entry.report / "report.json")
    if table is not None:
        from ..report.trend_page import write_trend_page

        write_trend_page(entry.report, report, table)


def entry_report(entry: FleetEntry, config: Any) -> dict[str, Any]:
    """Diagnose one controller's export (once, or every window) and write its report folder; its JSON report."""
    from ..report import build_report
    from ..report.html import ReportInput
    from .closing import close_and_write
    from .historian import read_export
    from .monitoring import WindowJob, monitor, window_stretches

    data = read_export(entry.data, config)
    job = WindowJob(config, data, data.usable)
    span, found = (0, data.samples - 1), None
    if entry.window is not None:
        found = monitor(data, config, window=entry.window, step=entry.step or entry.window, jobs=1)
        span, diagnosis = found.plan[-1], found.diagnoses[-1]
    else:
        from .monitoring import diagnose_window

        diagnosis = diagnose_window(job, span)
    if diagnosis.status == "ok":
        diagnosis = close_and_write(config, diagnosis)
    report = build_report(config, diagnosis, command="diagnose", scenario=None, seed=None)
    report.update(path="data", source=str(entry.data), controller=entry.name)
    if found is not None:
        report.update(monitor={"window": entry.window, "step": entry.step or entry.window}, windows=found.windows)
        for name, element in report["elements"].items():
            element["onset"] = found.onsets.get(name)
    if entry.report is not None:
        page = ReportInput(report, diagnosis, window_stretches(job, *span), data, config)
        _write_pages(entry, report, page, None if found is None else found.table)
    return report


def failed_entry(name: str, reason: str) -> tuple[list[dict[str, Any]], None]:
    """The one ``failed`` summary row of controller ``name`` and its missing report."""
    row = {"controller": name, "element": None, "verdict": "failed", "onset": None, "ise_ratio": None}
    return [row | {"size_over_tolerance": None, "report": None, "reason": " ".join(reason.split())}], None


WORKER_ENDED = "its worker process ended (killed? out of memory?)"
"""The reason of an entry whose diagnosis ended its process, and did again when run alone."""


def _named(work: Callable[[Any], Any], entry: Any) -> tuple[str, Any]:
    return entry.name, work(entry)


def run_local(entries: list[Any], *, jobs: int, work: Callable[[Any], Any] | None = None) -> dict[str, Any]:
    """``work(entry)`` (default :func:`diagnose_entry`, a module's function) of every entry on ``jobs`` processes.

    A process that ends mid-entry (the out-of-memory killer, a signal) breaks the whole pool: every entry not
    done then is run again alone, one at a time, each on a process of its own, and one that ends its process
    again is :func:`failed_entry` with :data:`WORKER_ENDED`; the others keep their results.  The pools are
    :func:`~pmr_ros.core.sim.workers.worker_pool` s: a Ctrl-C terminates their workers.
    """
    from concurrent.futures.process import BrokenProcessPool

    from ..core.sim.workers import WorkerEnded, completed, worker_pool

    work = diagnose_entry if work is None else work
    found: dict[str, Any] = {}  # by entry name
    broken: tuple[Any, ...] = ()
    with worker_pool(jobs) as pool:
        try:
            for name, result in completed(pool, partial(_named, work), entries):
                found[name] = result
        except WorkerEnded as ended:
            broken = ended.unfinished  # in the fleet's order
    for entry in broken:
        with worker_pool(1) as alone:
            try:
                found[entry.name] = alone.submit(work, entry).result()
            except BrokenProcessPool:
                found[entry.name] = failed_entry(entry.name, WORKER_ENDED)
    return found


def diagnose_entry(entry: FleetEntry) -> tuple[list[dict[str, Any]], dict[str, Any] | None]:
    """One controller: its summary rows and JSON report (None when it failed: one ``failed`` row saying why)."""
    from ..config import ConfigError, load_config

    try:
        for what, path in (("params", entry.params), ("data", entry.data)):
            if not path.is_file():
                raise ServiceError(f"{what} {path}: no such file")
        report = entry_report(entry, load_config(entry.params))
    except (ServiceError, ConfigError, ValueError, OSError) as exc:
        return failed_entry(entry.name, str(exc))
    folder = None if entry.report is None else entry.report.name
    return summary_rows(entry.name, report, folder), report


def _timed(_shared: Any, entry: FleetEntry) -> tuple[FleetEntry, Any, float]:
    """One entry on a Dask worker: ``(entry, (rows, report), cpu_s)``."""
    t0 = time.process_time()
    found = diagnose_entry(entry)
    return entry, found, time.process_time() - t0


def run_fleet(
    entries: list[FleetEntry], *, jobs: int | None = None, scheduler: str | None = None
) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any] | None]]:
    """Every entry diagnosed (local processes, this process with ``jobs=1``, or the Dask cluster).

    Returns
    -------
    rows : list of dict
        Every controller's summary rows, ranked (:func:`rank_rows`).
    reports : dict
        Each controller's JSON report (None where it failed), by name.
    """
    from ..core.sim.workers import worker_count

    found: dict[str, tuple[list[dict[str, Any]], dict[str, Any] | None]] = {}
    jobs = worker_count(jobs, tasks=len(entries))
    if scheduler is not None:
        from ..sweep.cluster import run_on_cluster

        def record(entry: Any, result: Any, _cpu_s: float) -> None:
            found[entry.name] = result

        run_on_cluster(None, entries, scheduler, work=_timed, record=record)
    elif jobs == 1:
        found = {entry.name: diagnose_entry(entry) for entry in entries}
    else:
        found = run_local(entries, jobs=jobs)
    rows = [row for entry in entries for row in found[entry.name][0]]
    return rank_rows(rows), {name: result[1] for name, result in found.items()}
