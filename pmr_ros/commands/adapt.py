"""``pmr-ros run --adapt``: run, diagnose, apply the proposed model, run on, diagnose again; roll back if worse.

The node set runs three windows of ``run.samples`` (N) samples: the
diagnostician diagnoses every N/4 samples a window of N; its first verdict
(samples 0..N-1, against the model the controller started with) comes with a
proposal, which :class:`~pmr_ros.nodes.adapter.ModelAdapter` hands to the
controller as an atomic change of its ``system`` parameters; the diagnostician
follows the switch and diagnoses the new model on samples after it only; the
first such verdict window is judged against the first
(:func:`pmr_ros.core.adaptation.judge_update`) and a worse update is rolled
back.  The report's ``elements`` are that last window's verdicts; its
``adaptation`` holds the first window's, the changes, the tracking figures and
the judgement.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from ..config import PmrConfig, parse_config
from . import CommandError

__all__ = ["ADAPT_WINDOWS", "adapt_config", "adapt_parameters", "adaptation_lines", "run_adapted"]

ADAPT_WINDOWS = 3
"""Windows of ``run.samples`` an adapted run lasts: before, the switch (with its settling), after."""

ADAPT_STALL_TIMEOUT_S = 120.0
"""A node-set run waits this long for progress: a verdict with a mismatch comes with its control impact
(11 closed-loop simulations of 4,096 samples for a 3x3: 14-31 s at a load of 7)."""


def adapt_config(config: PmrConfig) -> PmrConfig:
    """The configuration of an adapted run: ``run.samples`` x :data:`ADAPT_WINDOWS` samples in all."""
    tree = {**config.parameters, "run": {**config.parameters["run"], "samples": ADAPT_WINDOWS * config.run.samples}}
    return parse_config(tree, config.source)


def adapt_parameters(window: int) -> dict[str, int]:
    """The diagnostician's window of an adapted run: ``window`` samples, diagnosed every quarter of it."""
    return {
        "diagnostician.window_samples": window,
        "diagnostician.min_samples": window,
        "diagnostician.update_period_samples": max(window // 4, 1),
    }


def run_adapted(
    config: PmrConfig,
    options_factory: Callable[..., Any],
    run_node_set: Callable[..., Any],
    *,
    extra_nodes: Callable | None = None,
    proposal_filter: Callable[[dict], dict] | None = None,
) -> tuple[Any, Any]:
    """Run the node set with a :class:`ModelAdapter`; the node-set run and the adapter.

    Parameters
    ----------
    config : PmrConfig
        The user's configuration (``run.samples`` is one window).
    options_factory : callable
        :class:`~pmr_ros.node_set.NodeSetOptions` (given, so this module need not import rclpy at load);
        the adapter joins the node set in its ``namespace``.
    run_node_set : callable
    extra_nodes : callable, optional
        Other nodes spun with the set (a bag recorder).
    proposal_filter : callable, optional
        See :class:`~pmr_ros.nodes.adapter.ModelAdapter` (tests: a deliberately wrong proposal).
    """
    from ..nodes.adapter import ModelAdapter

    window = config.run.samples
    full = adapt_config(config)
    adapters: list[ModelAdapter] = []

    def nodes(context: Any, parameters: dict[str, Any]) -> list[Any]:
        adapters.append(ModelAdapter(context, full, proposal_filter=proposal_filter, namespace=options.namespace))
        return [adapters[0], *(extra_nodes(context, parameters) if extra_nodes else [])]

    options = options_factory(
        diagnose_once=False,
        extra_parameters=adapt_parameters(window),
        extra_nodes=nodes,
        stall_timeout_s=ADAPT_STALL_TIMEOUT_S,
    )
    result = run_node_set(full, options)
    return result, adapters[0]


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
        lines.append(
            f"  {change['element']}: K {b['gain']:.4g} -> {a['gain']:.4g}, tau {b['time_constant']} -> "
            f"{a['time_constant'] if a['time_constant'] is None else round(a['time_constant'], 3)}, "
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


def adapted_report(adapter: Any) -> tuple[Any, dict[str, Any]]:
    """The final window's diagnosis and the report's ``adaptation`` object.

    Raises
    ------
    CommandError
        No update could be made or judged (the notes say why), exit 3.
    """
    if adapter.adaptation is None or adapter.after is None or adapter.before is None:
        why = "; ".join(adapter.notes) or "no verdict window after the switch before the run ended"
        raise CommandError(f"--adapt: no model update was judged: {why}", code=3)
    out = adapter.adaptation.to_dict()
    out["before_window"] = [adapter.before.first, adapter.before.last]
    out["after_window"] = [adapter.after.first, adapter.after.last]
    out["notes"] = [*out["notes"], *adapter.notes]
    return adapter.after.diagnosis, out


def check_adapt(args: argparse.Namespace) -> None:
    """Refuse option clashes of ``--adapt`` before any work."""
    if getattr(args, "adapt", False) and args.batch:
        raise CommandError("--adapt updates the running controller of the node set; it cannot be used with --batch")
    if getattr(args, "adapt", False) and getattr(args, "method", None) == "classic":
        raise CommandError("--adapt needs the parametric method (a corrected model); --method classic cannot give it")
