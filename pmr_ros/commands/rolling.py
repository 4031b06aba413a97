"""``pmr-ros diagnose FILE|BAG --window W --step S``: print and write the rolling-window diagnosis.

The windows are diagnosed by :mod:`pmr_ros.service.monitoring`; this module
checks the options, prints the last window's table, the windows' summary and
each element's onsets, and writes ``--json``, ``--trend`` and ``--report``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from . import EXIT_INSUFFICIENT, CommandError

__all__ = ["check_monitor_options", "default_step", "diagnose_windows", "onset_lines"]


def default_step(window: str) -> str:
    """A quarter of the window, in its unit (at least one sample)."""
    from ..core.monitor import parse_span
    from ..core.monitor.windows import UNITS

    span = parse_span(window, option="window")
    if span.seconds:
        return f"{span.value / 4 / UNITS[span.unit]:g}{span.unit}"
    return str(max(1, int(span.value) // 4))


def check_monitor_options(args: argparse.Namespace) -> None:
    """Refuse, in one line, the rolling-window options without ``--window`` (and check the scheduler first).

    Raises
    ------
    CommandError
        ``--step``, ``--trend``, ``--jobs``, ``--scheduler`` without ``--window`` (or ``--fleet``), a trend
        file of another kind, an unreachable ``--scheduler``.
    """
    for name in ("step", "trend", "jobs", "scheduler", "connect_timeout"):
        if getattr(args, name) is not None and args.window is None and not getattr(args, "fleet", None):
            flag = name.replace("_", "-")
            raise CommandError(f"--{flag}: an option of --window W (the rolling windows) or --fleet")
    if args.trend is not None and not args.trend.lower().endswith((".csv", ".parquet")):
        raise CommandError(f"--trend {args.trend}: the trend file must end in .csv or .parquet")
    if args.scheduler:
        from ..sweep.cluster import ClusterError, check_scheduler

        try:
            check_scheduler(args.scheduler, timeout_s=args.connect_timeout)
        except ClusterError as exc:
            raise CommandError(str(exc)) from None


def _when(value: Any) -> str:
    """A time of the JSON as the terminal shows it: a date-time to the minute, seconds as they are."""
    if isinstance(value, str):
        return value[:16].replace("T", " ")
    return "-" if value is None else f"{value:g} s"


def onset_lines(onsets: dict[str, dict[str, Any]]) -> list[str]:
    """One line per element and parameter that moved (step or drift), and where a mismatch lasts from."""
    units = {"gain": "%", "tau": "%", "delay": " samples"}
    lines = []
    for element, entry in onsets.items():
        for parameter, unit in units.items():
            found = entry[parameter]
            if found["kind"] not in ("step", "drift"):
                continue
            low, high = found["interval"] or (None, None)
            size = "" if found["size"] is None else f", {found['size']:+.3g}{unit} by the last window"
            lines.append(
                f"  {element} {parameter}: {found['kind']} from {_when(found['onset'])} "
                f"(95 % {_when(low)} .. {_when(high)}){size}"
            )
        if entry["lasting_mismatch_window"] is not None:
            lines.append(
                f"  {element}: mismatch in every window since window {entry['lasting_mismatch_window']} "
                f"(ending {_when(entry['lasting_mismatch_end'])})"
            )
    return lines


def print_monitoring(found: Any) -> None:
    """The windows' summary and the onsets, below the last window's table."""
    counts: dict[str, int] = {}
    for window in found.windows:
        counts[window["status"]] = counts.get(window["status"], 0) + 1
    status = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    print(
        f"windows: {len(found.windows)} ({status}); the table shows the last "
        f"(samples {found.plan[-1][0]}..{found.plan[-1][1]}); {found.wall_time_s:.1f} s"
    )
    lines = onset_lines(found.onsets)
    print("onsets:" if lines else "onsets: no parameter moved over the windows")
    for line in lines:
        print(line)


def _write(args: argparse.Namespace, report: dict[str, Any], found: Any, page: Any) -> None:
    from ..core.monitor import write_trend
    from ..report import write_json

    outputs: list[tuple[str, Any, Callable[[], Any]]] = [("--json", args.json, lambda: write_json(report, args.json))]
    outputs.append(("--trend", args.trend, lambda: write_trend(found.table, args.trend)))
    for option, path, write in outputs:
        if not path:
            continue
        try:
            write()
        except OSError as exc:
            raise CommandError(f"{option} {path}: cannot write: {exc.strerror or exc}") from None
        except ValueError as exc:
            raise CommandError(str(exc)) from None
    if args.report:
        from ..report.html import write_html_report
        from ..report.trend_page import write_trend_page

        try:
            index = write_html_report(args.report, page)
            write_trend_page(args.report, report, found.table)
        except OSError as exc:
            raise CommandError(f"--report {args.report}: cannot write: {exc.strerror or exc}") from None
        print(f"report: {index}")


def monitor_report(report: dict[str, Any], found: Any, args: argparse.Namespace) -> dict[str, Any]:
    """The last window's report with the windows, the monitor's settings and each element's onset."""
    step = args.step or default_step(args.window)
    report["monitor"] = {"window": args.window, "step": step, "windows": len(found.windows)}
    report["windows"] = found.windows
    for name, element in report.get("elements", {}).items():
        element["onset"] = found.onsets.get(name)
    return report


def diagnose_windows(args: argparse.Namespace, data: Any, config: Any, report_of: Any) -> int:
    """Diagnose every window of ``data``; print, write; the exit code of the last window (0 ok, 3 insufficient).

    ``report_of(diagnosis)`` builds the JSON report of the last window (the
    source's own fields: file or bag).
    """
    from ..core.sim.workers import worker_count
    from ..progress import progress_callback
    from ..report import format_table
    from ..report.html import ReportInput
    from ..service.closing import close_and_write
    from ..service.monitoring import WindowJob, monitor, window_stretches

    step = args.step or default_step(args.window)
    quiet = getattr(args, "quiet", False)
    say = None if quiet else (lambda line: print(line, file=sys.stderr))
    update, close = (None, lambda: None) if quiet else progress_callback("windows", unit="windows")
    try:
        found = monitor(
            data,
            config,
            window=args.window,
            step=step,
            jobs=args.jobs,
            scheduler=args.scheduler,
            progress=say,
            windows_done=update,
        )
    finally:  # the bar's line ended before an error's line
        close()
    last = found.diagnoses[-1]
    if last.status == "ok":
        # the impact's simulations on the windows' local workers (its fork server runs already); on one
        # process here when the windows ran on a cluster
        jobs = 1 if args.scheduler else worker_count(args.jobs)
        last = close_and_write(config, last, model_path=getattr(args, "write_model", None), jobs=jobs)
    report = monitor_report(report_of(last), found, args)
    if last.status == "ok":
        sys.stdout.write(format_table(last, report))
    else:
        print(f"last window: INSUFFICIENT DATA: {last.reason}")
    print_monitoring(found)
    first, end = found.plan[-1]
    stretches = window_stretches(WindowJob(config, data, data.usable), first, end)
    _write(args, report, found, ReportInput(report, last, stretches, data, config))
    return 0 if last.status == "ok" else EXIT_INSUFFICIENT
