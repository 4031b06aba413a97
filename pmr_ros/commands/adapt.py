"""``pmr-ros run --adapt``: its option checks and its terminal lines (the flow: :mod:`pmr_ros.service.adapted_run`).

The report's ``elements`` are the verdicts of the window after the switch; its
``adaptation`` holds the first window's, the changes, the tracking figures and
the judgement.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import CommandError

__all__ = ["adaptation_lines", "check_adapt"]


def adaptation_lines(report: dict[str, Any]) -> list[str]:
    """The terminal lines of an adapted run: both windows, the changes, the tracking figures, the judgement."""
    adaptation = report.get("adaptation")
    if not adaptation:
        return []
    lines = ["", "live model update (--adapt):"]
    before = adaptation["before"]
    found = [n for n, e in before["elements"].items() if e["verdict"] == "mismatch"]
    lines.append(
        f"  before: samples {adaptation['before_window'][0]}..{adaptation['before_window'][1]}, "
        f"mismatch in {', '.join(found) or 'none'}"
    )
    for change in adaptation["changes"]:
        b, a = change["before"], change["after"]
        tau = (  # a tf, step_response or integrating element has no time constant to show
            "" if a["time_constant"] is None else f"tau {b['time_constant']} -> {round(a['time_constant'], 3)}, "
        )
        lines.append(
            f"  {change['element']}: K {b['gain']:.4g} -> {a['gain']:.4g}, {tau}"
            f"D {b['delay_samples']} -> {a['delay_samples']} samples"
        )
    t = adaptation["tracking"]
    lines.append(
        f"  switched at sample {adaptation['switch_sample']}; after: samples {adaptation['after_window'][0]}.."
        f"{adaptation['after_window'][1]}; tracking error per sample {t['before']['ise_per_sample']:.4g} -> "
        f"{t['after']['ise_per_sample']:.4g} (x{t['ise_ratio']:.3f})"
    )
    if adaptation["worse"]:
        lines.append(f"  WORSE: {'; '.join(adaptation['reasons'])}")
        if adaptation["rolled_back"]:
            lines.append(f"  rolled back to the previous model at sample {adaptation['rollback_sample']}")
    else:
        lines.append("  better or as good: the update stays")
    lines += [f"  note: {note}" for note in adaptation["notes"]]
    return lines


def check_adapt(args: argparse.Namespace) -> None:
    """Refuse option clashes of ``--adapt`` before any work."""
    if getattr(args, "adapt", False) and args.batch:
        raise CommandError("--adapt updates the running controller of the node set; it cannot be used with --batch")
    if getattr(args, "adapt", False) and getattr(args, "method", None) == "classic":
        raise CommandError("--adapt needs the parametric method (a corrected model); --method classic cannot give it")
