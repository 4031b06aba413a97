"""What a benchmark keeps in its ``out`` folder: the journal, results.parquet, the scores and the report.

:func:`open_journal` continues (``--resume``) or begins the journal of finished runs
(:mod:`pmr_ros.benchmark.journal`), :func:`left_to_do` and :func:`planned_rows` read it;
:func:`write_results` writes results.parquet (one row per run, method and element, with the run's
cell), :func:`score_and_write` the scores, the ROC table and the markdown report with its figures.
:mod:`.benchmark_run` runs the benchmark between them.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..benchmark import markdown, plots, scoring
from ..benchmark.journal import Journal, fingerprint
from ..benchmark.runner import RunTask
from ..benchmark.scenarios import run_table
from ..outputs import write_bytes, write_text
from .refusal import ServiceError

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = [
    "CELLS",
    "JOURNAL",
    "MANIFEST",
    "RESULTS",
    "left_to_do",
    "open_journal",
    "planned_rows",
    "score_and_write",
    "write_results",
]

JOURNAL = "runs"  # the journal folder in ``out``

RESULTS = "results.parquet"  # in ``out``: one row per run, method and element (write_results)
CELLS = ["unit", "samples", "disturbance", "seed"]
"""The columns of results.parquet that name a run's cell (:func:`write_results`), not a method's result."""

MANIFEST = "benchmark.json"
"""Beside results.parquet: the run's wall time [s] and number of runs, for ``--report-only``."""


def write_results(path: Path, rows: pd.DataFrame, lines: pd.DataFrame) -> pd.DataFrame:
    """``rows`` with their runs' cells, in run, method and element order, written to ``path``: the results."""
    cells = run_table(lines)[["run", *CELLS]]
    results = cells.merge(rows, on="run", how="right").sort_values(["run", "method", "element"])
    results.to_parquet(path, index=False)
    return results


def _write_report(report: Path, scores: pd.DataFrame, labelled: pd.DataFrame, wall_s: float) -> None:
    """The markdown report at ``report``, its figures in ``figures/`` beside it."""
    folder = report.parent / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    figures = {}
    drawn = {
        "benchmark_detection.png": ("detection at 1 % false alarms", plots.length_figure,
                                    ("detection_at_1", "detection at 1 % FA")),
        "benchmark_coverage.png": ("dK interval coverage", plots.length_figure, ("gain_coverage", "dK coverage")),
        "benchmark_time.png": ("CPU time per diagnosis", plots.length_figure, ("cpu_s", "CPU s / diagnosis")),
    }  # fmt: skip
    for name, (title, draw, args) in drawn.items():
        write_bytes(folder / name, draw(scores, *args, log=name == "benchmark_time.png"))
        figures[title] = f"figures/{name}"
    longest = int(labelled["samples"].max())
    write_bytes(folder / "benchmark_roc.png", plots.roc_figure(labelled, samples=longest))
    figures[f"ROC at {longest} samples"] = "figures/benchmark_roc.png"
    subset = _subset_text(labelled)
    paired = scoring.paired_scores(labelled)
    text = markdown.report_text(scores, subset=subset, figures=figures, wall_s=wall_s, paired=paired)
    write_text(report, text)


def _subset_text(labelled: pd.DataFrame) -> str:
    runs = labelled.drop_duplicates("run")
    cells = runs.groupby(["unit", "disturbance", "samples"]).size()
    units = ", ".join(sorted(set(runs["unit"])))
    lengths = ", ".join(f"{n:,}" for n in sorted(set(runs["samples"])))
    return (
        f"{len(runs)} runs of the scenario file (units {units}; lengths {lengths} samples; "
        f"{cells.min()}-{cells.max()} runs per unit, disturbance and length)"
    )


def score_and_write(
    results: pd.DataFrame, lines: pd.DataFrame, *, out: Path, report: Path, wall_s: float
) -> pd.DataFrame:
    """The scores of ``results`` (the runs of scenario ``lines``), written to ``out`` with the report at ``report``."""
    labelled = scoring.label_results(results.drop(columns=CELLS), lines)
    scores = scoring.score(labelled)
    write_text(out / "scores.csv", scores.to_csv(index=False))
    write_text(out / "roc.csv", scoring.roc_table(labelled).to_csv(index=False))
    _write_report(report, scores, labelled, wall_s)
    return scores


def left_to_do(tasks: list[RunTask], done: set[tuple[int, str]]) -> list[RunTask]:
    """``tasks`` without the methods ``done`` has for their run; tasks with no method left dropped."""
    left = [replace(t, methods=tuple(m for m in t.methods if (t.run, m) not in done)) for t in tasks]
    return [t for t in left if t.methods]


def planned_rows(journal: Journal, tasks: list[RunTask]) -> pd.DataFrame:
    """The journal's rows of the (run, method) pairs of ``tasks``."""
    rows = journal.read()
    planned = {(t.run, m) for t in tasks for m in t.methods}
    wanted = [(int(r), str(m)) in planned for r, m in zip(rows["run"], rows["method"], strict=True)]
    return rows[wanted].reset_index(drop=True)


def _seed_journal(journal: Journal, path: Path, scenarios: pd.DataFrame, key: str) -> None:
    """Begin ``journal`` with the runs of the results.parquet at ``path``, once its runs are the scenario file's.

    Raises
    ------
    ServiceError
        A run of the file whose unit, length, disturbance or seed is not that of the same run in ``scenarios``.
    """
    import pandas as pd

    results = pd.read_parquet(path)
    runs = results[["run", *CELLS]].drop_duplicates("run")
    table = run_table(scenarios)[["run", *CELLS]]
    merged = runs.merge(table, on="run", how="left", suffixes=("", "_file"))
    for _, line in merged.iterrows():
        if any(str(line[c]) != str(line[f"{c}_file"]) for c in CELLS):
            raise ServiceError(
                f"--resume: {path}: run {int(line['run'])} is {line['unit']} of {line['samples']} samples there, "
                "not the scenario file's: results of another scenario file; use --force to start afresh"
            )
    journal.start(key)
    journal.seed(results.drop(columns=CELLS))


def open_journal(out: Path, scenarios: pd.DataFrame, *, resume: bool, force: bool) -> Journal:
    """``out``'s journal, continued (``resume``) or begun anew; one that holds runs is kept unless told.

    With ``resume``, an ``out`` that holds a results.parquet and no journal (a committed or downloaded run) is
    continued from that file (:func:`_seed_journal`).

    Raises
    ------
    ServiceError
        ``resume`` with runs of another scenario file, or neither ``resume`` nor ``force`` with runs kept.
    """
    journal, key, shipped = Journal(out / JOURNAL), fingerprint(scenarios), out / RESULTS
    if resume and not journal.count() and shipped.is_file():
        _seed_journal(journal, shipped, scenarios, key)
    if resume:
        try:
            journal.check(key)
        except ValueError as exc:
            raise ServiceError(f"--resume: {exc}; use --force to start afresh") from None
    elif journal.count() and not force:
        raise ServiceError(
            f"--out {out}: {journal.folder} holds {journal.count()} finished run(s); "
            "use --resume to continue them or --force to start afresh"
        )
    else:
        journal.start(key)
    return journal
