"""``pmr-ros diagnose BAG|FILE.csv|FILE.parquet``: offline PMR diagnosis of a bag or a historian export.

A historian export goes to :mod:`pmr_ros.commands.plant_data` (read, cleaned,
one estimate from all its clean stretches); the rest of this module is a bag's.

The bag's r, u and y go through the live diagnostician's alignment and window
schedule (:mod:`pmr_ros.bag.offline`) with the recorded configuration (or
``--config``).  The table shows the last window; every window the live
diagnostician published on /diagnostics is re-diagnosed and compared
(:func:`pmr_ros.core.results.compare_diagnoses`: verdicts exact, numbers to a
stated tolerance, since the bag may come from another machine).
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from ..outputs import check_outputs
from ..service.closing import close_and_write
from . import EXIT_INSUFFICIENT, CommandError, add_method_argument, add_namespace_argument, positive_int, writable_file
from .arguments import JSON, WIDE, add_options, config_option
from .model_output import add_model_arguments, check_model_output
from .monitor_options import MONITOR_OPTIONS

if TYPE_CHECKING:
    from ..bag.offline import OfflineResult
    from ..bag.reader import Bag
    from ..core.results import Diagnosis


EXIT_DIFFERENT = 4
"""Exit code when an offline verdict differs from the one recorded for the same window."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros diagnose`` to the sub-command parsers."""
    p = sub.add_parser(
        "diagnose",
        help="diagnose a rosbag2 bag or a historian export (CSV, Parquet) offline (no ROS graph)",
        description=(
            "Diagnose a bag's r, u, y offline exactly as the live pmr_diagnostician does (same alignment, windows and "
            "model), "
            "with the bag's recorded configuration or --config, and compare with the verdicts recorded on "
            "/diagnostics. A historian export (.csv, .parquet) is read with the data block of --config (columns, "
            "time stamps, bad values), cleaned, and diagnosed as one estimate from all its clean stretches."
        ),
    )
    p.add_argument(
        "bag",
        metavar="PATH",
        nargs="?",
        help="rosbag2 bag directory (or a .mcap file), or a historian export (.csv or .parquet; needs --config); "
        "none with --fleet",
    )
    add_options(
        p,
        [
            config_option("ROS 2 params file with the controller's model (default: the bag's recorded configuration)"),
            JSON,
            WIDE,
        ],
    )
    add_report_argument(p)
    add_method_argument(p)
    add_namespace_argument(
        p, "a bag: diagnose the node set recorded under this namespace (default: the one the bag holds)"
    )
    add_model_arguments(p)
    p.add_argument(
        "--min-samples",
        type=positive_int,
        metavar="N",
        help="a bag: fewest samples for a verdict (default: diagnostician.min_samples of the configuration; for "
        "a 'pmr-ros run --bag' recording cut short, the declared default)",
    )
    add_options(p, MONITOR_OPTIONS)
    p.set_defaults(handler=handle)


def add_report_argument(parser: argparse.ArgumentParser) -> None:
    """--report DIR: the HTML report with its figures (bags and historian exports alike)."""
    parser.add_argument(
        "--report",
        metavar="DIR",
        help="also write an HTML report (index.html, figures/*.png): verdict matrix, per-element PMR with confidence "
        "band and fitted curve, data cleaning and time plot",
    )


def offline_report(result: OfflineResult, bag: Bag, diagnosis: Diagnosis | None = None) -> dict:
    """The JSON-ready report of an offline diagnosis (the run report plus bag and window fields).

    ``diagnosis`` replaces the final window's diagnosis (e.g. with its control impact added).
    """
    from ..report import build_report

    config = result.config
    recorded = bag.run_config()
    scenario = recorded.scenario if recorded is not None and result.config_origin == "bag" else None
    seed = recorded.seed if recorded is not None and result.config_origin == "bag" else None
    final_diagnosis = diagnosis if diagnosis is not None else result.final_diagnosis
    report = build_report(config, final_diagnosis, command="diagnose", scenario=scenario or None, seed=seed)
    final = result.final
    report["path"] = "bag"
    report["bag"] = {
        "path": str(bag.path),
        "storage": bag.storage,
        "complete": bag.complete,
        "messages": bag.counts,
        "configuration": result.config_origin,
    }
    report["window"] = dict(final.window) if final is not None else {}
    report["window_at_end_of_bag"] = result.end_of_bag
    report["updates"] = [{"kind": o.kind, "reason": o.reason, **o.window} for o in result.outcomes]
    report["recorded_comparison"] = {
        "windows": len(result.comparisons),
        "equal": sum(1 for c in result.comparisons if c["equal"]),
        "different": [c for c in result.comparisons if not c["equal"]],
    }
    report["warnings"] = result.warnings[:100]
    report["dropped_messages"] = result.drops.to_dict()
    report["gaps"] = result.gaps
    report["notes"] = list(result.notes)
    return report


def print_data_notes(result: OfflineResult, bag: Bag) -> None:
    """What the console says about the data beside the table: window, drops, gaps, a recording cut short."""
    window = result.final.window if result.final is not None else {}
    if window.get("window_samples"):
        print(
            f"window: samples {window.get('first_sample')}..{window.get('last_sample')} ({window['window_samples']} "
            f"samples), configuration from {result.config_origin}"
        )
    for line in result.drops.lines():
        print(f"dropped: {line}" if not line.startswith("  ") else line)
    if result.gaps:
        print(f"gaps: the data broke {result.gaps} time(s); each unbroken stretch long enough is diagnosed")
    for note in result.notes:
        print(f"note: {note}")
    if result.end_of_bag:
        print(
            "note: the data end between two diagnostician updates; the last window is diagnosed at the end of the bag"
        )
    if not bag.complete:
        print(
            f"note: {bag.path} is incomplete ({bag.recovery}): read as far as it is whole "
            f"({bag.message_count} messages)"
        )


def print_comparison(report: dict, result: OfflineResult) -> None:
    """How the offline verdicts compare with those the live node recorded on /diagnostics."""
    from ..core.results import RELATIVE_TOLERANCE

    compared = report["recorded_comparison"]
    if compared["windows"]:
        print(
            f"recorded /diagnostics: {compared['equal']} of {compared['windows']} verdict windows agree offline "
            f"(verdicts, flags and delays exact, numbers within {RELATIVE_TOLERANCE:g} relative)"
        )
    for entry in compared["different"][:3]:
        detail = (
            "; ".join(entry.get("differences", [])[:3])
            or f"recorded {entry['recorded_status']}, offline {entry['offline_status']}"
        )
        print(f"  window {entry['first_sample']}..{entry['last_sample']} differs: {detail}")
    if result.not_diagnosed_live:
        print(
            f"recorded /diagnostics: {result.not_diagnosed_live} window(s) without a live verdict (stale or too few "
            "samples) are not compared"
        )


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros diagnose``; the exit code (0 ok, 3 insufficient data, 4 a recorded verdict differs)."""
    from .plant_data import TABLE, diagnose_table, source_kind
    from .rolling import check_monitor_options

    if args.fleet:
        from .fleet_summary import diagnose_fleet

        return diagnose_fleet(args)
    if args.bag is None:
        raise CommandError("diagnose: give a bag or a historian export (PATH), or --fleet FLEET.yaml")
    check_outputs(args, inputs=(args.bag, args.config), files=("json", "write_model", "trend"), folders=("report",))
    check_monitor_options(args)
    if args.json:
        writable_file(args.json, "--json")  # before any work, for a bag and an export alike
    if args.window:
        from ..service.monitoring import start_workers

        start_workers(jobs=args.jobs, scheduler=args.scheduler)  # they load their modules while the record is read
    if source_kind(args.bag) == TABLE:
        if args.min_samples is not None:
            raise CommandError(f"--min-samples: an option for a bag; {args.bag} is judged on all its clean data")
        if args.namespace is not None:
            raise CommandError(f"--namespace: an option for a bag; {args.bag} is a historian export")
        return diagnose_table(args)
    return diagnose_bag_command(args)


def _write_bag_outputs(args: argparse.Namespace, report: dict, result: OfflineResult, bag: Bag) -> None:
    """--json and --report of a bag's diagnosis."""
    from ..report import write_json

    if args.json:
        try:
            write_json(report, args.json)
        except OSError as exc:
            raise CommandError(f"--json {args.json}: cannot write: {exc.strerror or exc}") from None
    if args.report:
        from .plant_data import write_bag_report

        write_bag_report(args, result, bag, report)


def _bag_windows(args: argparse.Namespace) -> int:
    """``diagnose BAG --window``: the bag's whole record read once, every window diagnosed."""
    from ..bag.reader import open_bag
    from ..bag.storage import BagError
    from ..report import build_report
    from ..service.bag_diagnosis import bag_record
    from .rolling import diagnose_windows

    try:
        bag = open_bag(args.bag)
        data, config = bag_record(bag, args.config, args.method, namespace=args.namespace)
    except BagError as exc:
        raise CommandError(str(exc)) from None

    def report_of(diagnosis: Diagnosis) -> dict:
        report = build_report(config, diagnosis, command="diagnose", scenario=None, seed=None)
        report.update(path="bag", source=str(bag.path))
        return report

    return diagnose_windows(args, data, config, report_of)


def diagnose_bag_command(args: argparse.Namespace) -> int:
    """``pmr-ros diagnose BAG``; the exit code (0 ok, 3 insufficient data, 4 a recorded verdict differs)."""
    from ..bag.reader import open_bag
    from ..bag.storage import BagError
    from ..report import format_table
    from ..service.bag_diagnosis import diagnose_bag

    check_model_output(args)
    if args.window:
        return _bag_windows(args)
    try:
        bag = open_bag(args.bag)
        result = diagnose_bag(bag, args.config, args.method, min_samples=args.min_samples, namespace=args.namespace)
        notes: list[str] = []
        diagnosis = close_and_write(
            result.config, result.final_diagnosis, model_path=getattr(args, "write_model", None), notes=notes
        )
        report = offline_report(result, bag, diagnosis)
        if notes:
            report["impact_note"] = " ".join(notes)
    except BagError as exc:
        raise CommandError(str(exc)) from None
    sys.stdout.write(format_table(diagnosis, report, wide=args.wide))
    print_data_notes(result, bag)
    for note in notes:
        print(f"note: {note}")
    print_comparison(report, result)
    _write_bag_outputs(args, report, result, bag)
    if report["recorded_comparison"]["different"]:
        return EXIT_DIFFERENT
    return 0 if result.final_diagnosis.status == "ok" else EXIT_INSUFFICIENT
