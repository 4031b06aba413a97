"""The sweep report's tables: baseline, breakdown points, MPC tuning, the methods side by side."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..config import PmrConfig
from ..core.sim.model import SCENARIOS
from ..sweep.analysis import (
    DIAGNOSES,
    GAIN_TOLERANCE,
    TAU_TOLERANCE_PCT,
    Breakdown,
    PointSummary,
    earliest,
    run_correctness,
)
from ..sweep.tuning import HORIZON_STEP, STABILITY_LIMIT
from .sweep_paper import (
    PAPER_DELAY,
    PAPER_GAIN_PCT,
    PAPER_TAU_INDEX,
    PARAMETRIC_TARGET_SHARE,
    by,
    fmt_nu,
    paper_breakdown,
    ratio_at,
)

if TYPE_CHECKING:
    pass


def baseline_section(
    summary: list[PointSummary], *, config: PmrConfig, first_sweep: str | None, base_nu: float, seeds: int, paper: bool
) -> list[str]:
    """The full-mismatch baseline (beside the paper's eqs. (16)-(17) where they apply) and its wrong seeds."""
    elements = config.model.element_names()
    paper_head = ("| paper eq. 16 ", "| paper eq. 17 ", "| paper ΔD ") if paper else ("", "", "")
    lines = [
        f"## Baseline (ν = {base_nu:g})" + (" beside the paper's eqs. (16)–(17)\n" if paper else "\n"),
        "Full-mismatch scenario, median over seeds [min … max]. The time-constant index is −100 × the slope of "
        "M(ω)/M(0) "
        f"on (0, {config.pmr.tau_band:g}] rad/sample, the paper's eq. (17) measure.\n",
        f"| element | injected ΔK {paper_head[0]}| ours ΔK | injected Δτ {paper_head[1]}| ours τ index | injected ΔD "
        f"{paper_head[2]}| ours ΔD |",
        "|---|" + "---|" * (6 + 3 * paper),
    ]
    for element in elements:
        pts = by(summary, method="classic", element_swept=first_sweep, nu=base_nu, scenario="full", element=element)
        if pts:
            lines.append(_baseline_row(pts[0], paper=paper))
    lines.append("")
    baseline = by(summary, method="classic", element_swept=first_sweep, nu=base_nu)
    scenarios = [s for s in SCENARIOS if any(p.scenario == s for p in baseline)]
    wrong = [
        f"{scenario}/{p.element}/{d}: {getattr(p, f'{d}_wrong')} of {p.seeds}"
        for scenario in scenarios
        for p in by(baseline, scenario=scenario)
        for d in DIAGNOSES
        if getattr(p, f"{d}_wrong")
    ]
    total = len(scenarios) * len(elements) * len(DIAGNOSES)
    lines.append(
        f"Baseline correctness over all {len(scenarios)} scenarios ({total} element-diagnosis pairs × {seeds} seeds, "
        "rules below): " + ("all right." if not wrong else "wrong seeds — " + "; ".join(wrong) + ".") + "\n"
    )
    return lines


def _baseline_row(p: PointSummary, *, paper: bool) -> str:
    """One element of the baseline table: injected, (the paper's,) and our gain, tau and delay."""
    paper_d = PAPER_DELAY.get(p.element)
    cells = [
        p.element,
        f"{100 * (p.true_gain_ratio - 1):+.1f} %",
        f"{PAPER_GAIN_PCT.get(p.element, float('nan')):+.1f} %" if paper else None,
        f"{100 * (p.gain_median - 1):+.1f} % [{100 * (p.gain_low - 1):+.1f} … {100 * (p.gain_high - 1):+.1f}]",
        f"{p.true_time_constant_pct:+.0f} %",
        f"{PAPER_TAU_INDEX.get(p.element, float('nan')):+.2f}" if paper else None,
        f"{p.tau_median:+.1f} [{p.tau_low:+.1f} … {p.tau_high:+.1f}]",
        f"{p.true_delay_samples:+d}",
        (f"{paper_d:+d}" if paper_d is not None else "not reported") if paper else None,
        f"{p.delay_median:+.0f} [{p.delay_low:+.0f} … {p.delay_high:+.0f}]",
    ]
    return "| " + " | ".join(c for c in cells if c is not None) + " |"


def definition_section(threshold: float) -> list[str]:
    """When a diagnosis is right, when a point fails, what the breakdown nu is."""
    return [
        '## When a diagnosis "breaks down"\n',
        "A run's diagnosis of an element is **right** when: gain — |K/K̂ estimate − injected K/K̂| ≤ "
        f"{100 * GAIN_TOLERANCE:g} pp; "
        f"time constant — with a τ mismatch injected, the classic flag is raised (|index| > {threshold:g}) with the "
        "mismatch's sign, "
        "without one, the flag stays down; delay — the estimated D − D̂ equals the injected one. A run with "
        "insufficient data is wrong. "
        "A point (sweep, ν, scenario, element, diagnosis) **fails** when more than half of its seeds are wrong. "
        "The **breakdown ν** of a diagnosis is the smallest ν of the grid at which it fails (if it already fails at "
        "the baseline ν it is reported as such, not as a breakdown); "
        '"share failing after" is the fraction of grid points from the breakdown ν on that fail (1.00 = it never '
        "recovers). "
        "For the **parametric** method, which fits the time constant itself, the time constant is right when |fitted "
        f"Δτ − injected Δτ| ≤ {TAU_TOLERANCE_PCT:g} pp; "
        "gain and delay are judged as above; an inconclusive verdict (no numbers) counts as wrong.\n",
    ]


def breakdown_section(
    summary: list[PointSummary],
    breaks: list[Breakdown],
    *,
    methods: list[str],
    swept: list[str],
    elements: list[str],
    paper: bool,
) -> list[str]:
    """Where each diagnosis breaks down, per method and sweep."""
    lines = ["## Breakdown points\n"]
    for method in methods:
        for element_swept in swept:
            bs = [b for b in breaks if b.method == method and b.element_swept == element_swept]
            lines.extend(
                _breakdown_sweep(
                    summary,
                    bs,
                    method=method,
                    element_swept=element_swept,
                    elements=elements,
                    paper_nu=paper_breakdown(element_swept, paper),
                )
            )
    lines.append('"base": fails at the baseline ν already; "never": no failing point on the grid.\n')
    return lines


def _breakdown_sweep(
    summary: list[PointSummary],
    bs: list[Breakdown],
    *,
    method: str,
    element_swept: str,
    elements: list[str],
    paper_nu: float | None,
) -> list[str]:
    """One sweep's first failure (overall and in the swept row) and its table of breakdown nu."""
    first = earliest(bs)
    lines = [f"### Sweep of τ of {element_swept} ({method})\n"]
    if first is not None:
        lines.append(
            f"First failure of any diagnosis: **ν = {first.nu:g}** (row ratio {first.ratio:.2f}) — {first.element} "
            f"{first.diagnosis}, scenario {first.scenario}"
            + (
                f"; the paper: ν ≈ {paper_nu:g} (row ratio {ratio_at(summary, element_swept, paper_nu):.2f})."
                if paper_nu
                else "."
            )
        )
    else:
        lines.append("No diagnosis fails anywhere on the grid.")
    first_row = earliest([b for b in bs if b.element[1] == element_swept[1]])
    if first_row is not None:
        lines.append(
            f" In the swept element's row: ν = {first_row.nu:g} (ratio {first_row.ratio:.2f}), {first_row.element} "
            f"{first_row.diagnosis}, scenario {first_row.scenario}."
        )
    lines.append("\n")
    lines.append(
        "| element | diagnosis | breakdown ν (earliest scenario) | row ratio | scenario | share failing after | per "
        "scenario: " + " / ".join(SCENARIOS) + " |"
    )
    lines.append("|---|---|---|---|---|---|---|")
    lines.extend(
        _breakdown_row([b for b in bs if b.element == element and b.diagnosis == d], element=element, diagnosis=d)
        for element in elements
        for d in DIAGNOSES
    )
    lines.append("")
    return lines


def _breakdown_row(items: list[Breakdown], *, element: str, diagnosis: str) -> str:
    """One (element, diagnosis) of a sweep: its earliest breakdown and the breakdown nu per scenario."""
    e = earliest(items)
    cells = []
    for scenario in SCENARIOS:
        b = next((x for x in items if x.scenario == scenario), None)
        cells.append(
            "—" if b is None else "base" if b.fails_at_baseline else fmt_nu(b) if b.nu is not None else "never"
        )
    return (
        f"| {element} | {diagnosis} | {fmt_nu(e)} | {f'{e.ratio:.2f}' if e else '—'} | {e.scenario if e else '—'} | "
        f"{f'{e.failing_share:.2f}' if e else '—'} | {' / '.join(cells)} |"
    )


def figures_section(figures: list[Path], report: Path, *, paper: bool) -> list[str]:
    """The figures, linked relative to the report."""
    paper_line = "dotted vertical line: the paper's breakdown ν; " if paper else ""
    lines = [
        "## Figures\n",
        f"Median over seeds (line) and min–max band; dashed lines: the injected value of each scenario; {paper_line}"
        "top axis: the row time-constant ratio. The time-constant index axis is symmetric-log.\n",
    ]
    for path in figures:
        rel = path.relative_to(report.parent) if path.is_relative_to(report.parent) else path
        lines.append(f"![{path.stem}]({rel.as_posix()})\n")
    return lines


def mpc_section(
    summary: list[PointSummary], *, config: PmrConfig, nus: list[float], swept: list[str], method: str
) -> list[str]:
    """The MPC along the sweep: per nu the horizon, spectral radius, OSQP share and failures, tracking error."""
    tuning = config.mpc
    n_plants = len({p.scenario for p in summary})
    lines = [
        "## The MPC along the sweep\n",
        f"The configured MPC (Np = {tuning.prediction_horizon}, Nc = {tuning.control_horizon}) can lose stability as "
        "a time constant grows: once its horizon no longer covers "
        "the slow element's response, a pole of the unconstrained loop leaves the unit circle even without mismatch, "
        "and the constrained loop settles into a saturated "
        f"limit cycle. At each ν the sweep therefore lengthens the prediction horizon in steps of {HORIZON_STEP} "
        f"until the unconstrained loop of all {n_plants} plants "
        f"has spectral radius < {STABILITY_LIMIT:g} (weights and Nc unchanged). "
        f"{_horizon_text(summary, swept=swept, method=method, configured=tuning.prediction_horizon)} "
        "Below: per ν, Np, that spectral radius ρ, the share of samples where a limit bound and OSQP ran, OSQP "
        "failures (summed over runs), and the median RMS tracking error.\n",
        "| ν | " + " | ".join(f"{e}: Np | ρ | OSQP share | failures | RMS e" for e in swept) + " |",
        "|" + "---|" * (1 + 5 * len(swept)),
    ]
    first_element = config.model.element_names()[0]
    for nu in nus:
        cells = [
            _mpc_cells(
                [p for p in summary if p.element_swept == e and p.nu == nu and p.method == method],
                first_element=first_element,
            )
            for e in swept
        ]
        lines.append(f"| {nu:g} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(
        "The per-point medians, spreads and wrong-seed counts are in `figures/sweep_summary.csv`; the record-level "
        "CSV (every estimate per element, ν, scenario and seed) is the sweep folder's `results.csv`.\n"
    )
    return lines


def _horizon_text(summary: list[PointSummary], *, swept: list[str], method: str, configured: int) -> str:
    """Where the sweep had to lengthen the configured prediction horizon, per sweep."""
    parts = []
    for e in swept:
        pts = by(summary, method=method, element_swept=e)
        longer = sorted({p.nu for p in pts if p.prediction_horizon > configured})
        if longer:
            parts.append(
                f"on the {e} sweep at {len(longer)} of {len({p.nu for p in pts})} ν, from ν = {longer[0]:g} (Np up to "
                f"{max(p.prediction_horizon for p in pts)})"
            )
    if not parts:
        return f"Here the configured Np = {configured} kept every loop stable at every ν of the grid."
    return f"Here Np = {configured} was lengthened " + "; ".join(parts) + "."


def _mpc_cells(pts: list[PointSummary], *, first_element: str) -> str:
    """One sweep's MPC cells at one nu (``pts``: that point's summaries of one method)."""
    if not pts:
        return "— | — | — | — | —"
    fails = sum(p.mpc_failures for p in pts if p.element == first_element)  # one element's rows count each run once
    share = float(np.median([p.solve_fraction for p in pts]))
    rms = float(np.median([p.tracking_rms for p in pts]))
    return (
        f"{pts[0].prediction_horizon} | {pts[0].loop_spectral_radius:.4f} | {100 * share:.0f} % | {fails} | {rms:.2f}"
    )


def side_by_side(
    rows: list[dict],
    summary: list[PointSummary],
    *,
    methods: list[str],
    swept: list[str],
    elements: list[str],
    threshold: float,
) -> list[str]:
    """Classic against parametric over the whole sweep: how often each diagnosis is right."""
    right: dict[tuple, list[dict[str, bool]]] = {}
    for row in rows:
        right.setdefault((row["method"], row["element_swept"], row["element"]), []).append(
            run_correctness(row, threshold)
        )
    lines = [
        "## Classic and parametric side by side\n",
        "Share of runs (every ν, scenario and seed) whose diagnosis is right by the rules below — for the parametric "
        f"method: ΔK within ±{100 * GAIN_TOLERANCE:g} pp, "
        f"Δτ within ±{TAU_TOLERANCE_PCT:g} pp, ΔD exact; for the classic method the gain ratio within "
        f"±{100 * GAIN_TOLERANCE:g} pp, the τ flag and sign, ΔD exact. "
        '"worst point" is the lowest share of right seeds at any single (ν, scenario).\n',
        "| sweep | element | diagnosis | " + " | ".join(f"{m}: right | {m}: worst point" for m in methods) + " |",
        "|---|---|---|" + "---|---|" * len(methods),
    ]
    for element_swept in swept:
        for element in elements:
            for d in DIAGNOSES:
                cells = [
                    _right_cells(
                        right.get((m, element_swept, element), []),
                        by(summary, method=m, element_swept=element_swept, element=element),
                        diagnosis=d,
                    )
                    for m in methods
                ]
                lines.append(f"| τ of {element_swept} | {element} | {d} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.extend(_method_totals(right, methods))
    lines.extend(_parametric_target([p for p in summary if p.method == "parametric"]))
    lines.append("")
    return lines


def _right_cells(runs: list[dict[str, bool]], pts: list[PointSummary], *, diagnosis: str) -> str:
    """Share of runs right and the share right at the worst point, for one method, sweep, element and diagnosis."""
    share = float(np.mean([r[diagnosis] for r in runs])) if runs else float("nan")
    worst = min((1.0 - getattr(p, f"{diagnosis}_wrong") / p.seeds for p in pts), default=float("nan"))
    return f"{100 * share:.1f} % | {100 * worst:.0f} %"


def _method_totals(right: dict[tuple, list[dict[str, bool]]], methods: list[str]) -> list[str]:
    """Per method: the share of (run, element, diagnosis) right, and of (run, element) right on all three."""
    lines = []
    for m in methods:
        runs = [r for key, rs in right.items() if key[0] == m for r in rs]
        each = [r[d] for r in runs for d in DIAGNOSES]
        lines.append(
            f"- **{m}**: {100 * float(np.mean(each)):.1f} % of all (run, element, diagnosis) right; "
            f"{100 * float(np.mean([all(r.values()) for r in runs])):.1f} % of (run, element) pairs right on gain, "
            "time constant and delay together."
        )
    return lines


def _parametric_target(parametric: list[PointSummary]) -> list[str]:
    """How many points meet the parametric target, and which do not.

    The target: :data:`PARAMETRIC_TARGET_SHARE` of the seeds right on all three parameters.
    """
    if not parametric:
        return []
    below = [
        p
        for p in parametric
        if any(1.0 - getattr(p, f"{d}_wrong") / p.seeds < PARAMETRIC_TARGET_SHARE for d in DIAGNOSES)
    ]
    others = "; ".join(
        f"{p.element_swept} ν={p.nu:g} {p.scenario} {p.element} (wrong seeds g/τ/D "
        f"{p.gain_wrong}/{p.tau_wrong}/{p.delay_wrong} of {p.seeds})"
        for p in below[:12]
    )
    return [
        f"- The parametric target (every element, every ν of every sweep, ≥ {100 * PARAMETRIC_TARGET_SHARE:g} % of "
        "seeds within spec): "
        f"{len(parametric) - len(below)} of {len(parametric)} (sweep, ν, scenario, element) points meet it"
        + ("." if not below else "; the others: " + others + (" …" if len(below) > 12 else "") + ".")
    ]
