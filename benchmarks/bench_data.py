"""Reading, cleaning and diagnosing a long historian export, and the HTML report (a script, not a test).

    .venv/bin/python benchmarks/bench_data.py [--rows N] [--extra-tags M]

A Wood-Berry MPC run (16,384 samples, repeated to ``--rows`` with fresh
noise) is exported as a historian would (ISO stamps, tags, "Bad" cells,
``--extra-tags`` other tags the configuration does not name) to CSV and
Parquet; the script prints the file sizes, the wall time of
:func:`pmr_ros.data.load_plant_data` (read + grid + clean), of the diagnosis
of all clean stretches, of the HTML report, and the process's peak memory.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.data import load_plant_data

TAGS = {"r": ("XC101.SP", "XC102.SP"), "u": ("FC201.OP", "FC202.OP"), "y": ("XI101.PV", "XI102.PV")}


def export(rows: int, extra_tags: int) -> pd.DataFrame:
    """A long export: the run repeated with fresh measurement noise, other tags beside it, some "Bad" cells."""
    config = load_config()
    record = simulate(config, samples=16384, seed=1)
    repeats = -(-rows // 16384)
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"Timestamp": pd.date_range("2024-01-01", periods=rows, freq="60s", tz="UTC")})
    frame["Timestamp"] = frame["Timestamp"].dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    for signal, tags in TAGS.items():
        values = np.tile(getattr(record, signal), (repeats, 1))[:rows]
        if signal == "y":
            values = values + 0.01 * rng.normal(size=values.shape)
        for j, tag in enumerate(tags):
            frame[tag] = values[:, j]
    for j in range(extra_tags):
        frame[f"TI{300 + j}.PV"] = rng.normal(size=rows)
    frame = frame.astype({TAGS["y"][0]: object})
    frame.loc[rng.choice(rows, size=rows // 2000, replace=False), TAGS["y"][0]] = "Bad"
    return frame


def timed(run):
    """``(result, wall time [s])``."""
    start = time.perf_counter()
    out = run()
    return out, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=525_600, help="rows (default: one year at 1 min)")
    parser.add_argument("--extra-tags", type=int, default=20)
    args = parser.parse_args()
    data_block = {
        "time_column": "Timestamp",
        "time_unit_s": 60.0,
        "setpoint_columns": list(TAGS["r"]),
        "input_columns": list(TAGS["u"]),
        "output_columns": list(TAGS["y"]),
    }
    config = load_config(overrides={"data": data_block})
    frame, made = timed(lambda: export(args.rows, args.extra_tags))
    print(f"export of {args.rows} rows x {frame.shape[1]} columns made in {made:.1f} s")
    with tempfile.TemporaryDirectory() as folder:
        csv, parquet = Path(folder) / "export.csv", Path(folder) / "export.parquet"
        frame.to_csv(csv, index=False)
        frame.astype({TAGS["y"][0]: str}).to_parquet(parquet)
        del frame
        for path in (csv, parquet):
            data, seconds = timed(lambda path=path: load_plant_data(path, config))
            size = path.stat().st_size / 1e6
            print(f"{path.suffix[1:]:8s} {size:7.1f} MB: read + grid + clean {seconds:6.2f} s "
                  f"({args.rows / seconds:,.0f} rows/s), {int(data.usable.sum())} usable samples in "
                  f"{len(data.stretch_bounds())} stretches")  # fmt: skip
        stretches = data.stretches()
        for method in ("classic", "parametric"):
            pmr = replace(config.pmr, method=method)
            diagnosis, seconds = timed(
                lambda pmr=pmr: diagnose_stretches(stretches, model=config.model, pmr=pmr, parametric=config.parametric)
            )
            print(f"diagnosis ({method}) of all stretches: {seconds:.2f} s, status {diagnosis.status}")
        from pmr_ros.report import build_report
        from pmr_ros.report.html import ReportInput, write_html_report

        report = build_report(config, diagnosis, command="diagnose", scenario=None, seed=None)
        page = ReportInput(report, diagnosis, stretches, data, config)
        index, seconds = timed(lambda: write_html_report(Path(folder) / "report", page))
        print(f"HTML report with its figures: {seconds:.2f} s, index.html {index.stat().st_size / 1e6:.1f} MB")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory (max RSS): {peak:.0f} MB")


if __name__ == "__main__":
    sys.exit(main())
