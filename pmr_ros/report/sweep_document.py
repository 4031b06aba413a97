"""The sweep's markdown reproduction report: figures, a summary CSV and the text, from the sweep's CSV rows."""

from __future__ import annotations

import csv
import subprocess
from dataclasses import asdict, fields
from pathlib import Path
from typing import TYPE_CHECKING

from ..config import PmrConfig
from ..core.sim.model import SCENARIOS
from ..outputs import replacing, write_text
from ..sweep.analysis import (
    DIAGNOSES,
    PointSummary,
    breakdowns,
    summarize,
)
from ..sweep.plan import row_time_constant_ratio
from .sweep_figures import element_grid, plot_sweep
from .sweep_findings import findings_section
from .sweep_paper import channels, paper_comparison_applies
from .sweep_tables import (
    baseline_section,
    breakdown_section,
    definition_section,
    figures_section,
    mpc_section,
    side_by_side,
)

if TYPE_CHECKING:
    pass


def write_report(rows: list[dict], report: Path, config: PmrConfig, manifest: dict) -> list[Path]:
    """Write the figures (``figures/`` beside ``report``), a summary CSV and the markdown report.

    Parameters
    ----------
    rows : list of dict
        The sweep's CSV rows (:func:`store.read_rows`).
    report : Path
        The markdown file to write.
    config : PmrConfig
        The configuration the sweep ran with: every setting the report quotes comes from it.
    manifest : dict
        The sweep folder's manifest (wall and CPU time, jobs).

    Returns
    -------
    list of Path
        The figure paths.  Every result in the report comes from ``rows``.
    """
    threshold = config.pmr.tau_index_threshold
    summary = summarize(rows, threshold)
    methods = sorted({p.method for p in summary})
    swept = list(dict.fromkeys(p.element_swept for p in summary))
    paper = paper_comparison_applies(config)
    figures_dir = report.parent / "figures"
    written = [
        plot_sweep(
            summary,
            method=method,
            element_swept=element_swept,
            quantity=quantity,
            tau_threshold=threshold,
            paper=paper,
            path=figures_dir / f"sweep_{element_swept}_{quantity}{'' if method == 'classic' else f'_{method}'}.png",
            grid=element_grid(config),
        )
        for method in methods
        for element_swept in swept
        for quantity in DIAGNOSES
    ]
    write_summary_csv(summary, figures_dir / "sweep_summary.csv")
    report.parent.mkdir(parents=True, exist_ok=True)
    write_text(
        report,
        _markdown(
            summary=summary, config=config, manifest=manifest, rows=rows, figures=written, report=report, paper=paper
        ),
    )
    return written


def write_summary_csv(summary: list[PointSummary], path: Path) -> None:
    """The per-point summary (medians, spreads, wrong seeds) as CSV."""
    names = [f.name for f in fields(PointSummary)]
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for p in summary:
            w.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in asdict(p).values()])


def _git_revision(folder: Path) -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=folder, capture_output=True, text=True, timeout=5
        )
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _markdown(
    *,
    summary: list[PointSummary],
    config: PmrConfig,
    manifest: dict,
    rows: list[dict],
    figures: list[Path],
    report: Path,
    paper: bool,
) -> str:
    """The report's text: one section after the other, results from ``rows``, settings from ``config``."""
    breaks = breakdowns(summary)
    methods = sorted({p.method for p in summary})
    swept = list(dict.fromkeys(p.element_swept for p in summary))
    elements = config.model.element_names()
    threshold = config.pmr.tau_index_threshold
    nus = sorted({round(r["nu"], 9) for r in rows})
    seeds = len({r["seed"] for r in rows})
    sections = [
        _title_section(methods, report, system=config.model.name, paper=paper),
        _run_section(config=config, manifest=manifest, rows=rows, methods=methods, swept=swept, paper=paper),
        baseline_section(
            summary, config=config, first_sweep=swept[0] if swept else None, base_nu=nus[0], seeds=seeds, paper=paper
        ),
        findings_section(
            summary, breaks, methods=methods, swept=swept, elements=elements, threshold=threshold, paper=paper
        ),
        definition_section(threshold),
        side_by_side(rows, summary, methods=methods, swept=swept, elements=elements, threshold=threshold)
        if "parametric" in methods
        else [],
        breakdown_section(summary, breaks, methods=methods, swept=swept, elements=elements, paper=paper),
        figures_section(figures, report, paper=paper),
        mpc_section(summary, config=config, nus=nus, swept=swept, method=methods[0]),
    ]
    return "\n".join(line for section in sections for line in section) + "\n"


def _title_section(methods: list[str], report: Path, *, system: str, paper: bool) -> list[str]:
    """The title and how to rebuild the report."""
    methods_flag = "" if list(methods) == ["classic"] else f" --methods {','.join(methods)}"
    title = (
        "Reproduction: the time-constant study (paper's sections 3.4–3.6, Figs. 2–7)"
        if paper
        else (f"The time-constant study of the paper's sections 3.4–3.6, on {system or 'the configured system'}")
    )
    return [
        f"# {title}\n",
        "Generated by `pmr-ros sweep` from its `results.csv`; every number below is computed from that file. "
        f"Rebuild with `pmr-ros sweep{methods_flag} --report {report.as_posix()}` (or `--report-only` on an existing "
        "sweep folder).\n",
    ]


def _time_unit(paper: bool) -> str:
    """The unit of time: minutes for the Wood-Berry column; a configuration does not state its unit otherwise."""
    return "min" if paper else "t.u."


def _run_section(
    *, config: PmrConfig, manifest: dict, rows: list[dict], methods: list[str], swept: list[str], paper: bool
) -> list[str]:
    """What was run: the system, the sweeps, the grid, seeds and samples, the loop's settings, the time it took."""
    model = config.model
    unit = _time_unit(paper)
    ts_text = f"Ts = {model.sample_time:g} {unit}" + ("" if paper else " (t.u.: the configuration's time unit)")
    lines = [
        "## What was run\n",
        f"- System: {model.name or 'configured system'} ({config.source}), {ts_text}; {_mismatch_text(config, paper)}.",
    ]
    for element in swept:
        i, k = divmod(model.element_names().index(element), model.n_inputs)
        lines.append(
            f"- Sweep `tau_{element}`: τ of {element} = {model.time_constant[i, k]:g}·ν {unit} in **both** the plant "
            "and the MPC's model (the MPC is rebuilt at every ν)."
        )
    lines.append(_grid_line(rows, methods=methods, n_elements=len(model.element_names())))
    lines.append(_loop_line(config))
    if manifest.get("wall_time_s"):
        lines.append(_wall_time_line(manifest))
    if paper and "G21" in swept:
        lines.append(
            "- The paper's Figs. 5–7 are captioned G12, but its section 3.5 and eq. (19) change G21 = "
            "6.6e^{-7s}/(10.9ν s + 1); "
            "10.9 min is τ21 of the standard Wood-Berry matrix (the text's eq. 14 prints rows 2 upside down). We "
            "sweep **G21**, as eq. (19) says."
        )
    if not paper:
        lines.append(
            "- The paper's published numbers (eqs. 16–17, the breakdown ν of section 3.6, Figs. 2–7) are for the "
            "Wood-Berry column under its eq. (15) mismatch; "
            f"the configured system is {model.name or 'another'}, so the paper comparison does not apply and is left "
            "out."
        )
    lines.append(_row_ratio_line(config, swept) + "\n")
    return lines


def _mismatch_text(config: PmrConfig, paper: bool) -> str:
    """The configured mismatch, which each scenario applies in part, on the plant only."""
    m = config.mismatch
    source = "the paper's eq. (15)" if paper else "configured"
    return (
        f"the mismatch ({source}; row-major) ΔK = {channels(m.gain_pct)} %, Δτ = {channels(m.time_constant_pct)} %, "
        f"ΔD = {channels(m.delay_samples)} samples, on the plant only"
    )


def _grid_line(rows: list[dict], *, methods: list[str], n_elements: int) -> str:
    """The nu grid, scenarios, seeds, samples and CSV size, as run."""
    nus = sorted({round(r["nu"], 9) for r in rows})
    present = {r["scenario"] for r in rows}
    scenarios = [s for s in SCENARIOS if s in present] + sorted(present - set(SCENARIOS))
    seeds = sorted({r["seed"] for r in rows})
    samples = sorted({r["samples"] for r in rows})
    return (
        f"- ν grid: {len(nus)} values from {nus[0]:g} to {nus[-1]:g}; scenarios: {', '.join(scenarios)} (the paper's "
        f"Table 2); seeds: {', '.join(map(str, seeds))}; "
        f"{', '.join(map(str, samples))} samples per run; {len(rows)} CSV rows ({len(rows) // n_elements} closed-loop "
        f"runs × {n_elements} elements), methods: {', '.join(methods)}."
    )


def _loop_line(config: PmrConfig) -> str:
    """The loop's settings as configured: noise, PRBS setpoints, MPC tuning, the classic index's band."""
    prbs, mpc = config.prbs, config.mpc
    return (
        f"- Loop: measurement noise σ = {channels(config.noise_std)}; PRBS setpoints ±{channels(prbs.amplitude)} "
        f"around {channels(prbs.nominal)}, "
        f"{prbs.clock_period} samples per bit, register length {prbs.register_length}; MPC Np = "
        f"{mpc.prediction_horizon} (lengthened where needed, see below), "
        f"Nc = {mpc.control_horizon}, Q = {channels(mpc.output_weight)}, R = {channels(mpc.move_weight)}, u ∈ "
        f"[{channels(mpc.u_min)}, {channels(mpc.u_max)}], "
        f"|Δu| ≤ {channels(mpc.du_max)}; classic τ index on (0, {config.pmr.tau_band:g}] rad/sample, flagged above "
        f"±{config.pmr.tau_index_threshold:g}."
    )


def _row_ratio_line(config: PmrConfig, swept: list[str]) -> str:
    """How the row time-constant ratio of each sweep follows from the model's time constants."""
    model = config.model
    names = model.element_names()
    parts = []
    for element in swept:
        i, k = divmod(names.index(element), model.n_inputs)
        tau = float(model.time_constant[i, k])
        others = [names[i * model.n_inputs + c] for c in range(model.n_inputs) if c != k]
        denominator = "·".join(f"τ{o[1:]}" for o in others)
        if len(others) > 1:
            denominator = f"({denominator})^(1/{len(others)})"
        parts.append(
            f"τ{element[1:]}/{denominator} = {tau:g}ν/{tau / row_time_constant_ratio(model, i, k):.4g} for the "
            f"{element} sweep"
        )
    geometric = "; their geometric mean" if model.n_inputs > 2 else ""
    return (
        f"- Row time-constant ratio: the swept τ over the other τ of its row (model values{geometric}): "
        + ", ".join(parts)
        + "."
    )


def _wall_time_line(manifest: dict) -> str:
    """Wall and CPU time of the sweep, and the code revision of the report."""
    wall = manifest["wall_time_s"]
    cpu = manifest.get("cpu_time_s")
    per_process = cpu / max(1, manifest.get("jobs", 1)) if cpu else 0.0
    cpu_text = f"; the workers' CPU time was {cpu:.0f} s, i.e. {per_process:.0f} s per process" if cpu else ""
    if cpu and wall > 1.15 * per_process:
        cpu_text += " (wall time well above CPU time per process: the cores were shared with other work during the run)"
    return (
        f"- Wall time of the sweep: **{wall:.0f} s** on {manifest.get('jobs', '?')} worker processes "
        f"({manifest.get('cpu_count', '?')} cores){cpu_text}; "
        f"report built at code revision `{_git_revision(Path(__file__).parent)}`."
    )
