"""``pmr-ros diagnose FILE.csv|FILE.parquet`` and ``--report DIR``: plant data in, HTML report out.

Used by :mod:`pmr_ros.commands.diagnose` (not a sub-command of its own):
:func:`source_kind` tells a bag from a historian export by what the path is,
:func:`diagnose_table` diagnoses an export (read and cleaned by
:mod:`pmr_ros.data`, one estimate from all its clean stretches), and
:func:`write_bag_report` writes the HTML report of a bag's last window.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from . import EXIT_INSUFFICIENT, CommandError, load_checked_config
from .model_output import check_model_output, close_the_loop

__all__ = ["BAG", "TABLE", "diagnose_table", "progress_callback", "source_kind", "write_bag_report"]

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


def progress_callback(label: str) -> Any:
    """A progress bar with an ETA on a terminal (stderr), None (quiet) elsewhere; and a function that ends it."""
    if not sys.stderr.isatty():
        return None, lambda: None
    from ..progress import ProgressBar

    bar: list[ProgressBar] = []

    def update(done: int, total: int) -> None:
        if not bar:
            bar.append(ProgressBar(total, label, stream=sys.stderr, unit="MB" if label.endswith("csv") else "rows"))
        bar[0].update(done - bar[0].done)

    return update, lambda: bar[0].close() if bar else None


def _table_config(args: argparse.Namespace) -> Any:
    if not args.config:
        raise CommandError(
            f"{args.bag}: a historian export holds no model; pass --config FILE (a params file with the controller's "
            "model in its system block, and a data block if the columns are not named time, r_<output>, u_<input>, "
            "y_<output>)"
        )
    overrides = {"pmr": {"method": args.method}} if getattr(args, "method", None) else None
    return load_checked_config(args.config, overrides)


def _with_data_quality(diagnosis: Any, args: argparse.Namespace, config: Any, data: Any) -> Any:
    """The diagnosis with its data-quality figures.

    Slow disturbances from the diagnosed (deviation) stretches; saturation from the values as read, and only
    against limits the params file gives (``mpc.u_min``, ``mpc.u_max`` in the data's units): the defaults
    describe the simulation, not the plant.
    """
    from dataclasses import replace

    from ..config.files import read_parameter_file
    from ..core.data_quality import assess, saturation
    from ..core.diagnosis import useful_stretches, with_data_quality

    settings = config.quality
    kw = {"model": config.model, "pmr": config.pmr, "parametric": config.parametric}
    used = useful_stretches(data.stretches(), **kw, method="classic")
    if not used:
        return diagnosis
    figures = assess(used, model=config.model, welch=config.pmr.welch, settings=settings.without_limits())
    if {"u_min", "u_max"} <= set(read_parameter_file(args.config).get("mpc") or {}):
        at, beyond = saturation(
            data.stretches(deviations=False),
            u_min=settings.u_min,
            u_max=settings.u_max,
            tolerance=settings.limit_tolerance,
        )
        figures = replace(figures, saturated=at, outside=beyond)
    else:
        settings = settings.without_limits()
    return with_data_quality(diagnosis, figures, model=config.model, settings=settings)


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
    from ..core.diagnosis import diagnose_stretches
    from ..data import DataError, load_plant_data
    from ..report import format_table
    from ..report.html import ReportInput

    config = _table_config(args)
    check_model_output(args)
    update, close = progress_callback(f"reading {Path(args.bag).name}")
    try:
        data = load_plant_data(args.bag, config, progress=update)
    except DataError as exc:
        raise CommandError(str(exc)) from None
    finally:
        close()
    stretches = data.stretches()
    diagnosis = diagnose_stretches(stretches, model=config.model, pmr=config.pmr, parametric=config.parametric)
    if diagnosis.status == "ok":
        diagnosis = _with_data_quality(diagnosis, args, config, data)
        diagnosis = close_the_loop(args, config, diagnosis)
    report = _data_report(config, diagnosis, data, str(args.bag))
    if diagnosis.status == "ok":
        sys.stdout.write(format_table(diagnosis, report))
        _print_cleaning(data)
    _write_outputs(args, report, ReportInput(report, diagnosis, stretches, data, config))
    if diagnosis.status != "ok":
        usable = int(data.usable.sum())
        raise CommandError(
            f"{args.bag}: too little clean data for the {diagnosis.method} method: {usable} usable samples in "
            f"{len(stretches)} stretch(es) after cleaning; {diagnosis.reason}",
            code=EXIT_INSUFFICIENT,
        )
    return 0


def _bag_window(bag: Any, result: Any) -> tuple[dict[str, np.ndarray], int] | None:
    """r, u, y of the last diagnosed window of a bag, in the model's channel order; None without one."""
    from ..contract.layout import read_signal
    from ..contract.topics import SIGNAL_TOPICS, topic

    window = result.final.window if result.final is not None else {}
    if "first_sample" not in window:
        return None
    model = result.config.model
    first, samples = int(window["first_sample"]), int(window["window_samples"])
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    signals = {s: np.full((samples, len(n)), np.nan) for s, n in names.items()}
    by_topic = {topic(SIGNAL_TOPICS[s]).resolved(result.namespace): s for s in names}
    for message in bag.messages(set(by_topic)):
        signal = by_topic[message.topic]
        stamp, channels, values = read_signal(bag.decode(message))
        k = int(round(stamp / model.sample_time)) - first
        if 0 <= k < samples and tuple(channels) == names[signal] and values.size == len(channels):
            signals[signal][k] = values
    return signals, first


def write_bag_report(args: argparse.Namespace, result: Any, bag: Any, report: dict[str, Any]) -> None:
    """Write the HTML report of a bag's last diagnosed window (``--report DIR``).

    Raises
    ------
    CommandError
        The directory cannot be written.
    """
    from ..contract.windowing import window_dither
    from ..core.stretch import Stretch
    from ..data import PlantData
    from ..report.html import ReportInput

    found = _bag_window(bag, result)
    if found is None:
        print("note: no window of the bag was diagnosed: no HTML report", file=sys.stderr)
        return
    window, first = found
    config = result.config
    data = PlantData.from_record(
        window, source=str(bag.path), sample_time_s=config.model.sample_time, start=f"sample {first}"
    )
    dither = window_dither(config, first, data.samples)
    stretches = [Stretch(window["r"], window["u"], window["y"], dither)]
    page = ReportInput(report, result.final_diagnosis, stretches, data, config)
    _write_outputs(argparse.Namespace(json=None, report=args.report), report, page)
