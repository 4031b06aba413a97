"""``pmr-ros diagnose --fleet FLEET.yaml``: a fleet of controllers in one ranked summary (terminal, JSON, HTML index).

The entries run in :mod:`pmr_ros.service.fleet`; this module prints the
summary, writes ``--json`` and, with ``--report DIR``, every controller's
report in ``DIR/<name>/`` and the index page ``DIR/index.html`` linking them
in the summary's order.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from . import CommandError

__all__ = ["diagnose_fleet", "format_summary", "index_page"]

_INDEX = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>PMR fleet</title>
<style>
 body { font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1100px; padding: 1.2em; color: #212121; }
 td, th { border: 1px solid #e0e0e0; padding: 0.3em 0.6em; text-align: left; } table { border-collapse: collapse; }
 .mismatch { background: #c62828; color: white; } .ok { background: #2e7d32; color: white; }
 .inconclusive { background: #f9a825; } .failed { background: #616161; color: white; }
</style></head><body>
<h1>PMR fleet: {{ controllers }} controllers</h1>
<p>Ranked by control impact (tracking-error ratio) where the diagnosis computed it, else by the decided mismatch
over its tolerance.</p>
<table><tr><th>rank</th><th>controller</th><th>element</th><th>verdict</th><th>onset</th><th>impact (ISE ratio)</th>
<th>size / tolerance</th><th>report</th></tr>
{% for row in rows %}<tr><td>{{ row.rank }}</td><td>{{ row.controller }}</td><td>{{ row.element or "-" }}</td>
<td class="{{ row.verdict }}">{{ row.verdict }}</td><td>{{ row.onset or "-" }}</td>
<td>{{ "%.3g"|format(row.ise_ratio) if row.ise_ratio is not none else "-" }}</td>
<td>{{ "%.3g"|format(row.size_over_tolerance) if row.size_over_tolerance is not none else "-" }}</td>
<td>{% if row.report %}<a href="{{ row.report }}/index.html">{{ row.controller }}</a>{% else %}{{ row.reason }}
{% endif %}</td></tr>
{% endfor %}</table></body></html>
"""


def index_page(rows: list[dict[str, Any]], controllers: int) -> str:
    """The fleet's index page: the ranked summary, each row linking its controller's report."""
    import jinja2

    template = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined).from_string(_INDEX)
    return template.render(rows=rows, controllers=controllers)


def format_summary(rows: list[dict[str, Any]]) -> str:
    """The ranked summary as a terminal table (failed entries with their reason)."""
    lines = [f"{'rank':>4}  {'controller':<14} {'element':<8} {'verdict':<12} {'impact':>8} {'size/tol':>8}  onset"]
    for row in rows:
        impact = "-" if row["ise_ratio"] is None else f"{row['ise_ratio']:.3g}"
        size = "-" if row["size_over_tolerance"] is None else f"{row['size_over_tolerance']:.3g}"
        tail = row["reason"] if row["verdict"] == "failed" else row["onset"] or "-"
        lines.append(
            f"{row['rank']:>4}  {row['controller']:<14} {row['element'] or '-':<8} {row['verdict']:<12} "
            f"{impact:>8} {size:>8}  {tail}"
        )
    return "\n".join(lines) + "\n"


def _write(args: argparse.Namespace, rows: list[dict[str, Any]], reports: dict[str, Any]) -> None:
    from ..outputs import write_text
    from ..report import write_json

    try:
        if args.json:
            write_json(
                {"tool": "pmr_ros", "command": "diagnose --fleet", "summary": rows, "controllers": reports}, args.json
            )
        if args.report:
            index = Path(args.report) / "index.html"
            write_text(index, index_page(rows, len(reports)))
            print(f"report: {index}")
    except OSError as exc:
        raise CommandError(f"cannot write the fleet's outputs: {exc.strerror or exc}") from None


def diagnose_fleet(args: argparse.Namespace) -> int:
    """Run ``pmr-ros diagnose --fleet``; 0 when every controller ran, 2 when some failed (after the summary)."""
    from ..service.fleet import read_fleet, run_fleet
    from .rolling import check_monitor_options

    if args.bag is not None:
        raise CommandError(f"--fleet: the fleet file names the data; drop {args.bag}")
    check_monitor_options(args)
    entries = read_fleet(args.fleet)
    defaults = {"window": args.window, "step": args.step}
    entries = [
        replace(e, **{k: v for k, v in defaults.items() if v is not None and getattr(e, k) is None}) for e in entries
    ]
    if args.report:
        Path(args.report).mkdir(parents=True, exist_ok=True)
        entries = [replace(e, report=Path(args.report) / e.name) for e in entries]
    if not args.quiet:
        print(f"diagnosing {len(entries)} controllers", file=sys.stderr)
    rows, reports = run_fleet(entries, jobs=args.jobs, scheduler=args.scheduler)
    sys.stdout.write(format_summary(rows))
    _write(args, rows, reports)
    failed = [row["controller"] for row in rows if row["verdict"] == "failed"]
    if failed:
        raise CommandError(
            f"--fleet {args.fleet}: {len(failed)} of {len(entries)} controllers failed: {', '.join(failed)}"
        )
    return 0
