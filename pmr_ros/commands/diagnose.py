"""``pmr-ros diagnose BAG``: offline PMR diagnosis straight from a bag, no ROS graph.

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

from . import EXIT_INSUFFICIENT, CommandError, add_method_argument, add_namespace_argument

EXIT_DIFFERENT = 4
"""Exit code when an offline verdict differs from the one recorded for the same window."""


def register(sub) -> None:
    """Add ``pmr-ros diagnose`` to the sub-command parsers."""
    p = sub.add_parser(
        "diagnose",
        help="diagnose a recorded rosbag2 bag offline (no ROS graph)",
        description=(
            "Diagnose a bag's r, u, y offline exactly as the live pmr_diagnostician does (same alignment, windows and "
            "model), "
            "with the bag's recorded configuration or --config, and compare with the verdicts recorded on /diagnostics."
        ),
    )
    p.add_argument("bag", metavar="BAG", help="rosbag2 bag directory (or a .mcap file)")
    p.add_argument(
        "--config",
        metavar="FILE",
        help="ROS 2 params file with the controller's model (default: the bag's recorded configuration)",
    )
    p.add_argument("--json", metavar="FILE", help="also write the report as JSON")
    add_method_argument(p)
    add_namespace_argument(p, "diagnose the node set recorded under this namespace (default: the one the bag holds)")
    p.set_defaults(handler=handle)


def offline_report(result, bag) -> dict:
    """The JSON-ready report of an offline diagnosis (the run report plus bag and window fields)."""
    from ..report import build_report

    config = result.config
    recorded = bag.run_config()
    scenario = recorded.scenario if recorded is not None and result.config_origin == "bag" else None
    seed = recorded.seed if recorded is not None and result.config_origin == "bag" else None
    report = build_report(config, result.final_diagnosis, command="diagnose", scenario=scenario or None, seed=seed)
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
    return report


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros diagnose``; the exit code (0 ok, 3 insufficient data, 4 a recorded verdict differs)."""
    from ..bag.offline import diagnose_bag
    from ..bag.reader import open_bag
    from ..bag.schema import BagError
    from ..core.results import RELATIVE_TOLERANCE
    from ..report import format_table, write_json

    try:
        bag = open_bag(args.bag)
        result = diagnose_bag(bag, args.config, args.method, namespace=args.namespace)
        report = offline_report(result, bag)
    except BagError as exc:
        raise CommandError(str(exc)) from None
    sys.stdout.write(format_table(report))
    window = report["window"]
    if window.get("window_samples"):
        print(
            f"window: samples {window.get('first_sample')}..{window.get('last_sample')} ({window['window_samples']} "
            f"samples), configuration from {result.config_origin}"
        )
    if result.end_of_bag:
        print(
            "note: the data end between two diagnostician updates; the last window is diagnosed at the end of the bag"
        )
    if not bag.complete:
        print(
            f"note: {bag.path} was not closed by its recorder; read up to its last flush ({bag.message_count} messages)"
        )
    compared = report["recorded_comparison"]
    if compared["windows"]:
        print(
            f"recorded /diagnostics: {compared['equal']} of {compared['windows']} windows agree offline "
            f"(verdicts, flags and delays exact, numbers within {RELATIVE_TOLERANCE:g} relative)"
        )
        for entry in compared["different"][:3]:
            detail = (
                "; ".join(entry.get("differences", [])[:3])
                or f"recorded {entry['recorded_status']}, offline {entry['offline_status']}"
            )
            print(f"  window {entry['first_sample']}..{entry['last_sample']} differs: {detail}")
    if args.json:
        try:
            write_json(report, args.json)
        except OSError as exc:
            raise CommandError(f"--json {args.json}: cannot write: {exc.strerror or exc}") from None
    if compared["different"]:
        return EXIT_DIFFERENT
    return 0 if result.final_diagnosis.status == "ok" else EXIT_INSUFFICIENT
