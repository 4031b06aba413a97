"""``pmr-ros run --adapt``: run, diagnose, apply the proposed model, run on, diagnose again; roll back if worse.

The node set runs three windows of ``run.samples`` (N) samples: the
diagnostician diagnoses every N/4 samples a window of N; its first verdict
(samples 0..N-1, against the model the controller started with) comes with a
proposal, which :class:`~pmr_ros.nodes.adapter.ModelAdapter` hands to the
controller as an atomic change of its ``system`` parameters; the diagnostician
follows the switch and diagnoses the new model on samples after it only; the
first such verdict window is judged against the first
(:func:`pmr_ros.core.loop.adaptation.judge_update`) and a worse update is rolled
back.  The node set, its options and the adapter are given by the caller, so
this module stays free of rclpy.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..config import PmrConfig, parse_config
from .refusal import EXIT_INSUFFICIENT, ServiceError

__all__ = [
    "ADAPT_STALL_TIMEOUT_S",
    "ADAPT_WINDOWS",
    "adapt_config",
    "adapt_parameters",
    "adapted_report",
    "run_adapted",
]

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
    adapter_type: Callable[..., Any],
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
    adapter_type : callable
        :class:`~pmr_ros.nodes.adapter.ModelAdapter` (given for the same reason).
    extra_nodes : callable, optional
        Other nodes spun with the set (a bag recorder).
    proposal_filter : callable, optional
        See :class:`~pmr_ros.nodes.adapter.ModelAdapter` (tests: a deliberately wrong proposal).
    """
    window = config.run.samples
    full = adapt_config(config)
    adapters: list[Any] = []

    def nodes(context: Any, parameters: dict[str, Any]) -> list[Any]:
        adapters.append(adapter_type(context, full, proposal_filter=proposal_filter, namespace=options.namespace))
        return [adapters[0], *(extra_nodes(context, parameters) if extra_nodes else [])]

    options = options_factory(
        diagnose_once=False,
        extra_parameters=adapt_parameters(window),
        extra_nodes=nodes,
        stall_timeout_s=ADAPT_STALL_TIMEOUT_S,
    )
    result = run_node_set(full, options)
    return result, adapters[0]


def adapted_report(adapter: Any) -> tuple[Any, dict[str, Any]]:
    """The final window's diagnosis and the report's ``adaptation`` object.

    Raises
    ------
    ServiceError
        No update could be made or judged (the notes say why), exit 3.
    """
    if adapter.adaptation is None or adapter.after is None or adapter.before is None:
        why = "; ".join(adapter.notes) or "no verdict window after the switch before the run ended"
        raise ServiceError(f"--adapt: no model update was judged: {why}", code=EXIT_INSUFFICIENT)
    out = adapter.adaptation.to_dict()
    out["before_window"] = [adapter.before.first, adapter.before.last]
    out["after_window"] = [adapter.after.first, adapter.after.last]
    out["notes"] = [*out["notes"], *adapter.notes]
    return adapter.after.diagnosis, out
