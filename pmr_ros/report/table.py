"""The verdict table people read in a terminal, from a JSON report."""

from __future__ import annotations

from typing import Any

__all__ = ["format_classic_table", "format_parametric_table", "format_table"]

MARKS = {"ok": "", "mismatch": "!", "inconclusive": "?"}
"""Table marks of a parameter's verdict."""


def _interval(value: float | None, interval: list[float] | None) -> str:
    if value is None or interval is None:
        return "-"
    return f"{value:+6.1f} [{interval[0]:+6.1f},{interval[1]:+6.1f}]"


def _injected(report: dict[str, Any], name: str) -> str:
    t = report["injected"][name]
    return f" {t['gain_pct']:+.0f}, {t['time_constant_pct']:+.0f}, {t['delay_samples']:+d}"


def _parametric_line(name: str, element: dict[str, Any]) -> str:
    p = element.get("parametric") or {}
    gain = (
        _interval(p.get("gain_mismatch_pct"), p.get("gain_mismatch_pct_interval"))
        + MARKS[p.get("gain_verdict", "inconclusive")]
    )
    tau = (
        _interval(p.get("tau_mismatch_pct"), p.get("tau_mismatch_pct_interval"))
        + MARKS[p.get("tau_verdict", "inconclusive")]
    )
    delay = "-"
    if p.get("delay_mismatch_samples") is not None:
        delay = (
            f"{p['delay_mismatch_samples']:+d} ({100 * p['delay_confidence']:.0f} %)"
            + MARKS[p.get("delay_verdict", "inconclusive")]
        )
    return f"{name:8s} {gain:26s} {tau:26s} {delay:16s} {element['verdict']:13s} {_impact(element.get('impact')):11s}"


def _impact(impact: dict[str, Any] | None) -> str:
    """``x1.23 (#1)``: the ISE ratio and rank of an element's mismatch, or nothing."""
    if not impact:
        return ""
    return f"x{impact['ise_ratio']:.2f} (#{impact['rank']})" if impact["rank"] else f"x{impact['ise_ratio']:.2f}"


def _impact_lines(report: dict[str, Any]) -> list[str]:
    together = report.get("impact")
    if not together:
        return []
    return [
        f"control impact (configured MPC, noise-free, plant as estimated vs as modelled): all together ISE "
        f"x{together['ise_ratio']:.2f}, input moves x{together['input_movement_ratio']:.2f}; "
        "per element: ISE ratio with that mismatch alone (#1 matters most)"
    ]


def format_parametric_table(report: dict[str, Any]) -> str:
    """The parametric method's table: estimates with intervals and verdicts, then the reasons."""
    level = 100 * report["settings"]["parametric"]["confidence_level"]
    injected = report.get("injected")
    cols = (
        f"{'element':8s} {'dK % [' + f'{level:.0f} % interval]':26s} {'dtau % [interval]':26s} "
        f"{'dD (confidence)':16s} {'verdict':13s} {'impact ISE':11s}"
    )
    lines = [cols + (" injected dK %, dtau %, dD" if injected else "")]
    notes = []
    for name, e in report["elements"].items():
        lines.append(_parametric_line(name, e) + (_injected(report, name) if injected else ""))
        p = e.get("parametric") or {}
        notes += [f"{name}: {text}" for text in [*e.get("reasons", []), *p.get("reasons", []), *p.get("warnings", [])]]
    lines.append("")
    lines.append("! mismatch (interval excludes 0 and beyond tolerance), ? inconclusive; dD = D - Dhat [samples]")
    lines += _impact_lines(report)
    lines += notes
    return "\n".join(lines) + "\n"


def format_classic_table(report: dict[str, Any]) -> str:
    """The classic method's table: gain ratio, tau index, delay and the flags."""
    injected = report.get("injected")
    cols = (
        f"{'element':8s} {'gain ratio':>10s}  {'gain':14s} {'tau index':>9s}  {'time constant':15s} {'delay':>5s}  "
        f"{'verdict':9s}"
    )
    lines = [cols + ("  injected dK %, dtau %, dD" if injected else "")]
    for name, e in report["elements"].items():
        c = e["classic"]
        direction = ("higher" if c["gain_ratio"] > 1 else "lower") if c["gain_mismatch"] else "ok"
        gain = f"{100 * (c['gain_ratio'] - 1):+.1f} % {direction}" if c["gain_mismatch"] else "ok"
        tau = ("larger" if c["tau_index"] > 0 else "smaller") if c["tau_mismatch"] else "ok"
        line = (
            f"{name:8s} {c['gain_ratio']:10.3f}  {gain:14s} {c['tau_index']:+9.1f}  {tau:15s} "
            f"{c['delay_mismatch_samples']:+5d}  {e['verdict']:9s}"
        )
        lines.append(line + (" " + _injected(report, name) if injected else ""))
    lines.append("")
    lines.append(
        "gain ratio = K/Khat from M(0); tau index = -100 x slope of M(w)/M(0) on (0, tau_band], > 0: plant slower; "
        "delay = D - Dhat [samples]"
    )
    return "\n".join(lines) + "\n"


def format_table(report: dict[str, Any]) -> str:
    """The verdict table of a report, one line per element, headed by what was diagnosed."""
    origin = report.get("source") or f"scenario {report['scenario']}, seed {report['seed']}"
    head = (
        f"{report['system'] or 'system'}: {report['command']} ({report['method']} PMR), {origin}, "
        f"{report['samples']} samples"
    )
    if report["status"] != "ok":
        return f"{head}\nINSUFFICIENT DATA: {report['reason']}\n"
    body = format_parametric_table(report) if report["method"] == "parametric" else format_classic_table(report)
    return f"{head}\n\n{body}"
