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


def _delay_text(samples: int | None, confidence: float | None, verdict: str | None) -> str:
    if samples is None or confidence is None:
        return "-"
    return f"{samples:+d} ({100 * confidence:.0f} %)" + MARKS.get(verdict or "ok", "")


def _data_warnings(element: dict[str, Any]) -> list[str]:
    """The element's data-quality warnings (saturation, slow disturbances), whatever the method."""
    return list((element.get("data_quality") or {}).get("warnings", []))


def _parametric_line(name: str, element: dict[str, Any]) -> str:
    p = element.get("parametric") or {}
    if element["model"]["kind"] == "none":
        return _interaction_line(name, element, p)
    gain = (
        _interval(p.get("gain_mismatch_pct"), p.get("gain_mismatch_pct_interval"))
        + MARKS[p.get("gain_verdict") or "ok"]
    )
    tau = "-"  # an integrating element has no time constant
    if p.get("tau_verdict") is not None or p.get("tau_mismatch_pct") is not None:
        tau = (
            _interval(p.get("tau_mismatch_pct"), p.get("tau_mismatch_pct_interval"))
            + MARKS[p.get("tau_verdict") or "ok"]
        )
    delay = _delay_text(p.get("delay_mismatch_samples"), p.get("delay_confidence"), p.get("delay_verdict"))
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


def _interaction_line(name: str, element: dict[str, Any], p: dict[str, Any]) -> str:
    """An empty cell: the gain [interval] and delay of the plant's interaction there, across the dK and dtau columns."""
    gain, interval = p.get("unmodeled_gain"), p.get("unmodeled_gain_interval")
    text = "no model, not tested"
    if gain is not None and interval is not None:
        mark = MARKS[p.get("unmodeled_verdict") or "ok"]
        text = f"no model: K {gain:+.3g} [{interval[0]:+.3g},{interval[1]:+.3g}]{mark}"
    delay = _delay_text(p.get("unmodeled_delay_samples"), p.get("delay_confidence"), None)
    delay = delay if gain is not None and p.get("unmodeled_verdict") == "mismatch" else "-"
    return f"{name:8s} {text:53s} {delay:16s} {element['verdict']:13s} {_impact(element.get('impact')):11s}"


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
        texts = [*e.get("reasons", []), *p.get("reasons", []), *p.get("warnings", []), *_data_warnings(e)]
        notes += [f"{name}: {text}" for text in texts]
    lines.append("")
    lines.append("! mismatch (whole interval beyond the tolerance), ? inconclusive; dD = D - Dhat [samples]")
    if any(e["model"]["kind"] == "none" for e in report["elements"].values()):
        lines.append(
            "no model: an empty cell; K [interval] and delay of the plant's interaction there (! one the model lacks)"
        )
    lines += _impact_lines(report)
    lines += notes
    return "\n".join(lines) + "\n"


def _classic_line(name: str, element: dict[str, Any]) -> str:
    c = element.get("classic")
    if c is None:
        return f"{name:8s} {'-':>10s}  {'-':14s} {'-':>9s}  {'-':15s} {'-':>5s}  {element['verdict']:9s}"
    direction = ("higher" if c["gain_ratio"] > 1 else "lower") if c["gain_mismatch"] else "ok"
    gain = f"{100 * (c['gain_ratio'] - 1):+.1f} % {direction}" if c["gain_mismatch"] else "ok"
    if c.get("tau_index") is None:
        index, tau = f"{'-':>9s}", "-"
    else:
        index = f"{c['tau_index']:+9.1f}"
        tau = ("larger" if c["tau_index"] > 0 else "smaller") if c["tau_mismatch"] else "ok"
    return (
        f"{name:8s} {c['gain_ratio']:10.3f}  {gain:14s} {index}  {tau:15s} "
        f"{c['delay_mismatch_samples']:+5d}  {element['verdict']:9s}"
    )


def format_classic_table(report: dict[str, Any]) -> str:
    """The classic method's table: gain ratio, tau index, delay and the flags."""
    injected = report.get("injected")
    cols = (
        f"{'element':8s} {'gain ratio':>10s}  {'gain':14s} {'tau index':>9s}  {'time constant':15s} {'delay':>5s}  "
        f"{'verdict':9s}"
    )
    lines = [cols + ("  injected dK %, dtau %, dD" if injected else "")]
    notes = []
    for name, e in report["elements"].items():
        lines.append(_classic_line(name, e) + (" " + _injected(report, name) if injected else ""))
        c = e.get("classic") or {}
        notes += [f"{name}: {text}" for text in [*e.get("reasons", []), *c.get("reasons", []), *_data_warnings(e)]]
    lines.append("")
    lines.append(
        "gain ratio = K/Khat from M(0); tau index = -100 x slope of M(w)/M(0) on (0, tau_band], > 0: plant slower; "
        "delay = D - Dhat [samples]"
    )
    lines += notes
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
