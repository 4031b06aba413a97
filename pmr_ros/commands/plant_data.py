"""``pmr-ros diagnose FILE.csv|FILE.parquet`` and ``--report DIR``: plant data in, HTML report out.

Used by :mod:`pmr_ros.commands.diagnose` (not a sub-command of its own):
:func:`source_kind` tells a bag from a historian export by what the path is,
:func:`diagnose_table` diagnoses an export (:mod:`pmr_ros.service.historian`)
and prints and writes its reports, and :func:`write_bag_report` writes the
HTML report of a bag's last window (:mod:`pmr_ros.service.bag_diagnosis`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..progress import progress_callback
from . import EXIT_INSUFFICIENT, CommandError, load_checked_config
from .model_output import check_model_output

__all__ = ["BAG", "TABLE", "diagnose_table", "source_kind", "write_bag_report"]

BAG, TABLE = "bag", "table"
"""What ``pmr-ros diagnose`` reads."""

BAG_SUFFIXES = (".mcap", ".db3")


def source_kind(path: str | Path) -> str:
    """:data:`BAG` (a directory, a .mcap or .db3 file, or nothing there) or :data:`TABLE` (.csv, .parquet).

    Raises
    ------
    CommandError
        A file that is neither (e.g. a spreadsheet).
    """
    from ..data import FORMATS, table_format

    path = Path(path)
    if table_format(path) is not None and not path.is_dir():
        return TABLE
    if path.is_dir() or not path.exists() or path.suffix.lower() in BAG_SUFFIXES:
        return BAG
    raise CommandError(
        f"{path}: not a bag (a rosbag2 bag is a directory or an .mcap file) nor a historian export "
        f"({', '.join(FORMATS)}); save the export as CSV or Parquet"
    )


def _table_config(args: argparse.Namespace) -> Any:
    if not args.config:
        raise CommandError(
            f"{args.bag}: a historian export holds no model; pass --config FILE (a params file with the controller's "
            "model in its system block, and a data block if the columns are not named time, r_<output>, u_<input>, "
            "y_<output>)"
        )
    overrides = {"pmr": {"method": args.method}} if getattr(args, "method", None) else None
    return load_checked_config(args.config, overrides)


def _data_report(config: Any, diagnosis: Any, data: Any, path: str) -> dict[str, Any]:
    from ..report import build_report

    report = build_report(config, diagnosis, command="diagnose", scenario=None, seed=None)
    report["path"] = "data"
    report["source"] = path
    report["data"] = {
        "start": data.start,
        "sample_time_s": data.sample_time_s,
        "samples": data.samples,
        "cleaning": [{"step": s.name, "count": s.count, "unit": s.unit, "detail": s.detail} for s in data.steps],
        "stretches": [[a, b] for a, b in data.stretch_bounds()],
    }
    return report


def _print_cleaning(data: Any) -> None:
    print("data cleaning:")
    for step in data.steps:
        if step.count or step.name in ("rows read", "usable samples"):
            detail = f" ({step.detail})" if step.detail else ""
            print(f"  {step.name}: {step.count} {step.unit}{detail}")


def _write_outputs(args: argparse.Namespace, report: dict[str, Any], page: Any) -> None:
    from ..report import write_json

    if args.json:
        try:
            write_json(report, args.json)
        except OSError as exc:
            raise CommandError(f"--json {args.json}: cannot write: {exc.strerror or exc}") from None
    if getattr(args, "report", None):
        from ..report.html import write_html_report

        try:
            index = write_html_report(args.report, page)
        except OSError as exc:
            raise CommandError(f"--report {args.report}: cannot write: {exc.strerror or exc}") from None
        print(f"report: {index}")


def diagnose_table(args: argparse.Namespace) -> int:
    """Diagnose a CSV or Parquet export; the exit code (0 verdicts, 3 too little clean data).

    Raises
    ------
    CommandError
        Bad input (one line naming the file, column, row and value), or too
        little clean data for the method (exit code 3, after the reports are written).
    """
    from ..report import format_table
    from ..report.html import ReportInput
    from ..service.historian import diagnose_table as diagnose_export

    config = _table_config(args)
    check_model_output(args)
    if getattr(args, "window", None):
        return _diagnose_table_windows(args, config)
    update, close = progress_callback(f"reading {Path(args.bag).name}")
    try:
        found = diagnose_export(args.bag, config, progress=update, model_path=getattr(args, "write_model", None))
    finally:
        close()
    diagnosis, data, stretches = found.diagnosis, found.data, found.stretches
    report = _data_report(found.config, diagnosis, data, str(args.bag))
    if found.notes:
        report["impact_note"] = " ".join(found.notes)
    if diagnosis.status == "ok":
        sys.stdout.write(format_table(diagnosis, report, wide=args.wide))
        _print_cleaning(data)
        for note in found.notes:
            print(f"note: {note}")
    _write_outputs(args, report, ReportInput(report, diagnosis, stretches, data, found.config))
    if diagnosis.status != "ok":
        usable = int(data.usable.sum())
        raise CommandError(
            f"{args.bag}: too little clean data for the {diagnosis.method} method: {usable} usable samples in "
            f"{len(stretches)} stretch(es) after cleaning; {diagnosis.reason}",
            code=EXIT_INSUFFICIENT,
        )
    return 0


def _diagnose_table_windows(args: argparse.Namespace, config: Any) -> int:
    """``--window``: the export read once, every window diagnosed (:mod:`pmr_ros.commands.rolling`)."""
    from ..service.historian import read_export
    from .rolling import diagnose_windows

    update, close = progress_callback(f"reading {Path(args.bag).name}")
    try:
        data = read_export(args.bag, config, progress=update)
    finally:
        close()
    return diagnose_windows(args, data, config, lambda diagnosis: _data_report(config, diagnosis, data, str(args.bag)))


def write_bag_report(args: argparse.Namespace, result: Any, bag: Any, report: dict[str, Any]) -> None:
    """Write the HTML report of a bag's last diagnosed window (``--report DIR``).

    Raises
    ------
    CommandError
        The directory cannot be written.
    """
    from ..report.html import ReportInput
    from ..service.bag_diagnosis import window_data

    found = window_data(bag, result)
    if found is None:
        print("note: no window of the bag was diagnosed: no HTML report", file=sys.stderr)
        return
    data, stretches = found
    page = ReportInput(report, result.final_diagnosis, stretches, data, result.config)
    _write_outputs(argparse.Namespace(json=None, report=args.report), report, page)
