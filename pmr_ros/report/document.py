"""The JSON report of a diagnosis: the diagnosis's own serialisation plus where it came from."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from .. import __version__
from ..config import PmrConfig
from ..core.results import Diagnosis
from ..core.results.codec import diagnosis_to_json
from ..outputs import write_text
from .absolute import model_and_plant
from .system_units import units_of

__all__ = ["build_report", "injected_mismatch", "report_text", "write_json"]


def injected_mismatch(config: PmrConfig, scenario: str) -> dict[str, dict[str, float | int]]:
    """The mismatch a simulated run injected, per element (the truth to compare with)."""
    mm = config.mismatch.for_scenario(scenario)
    out: dict[str, dict[str, float | int]] = {}
    for name, (i, k, _) in config.model.element_models().items():
        out[name] = {
            "gain_pct": float(mm.gain_pct[i, k]),
            "time_constant_pct": float(mm.time_constant_pct[i, k]),
            "delay_samples": int(mm.delay_samples[i, k]),
        }
    return out


def build_report(
    config: PmrConfig, diagnosis: Diagnosis, *, command: str, scenario: str | None, seed: int | None
) -> dict[str, Any]:
    """The JSON-ready report of a diagnosis.

    The diagnosis's JSON form (:func:`~pmr_ros.core.results.codec.diagnosis_to_json`:
    status, reason, samples, method, ``elements``) with the tool, command, system,
    settings, the system's ``units``, ``model_vs_plant`` per element name (absolute K,
    tau, D of the model and of the estimated plant, :mod:`.absolute`; beside
    ``elements``, which stay the diagnosis's own JSON) and, for
    simulated runs, the ``injected`` truth.
    """
    report: dict[str, Any] = {
        "tool": "pmr_ros",
        "version": __version__,
        "command": command,
        "system": config.model.name,
        "config": config.source,
        "scenario": scenario,
        "seed": seed,
        "sample_time": config.model.sample_time,
        "controller": config.controller.kind,
        "settings": {
            "pmr": asdict(config.pmr),
            "parametric": asdict(config.parametric) if diagnosis.method == "parametric" else None,
        },
    }
    report.update(diagnosis_to_json(diagnosis))
    units = units_of(config)
    dvs = config.disturbance_model.input_names if config.disturbance_model is not None else ()
    report["units"] = units.to_json(config.model.output_names, config.model.input_names, dvs)
    report["model_vs_plant"] = model_and_plant(diagnosis, units=units, sample_time=config.model.sample_time)
    if scenario is not None:
        report["injected"] = injected_mismatch(config, scenario)
    return report


_WINDOWS = "\0windows\0"
"""Where the windows go in the indented text (json writes the NUL as an escape, which no other text holds)."""


def report_text(report: dict[str, Any]) -> str:
    """``report`` as JSON text: indented, a monitor's ``windows`` one to a line.

    A year's 352 windows are 3 million values; indented they took 2.0 s to write, as lines 0.5 s (json's C
    encoder writes only unindented text), and a window per line reads and greps as well.
    """
    windows = report.get("windows")
    if not windows:
        return json.dumps(report, indent=2, ensure_ascii=False)
    text = json.dumps({**report, "windows": [_WINDOWS]}, indent=2, ensure_ascii=False)
    quoted = json.dumps(_WINDOWS)
    indent = text[: text.index(quoted)].rsplit("\n", 1)[1]  # the line's leading spaces
    lines = f",\n{indent}".join(json.dumps(window, ensure_ascii=False) for window in windows)
    return text.replace(quoted, lines, 1)


def write_json(report: dict[str, Any], path: str | Path) -> None:
    """Write ``report`` to ``path`` (UTF-8, :func:`report_text`)."""
    write_text(path, report_text(report) + "\n")  # atomic: never a truncated report
