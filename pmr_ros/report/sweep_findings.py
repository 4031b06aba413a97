"""The sweep report's findings: per method and sweep, where each diagnosis first fails and why."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..sweep.analysis import (
    DIAGNOSES,
    Breakdown,
    PointSummary,
    earliest,
)
from .sweep_paper import by, paper_breakdown, ratio_at

if TYPE_CHECKING:
    pass


def findings_section(
    summary: list[PointSummary],
    breaks: list[Breakdown],
    *,
    methods: list[str],
    swept: list[str],
    elements: list[str],
    threshold: float,
    paper: bool,
) -> list[str]:
    """The findings: bullet points per method and sweep."""
    lines = ["## Findings\n"]
    for method in methods:
        for element_swept in swept:
            lines.extend(
                _findings(
                    summary,
                    breaks,
                    method=method,
                    element_swept=element_swept,
                    elements=elements,
                    threshold=threshold,
                    paper_nu=paper_breakdown(element_swept, paper),
                )
            )
    lines.append("")
    return lines


def _findings(
    summary: list[PointSummary],
    breaks: list[Breakdown],
    *,
    method: str,
    element_swept: str,
    elements: list[str],
    threshold: float,
    paper_nu: float | None,
) -> list[str]:
    """Bullet points on one sweep, every number from the data.

    ``paper_nu`` is the paper's breakdown nu, if the comparison applies.
    """
    bs = [b for b in breaks if b.method == method and b.element_swept == element_swept]
    pts = by(summary, method=method, element_swept=element_swept)
    if not pts:
        return []
    nus = sorted({p.nu for p in pts})
    ratio0 = next(p.row_time_constant_ratio for p in pts if p.nu == nus[0])
    first = earliest(bs)
    head = f"- **Sweep of τ of {element_swept}** ({method}; row ratio {ratio0:.2f} at ν = {nus[0]:g}): "
    if first is None or first.nu is None:  # earliest() gives only breakdowns with a nu: both None together
        return [
            head
            + "no diagnosis fails on the grid"
            + (f"; the paper reports a breakdown at ν ≈ {paper_nu:g}." if paper_nu else ".")
        ]
    paper_text = (
        f"; the paper reports ν ≈ {paper_nu:g} (row ratio {ratio_at(summary, element_swept, paper_nu):.2f})"
        if paper_nu
        else ""
    )
    return [
        head + _first_failure_text(pts, first, base_nu=nus[0], threshold=threshold, paper_text=paper_text),
        _never_failing_line(bs, elements),
        *_other_failures_line(bs, first, elements),
        _mpc_findings_line(pts, first_nu=first.nu, base_nu=nus[0], first_element=elements[0]),
    ]


def _first_failure_text(
    pts: list[PointSummary], first: Breakdown, *, base_nu: float, threshold: float, paper_text: str
) -> str:
    """Where the first diagnosis fails, its value there and at the baseline, and how much of the grid stays failed."""

    def at(nu: float | None) -> PointSummary:
        return next(p for p in pts if p.nu == nu and p.scenario == first.scenario and p.element == first.element)

    here, base = at(first.nu), at(base_nu)
    label, attribute, form = {
        "gain": ("median gain ratio", "gain_median", "{:.3f}"),
        "tau": ("median τ index", "tau_median", "{:+.1f}"),
        "delay": ("median delay mismatch", "delay_median", "{:+.0f}"),
    }[first.diagnosis]
    text = (
        f"the first diagnosis to fail is {first.element}'s {first.diagnosis} diagnosis in scenario {first.scenario} "
        f"at **ν = {first.nu:g}** "
        f"(row ratio **{first.ratio:.2f}**){paper_text}"
    )
    text += (
        f". There the {label} of {first.element} is {form.format(getattr(here, attribute))} "
        f"(baseline {form.format(getattr(base, attribute))}, {getattr(here, first.diagnosis + '_wrong')} of "
        f"{here.seeds} seeds wrong"
    )
    if first.diagnosis == "tau":
        text += f"; flag threshold ±{threshold:g}"
    return text + f"); it stays failed at {100 * first.failing_share:.0f} % of the grid points from there on."


def _never_failing_line(bs: list[Breakdown], elements: list[str]) -> str:
    """The (element, diagnosis) pairs that fail in no scenario, neither at the baseline nor later."""
    broken = {(b.element, b.diagnosis) for b in bs if b.nu is not None or b.fails_at_baseline}
    never = [f"{e} {d}" for e in elements for d in DIAGNOSES if (e, d) not in broken]
    return (
        f"  - {len(never)} of {len(elements) * len(DIAGNOSES)} (element, diagnosis) pairs never fail in any "
        f"scenario: {', '.join(never) if never else 'none'}."
    )


def _other_failures_line(bs: list[Breakdown], first: Breakdown, elements: list[str]) -> list[str]:
    """The breakdowns of the other (element, diagnosis) pairs, one line (none if there are none)."""
    others = []
    for e in elements:
        for d in DIAGNOSES:
            b = earliest([x for x in bs if x.element == e and x.diagnosis == d])
            if b is not None and (e, d) != (first.element, first.diagnosis):
                others.append(f"{e} {d} at ν = {b.nu:g} ({b.scenario}, stays failed at {100 * b.failing_share:.0f} %)")
    return ["  - Other failures: " + "; ".join(others) + "."] if others else []


def _mpc_findings_line(pts: list[PointSummary], *, first_nu: float, base_nu: float, first_element: str) -> str:
    """How the MPC fares along one sweep: OSQP share at the first failure and baseline, failures, horizons, radii."""
    solve_here = float(np.median([p.solve_fraction for p in pts if p.nu == first_nu]))
    solve_base = float(np.median([p.solve_fraction for p in pts if p.nu == base_nu]))
    failures = sum(p.mpc_failures for p in pts if p.element == first_element)
    return (
        f"  - The MPC: input limits bind (OSQP runs) at {100 * solve_here:.0f} % of the samples at ν = {first_nu:g} "
        f"against {100 * solve_base:.0f} % at the baseline; "
        f"OSQP failures over the whole sweep: {failures}; largest prediction horizon used: "
        f"{max(p.prediction_horizon for p in pts)}; "
        f"largest unconstrained-loop spectral radius: {max(p.loop_spectral_radius for p in pts):.4f}."
    )
