"""The benchmark's markdown report: what was run, the headline and full score tables, where a peer beats ours."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["HEADLINE_LENGTHS", "OURS", "report_text"]

OURS = "parametric"
"""The project's method, the one every peer is compared with."""

HEADLINE_LENGTHS = (8192, 32768)
"""Record lengths of the headline table (where run)."""

COLUMNS = {
    "samples": "samples",
    "runs": "runs",
    "detection": "detected (own verdict)",
    "false_alarm": "false alarms (own verdict)",
    "detection_at_1": "det. @1 % FA",
    "detection_at_5": "det. @5 % FA",
    "detection_at_1_big": "det. @1 % FA, abs dK >= 10 %",
    "localisation": "runs located exactly",
    "gain_error": "median abs dK error [pp]",
    "tau_error": "median abs dtau error [pp]",
    "delay_exact": "dD exact",
    "gain_coverage": "dK coverage",
    "tau_coverage": "dtau coverage",
    "inconclusive": "inconclusive",
    "cpu_s": "CPU s / diagnosis",
}
"""Score-table column -> heading; rates are printed in %."""

RATES = {
    "detection", "false_alarm", "detection_at_1", "detection_at_5", "detection_at_1_big",
    "localisation", "delay_exact", "gain_coverage", "tau_coverage", "inconclusive",
}  # fmt: skip


def _cell(column: str, value: object) -> str:
    if isinstance(value, float) and math.isnan(value):
        return "-"
    if column in RATES:
        return f"{100 * float(value):.0f} %"  # type: ignore[arg-type]
    if column in ("gain_error", "tau_error"):
        return f"{float(value):.2f}"  # type: ignore[arg-type]
    if column == "cpu_s":
        return f"{float(value):.2g}"  # type: ignore[arg-type]
    return str(value)


def table(scores: pd.DataFrame, columns: list[str]) -> str:
    """A markdown table of ``columns`` of the score table (headings of :data:`COLUMNS`)."""
    lines = ["| " + " | ".join(COLUMNS.get(c, c) for c in columns) + " |", "|" + "---|" * len(columns)]
    for _, line in scores.iterrows():
        lines.append("| " + " | ".join(_cell(c, line[c]) for c in columns) + " |")
    return "\n".join(lines)


def _case_name(unit: str, disturbance: int) -> str:
    return f"{unit}, {'coloured output disturbance' if disturbance else 'white measurement noise only'}"


def headline(scores: pd.DataFrame) -> str:
    """Per method and case at the headline lengths: detection at 1 % FA for |dK| >= 10 %, dK error, coverage, time."""
    part = scores[scores["samples"].isin(HEADLINE_LENGTHS)]
    if part.empty:
        part = scores[scores["samples"] == scores["samples"].max()]
    part = part.assign(case=[_case_name(u, d) for u, d in zip(part["unit"], part["disturbance"], strict=True)])
    columns = ["case", "samples", "method", "detection_at_1_big", "gain_error", "gain_coverage", "cpu_s"]
    return table(part.sort_values(["case", "samples", "method"]), columns)


def _pairs(paired: pd.DataFrame) -> Iterator[tuple[str, int, str, pd.Series, pd.Series, str]]:
    """Per (peer, unit, disturbance, length): ours' line and the peer's, both on the runs the peer diagnosed."""
    import pandas as pd

    if "peer" not in paired:  # a plain score table: each method on its own runs
        peers = sorted(set(paired["method"]) - {OURS})
        paired = pd.concat([paired[paired["method"].isin([OURS, p])].assign(peer=p) for p in peers])
    for (peer, unit, disturbance, samples), group in paired.groupby(["peer", "unit", "disturbance", "samples"]):
        ours, theirs = group[group["method"] == OURS], group[group["method"] == peer]
        if ours.empty or theirs.empty:
            continue
        n = int(theirs["runs"].iloc[0]) if "runs" in theirs else 0
        runs = f" on the {n} run{'' if n == 1 else 's'} both diagnosed" if n else ""
        yield _case_name(str(unit), int(disturbance)), int(samples), str(peer), ours.iloc[0], theirs.iloc[0], runs


def peer_wins(paired: pd.DataFrame, column: str = "detection_at_1", margin: float = 0.02) -> list[str]:
    """Sentences: each (case, length) where a peer's ``column`` exceeds ours by more than ``margin``.

    ``paired``: :func:`~pmr_ros.benchmark.scoring.paired_scores` (ours on each peer's runs), or a plain
    score table (each method on its own runs).
    """
    out = []
    for case, samples, peer, ours, theirs, runs in _pairs(paired):
        mine, other = float(ours[column]), float(theirs[column])
        if not math.isnan(mine) and other > mine + margin:
            out.append(
                f"- {case}, {samples} samples: {peer} {100 * other:.0f} % against ours {100 * mine:.0f} % "
                f"({COLUMNS[column]}{runs})"
            )
    return out


SETUP = """## How the runs were made

- **Scenarios**: `config/benchmark_scenarios.csv`, 1,560 labelled runs drawn once by the rule in
  `pmr_ros/benchmark/scenarios.py` (`python -m pmr_ros.benchmark.scenarios FILE` draws it again; a test
  checks the committed file against the rule): Wood-Berry, the 3x3 (`config/three_by_three.yaml`), the
  debutanizer 4x8 (`config/industrial_column.yaml`) and a 16x16 sparse unit (`config/sparse_sixteen.yaml`)
  with their PRBS setpoints (and MV dither where the unit has it), runs 1-1,040; then Wood-Berry and the
  4x8 in routine operation (`wood_berry_routine`, `debutanizer_routine`, runs 1,041-1,560): rare operator
  setpoint steps (`prbs.mode: steps`, one per CV every 240 samples on average) and a small MV dither
  (Wood-Berry +/-0.02, the 4x8 half its step-test dither); per modelled element no mismatch with
  probability 0.5, else dK +/-U[5, 30] %, dtau +/-U[5, 40] % and dD +/-{1, 2, 3} samples together;
  lengths 2,048 .. 32,768 samples; with and without a coloured output disturbance (3 x the measurement
  noise's standard deviation, pole 0.97); a run's seed is its number.
- **Simulation**: the MPC closed loop of each unit's shipped configuration, on the lockstep batch core.
- **Methods** see r, u, y (and the known dither) and the controller's model, nothing else; each
  element's evidence (for the fixed false-alarm rates and the ROC) is the method's own score:
  ours the largest standardized dK or dtau, the classic |M(0) - 1|, the partial correlation
  -log10 of its Bonferroni p, the PEM fits the same standardized change as ours.
- **Fixed false-alarm rates**: the threshold is set on each group's clean elements; with
  n of them a rate below 1/n means "above every clean element's evidence" (a group of
  8 Wood-Berry runs has about 16 clean elements, so there 1 % and 5 % are both that).
  A `-` is a number that does not apply (no clean element, no interval, no estimate).
- **Dataset**: `pmr-ros benchmark --export DIR` writes every run's r, u, y as Parquet, the models
  and the labels, with a schema (SCHEMA.md in DIR); pandas alone reads it.
- **Stopping and resuming**: each run's result rows are kept in `DIR/runs` the moment the run ends;
  `pmr-ros benchmark --resume` runs only the (run, method) pairs not there yet (the whole scenario
  file is many hours of CPU), and refuses a journal of another scenario file. A folder with a
  results.parquet and no journal (this page's `docs/benchmark_results`, copied) is continued from that file
  once its runs are checked against the scenario file.
"""


def report_text(
    scores: pd.DataFrame, *, subset: str, figures: dict[str, str], wall_s: float, paired: pd.DataFrame | None = None
) -> str:
    """The whole page: the subset run, the headline, peers that win, a full table per case, the figures.

    ``paired``: :func:`~pmr_ros.benchmark.scoring.paired_scores`, so that a peer is compared with ours on
    the runs it diagnosed (None: ``scores``, each method on its own runs).
    """
    paired = scores if paired is None else paired
    parts = [
        "# Benchmark: our parametric PMR beside its peers",
        "",
        "Written by `pmr-ros benchmark` (docs/benchmark.md of the repository is the committed output of a run).",
        f"Subset run: {subset}. Wall time {wall_s / 60:.1f} min."
        if math.isfinite(wall_s)
        else f"Subset run: {subset}.",
        "Methods: `parametric` (ours), `classic` (the seed paper's PMR), `partial_correlation`"
        " (Badwe et al. 2009), `pem_oe` and `pem_bj` (prediction-error fits of each row, output"
        " error and Box-Jenkins ARMA(1,1)). Scoring: pmr_ros/benchmark/scoring.py's docstring.",
        "",
        SETUP,
        "## Headline",
        "",
        headline(scores),
        "",
        "## Where a peer beats ours (detection at 1 % false alarms, by more than 2 points, on the same runs)",
        "",
        *(peer_wins(paired) or ["- nowhere in this run"]),
        "",
        "## Where a peer quantifies dK better (median abs error, by more than 0.2 pp, on the same runs)",
        "",
        *(_better_gain(paired) or ["- nowhere in this run"]),
        "",
    ]
    for (unit, disturbance), group in scores.groupby(["unit", "disturbance"]):
        parts += [f"## {_case_name(str(unit), int(disturbance))}", ""]
        parts += [table(group.sort_values(["samples", "method"]), ["method", *COLUMNS]), ""]
    parts += ["## Figures", ""]
    parts += [f"![{title}]({path})" for title, path in figures.items()]
    return "\n".join(parts) + "\n"


def _better_gain(paired: pd.DataFrame) -> list[str]:
    out = []
    for case, samples, peer, ours, theirs, runs in _pairs(paired):
        if float(theirs["gain_error"]) < float(ours["gain_error"]) - 0.2:
            out.append(
                f"- {case}, {samples} samples: {peer} {theirs['gain_error']:.2f} pp against ours "
                f"{ours['gain_error']:.2f} pp{runs}"
            )
    return out
