"""Diagnosis reports: the JSON document and the verdict table people read."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from .. import __version__
from .config import PmrConfig
from .pmr import Diagnosis


def injected_mismatch(config: PmrConfig, scenario: str) -> dict[str, dict]:
    """The mismatch a simulated run injected, per element."""
    mm = config.mismatch.for_scenario(scenario)
    names = config.model.element_names()
    n_in = config.model.n_inputs
    out = {}
    for j, name in enumerate(names):
        i, k = divmod(j, n_in)
        out[name] = {
            "gain_pct": float(mm.gain_pct[i, k]),
            "time_constant_pct": float(mm.time_constant_pct[i, k]),
            "delay_samples": int(mm.delay_samples[i, k]),
        }
    return out


def build_report(config: PmrConfig, diagnosis: Diagnosis, *, command: str, scenario: str | None, seed: int | None) -> dict:
    """The JSON-ready report of a diagnosis.

    ``elements`` maps ``G11, G12, ...`` to the numbers and verdicts of each
    element; ``injected`` (simulated runs only) holds the truth to compare with.
    """
    report = {
        "tool": "pmr_ros",
        "version": __version__,
        "command": command,
        "system": config.model.name,
        "config": config.source,
        "method": diagnosis.method,
        "scenario": scenario,
        "seed": seed,
        "samples": diagnosis.samples,
        "sample_time": config.model.sample_time,
        "status": diagnosis.status,
        "reason": diagnosis.reason,
        "settings": asdict(config.pmr),
        "parametric_settings": asdict(config.parametric) if diagnosis.method == "parametric" else None,
        "elements": {},
    }
    for name, element in diagnosis.elements.items():
        entry = element.to_dict()
        entry["summary"] = element.summary()
        report["elements"][name] = entry
    if scenario is not None:
        report["injected"] = injected_mismatch(config, scenario)
    return report


def write_json(report: dict, path: str | Path) -> None:
    """Write ``report`` to ``path`` (UTF-8, indented)."""
    Path(path).write_text(json.dumps(report, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


def _interval(value: float | None, interval: list | None) -> str:
    if value is None:
        return "-"
    return f"{value:+6.1f} [{interval[0]:+6.1f},{interval[1]:+6.1f}]"


def format_parametric_table(report: dict) -> str:
    """The parametric method's table: estimates with intervals and verdicts."""
    level = 100 * report["parametric_settings"]["confidence_level"]
    injected = report.get("injected")
    cols = f"{'element':8s} {'dK % [' + f'{level:.0f} % interval]':26s} {'dtau % [interval]':26s} {'dD (confidence)':16s} {'verdict':13s}"
    if injected:
        cols += " injected dK %, dtau %, dD"
    lines = [cols]
    notes = []
    for name, e in report["elements"].items():
        marks = {"ok": "", "mismatch": "!", "inconclusive": "?"}
        gain = _interval(e["gain_mismatch_pct"], e["gain_mismatch_pct_interval"]) + marks[e.get("gain_verdict", "inconclusive")]
        tau = _interval(e["tau_mismatch_pct"], e["tau_mismatch_pct_interval"]) + marks[e.get("tau_verdict", "inconclusive")]
        delay = "-" if e["delay_mismatch_samples"] is None else f"{e['delay_mismatch_samples']:+d} ({100 * e['delay_confidence']:.0f} %)" + marks[e.get("delay_verdict", "inconclusive")]
        line = f"{name:8s} {gain:26s} {tau:26s} {delay:16s} {e['verdict']:13s}"
        if injected:
            t = injected[name]
            line += f" {t['gain_pct']:+.0f}, {t['time_constant_pct']:+.0f}, {t['delay_samples']:+d}"
        lines.append(line)
        notes += [f"{name}: {text}" for text in e.get("reasons", []) + e.get("warnings", [])]
    lines.append("")
    lines.append("! mismatch (interval excludes 0 and beyond tolerance), ? inconclusive; dD = D - Dhat [samples]")
    lines += notes
    return "\n".join(lines) + "\n"


def format_table(report: dict) -> str:
    """The verdict table, one line per element."""
    head = (
        f"{report['system'] or 'system'}: {report['command']} ({report['method']} PMR), "
        f"scenario {report['scenario']}, seed {report['seed']}, {report['samples']} samples"
    )
    if report["status"] != "ok":
        return f"{head}\nINSUFFICIENT DATA: {report['reason']}\n"
    if report["method"] == "parametric":
        return f"{head}\n\n" + format_parametric_table(report)
    injected = report.get("injected")
    lines = [head, ""]
    cols = f"{'element':8s} {'gain ratio':>10s}  {'gain':14s} {'tau index':>9s}  {'time constant':15s} {'delay':>5s}  {'verdict':9s}"
    if injected:
        cols += "  injected dK %, dtau %, dD"
    lines.append(cols)
    for name, e in report["elements"].items():
        gain = f"{100 * (e['gain_ratio'] - 1):+.1f} % {e['gain_direction']}" if e["gain_mismatch"] else "ok"
        tau = e["tau_direction"] if e["tau_mismatch"] else "ok"
        line = (
            f"{name:8s} {e['gain_ratio']:10.3f}  {gain:14s} {e['tau_index']:+9.1f}  {tau:15s} "
            f"{e['delay_mismatch_samples']:+5d}  {e['verdict']:9s}"
        )
        if injected:
            t = injected[name]
            line += f"  {t['gain_pct']:+.0f}, {t['time_constant_pct']:+.0f}, {t['delay_samples']:+d}"
        lines.append(line)
    lines.append("")
    lines.append("gain ratio = K/Khat from M(0); tau index = -100 x slope of M(w)/M(0) on (0, tau_band], > 0: plant slower; delay = D - Dhat [samples]")
    return "\n".join(lines) + "\n"
