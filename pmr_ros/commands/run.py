"""``pmr-ros run``: run the closed loop and print the per-element verdicts.

By default the four ROS 2 nodes (plant, PRBS setpoint, MPC, diagnostician) run
in this process over real topics in lockstep, and the verdicts are the
diagnostician's final ones read from /diagnostics.  ``--batch`` runs the pure
core instead (no ROS); both give the same data and verdicts for a seed.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from ..outputs import check_outputs
from ..service.adapted_run import ADAPT_STALL_TIMEOUT_S, adapt_config, adapted_report, run_adapted
from ..service.closing import close_and_write
from . import (
    EXIT_INSUFFICIENT,
    CommandError,
    add_method_argument,
    add_namespace_argument,
    add_system_arguments,
    check_memory,
    load_checked_config,
    nonnegative_int,
    run_overrides,
    writable_file,
)
from .adapt import adaptation_lines, check_adapt
from .arguments import JSON, WIDE, add_options
from .model_output import add_model_arguments, check_model_output
from .preflight import check_model_memory, not_run, run_samples_shortfall
from .record import add_storage_arguments, start_recording

if TYPE_CHECKING:
    from ..config import PmrConfig
    from ..node_set import NodeSetRun


STALL_TIMEOUT_S = ADAPT_STALL_TIMEOUT_S
"""How long the node set may go without progress: its final verdict comes with the control impact."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros run`` to the sub-command parsers."""
    p = sub.add_parser(
        "run",
        help="run the closed loop (PRBS setpoints, MPC, plant) and diagnose it",
        description=(
            "Run the closed loop for N samples on a configured system and print the per-element PMR verdicts. "
            "Default: the four ROS 2 nodes in this process over real topics, verdicts from /diagnostics; --batch: the "
            "pure core."
        ),
    )
    add_system_arguments(p)
    add_method_argument(p)
    add_options(p, [JSON, WIDE])
    p.add_argument("--batch", action="store_true", help="run the pure numerical core instead of the ROS 2 node set")
    p.add_argument(
        "--visible",
        action="store_true",
        help="let other processes see the node set's topics (ROS_DOMAIN_ID / ROS_AUTOMATIC_DISCOVERY_RANGE apply); "
        "default: private to this process",
    )
    p.add_argument(
        "--bag",
        metavar="DIR",
        help="record every contract topic and the run's configuration into a rosbag2 bag (node set only)",
    )
    p.add_argument(
        "--wait-for-subscribers",
        type=nonnegative_int,
        default=None,
        metavar="N",
        help="the plant sends sample 0 once N nodes subscribe to y (default: simulation.wait_for_subscribers, 2: the "
        "controller and the diagnostician); with --visible, count a recorder started before the run (3), so it is "
        "waited for however long DDS takes to discover it",
    )
    add_storage_arguments(p)
    add_namespace_argument(
        p,
        "run the node set in this namespace (its topics become /NS/pmr/...), so several sets share a ROS domain "
        "(with --visible); default: the root namespace",
    )
    add_model_arguments(p)
    p.add_argument(
        "--adapt",
        action="store_true",
        help="close the loop live (node set, parametric): run N = run.samples samples, apply the diagnostician's "
        "proposed model to the running controller, run on, diagnose the new model on N samples after the switch; "
        "an update that makes things worse is rolled back. 3 N samples in all",
    )
    p.set_defaults(handler=handle)


def _node_set_report(config: PmrConfig):
    """Run the node set; the core diagnosis from /diagnostics and the extras the node path knows."""
    try:
        from ..node_set import NodeSetError, NodeSetOptions, run_node_set
    except ImportError as exc:
        raise CommandError(f"the ROS 2 node set needs rclpy ({exc}); install pmr_ros[ros] or use --batch") from None
    return run_node_set, NodeSetOptions, NodeSetError


def run_memory(config: PmrConfig, *, batch: bool) -> dict[str, int]:
    """What a run of ``config.run.samples`` needs in memory [bytes]: the record or live window, and the diagnosis."""
    from ..core.sim.memory import diagnosis_bytes, simulation_bytes, window_bytes

    model, samples = config.model, config.run.samples
    held = simulation_bytes(model, samples) if batch else window_bytes(model, samples)
    return {
        "simulation" if batch else "diagnostician window": held,
        "diagnosis": diagnosis_bytes(model, samples, dither=config.excitation.active),
    }


def _check_before_running(args: argparse.Namespace, config: PmrConfig) -> None:
    """Everything that can be refused before the run: option clashes, memory, the --json path."""
    check_adapt(args)
    if args.adapt and config.pmr.method != "parametric":
        raise CommandError("--adapt needs pmr.method parametric (a corrected model); the configuration has classic")
    if args.bag and args.batch:
        raise CommandError("--bag records the node set's topics; it cannot be used with --batch")
    source = "command line" if args.samples is not None else config.source
    check_model_memory(config)
    check_memory(run_memory(config, batch=args.batch), cause=f"run.samples = {config.run.samples} ({source})")
    if args.json:
        writable_file(args.json, "--json")


def _run_nodes(args: argparse.Namespace, config: PmrConfig, recording: Any):
    """The node set's run (and the adapter of ``--adapt``, else None); the recording is closed after it."""
    run_node_set, NodeSetOptions, NodeSetError = _node_set_report(config)
    extra = recording.nodes if recording else None

    def options(**kwargs):
        return NodeSetOptions(private=not args.visible, namespace=args.namespace or "/", **kwargs)

    try:
        if args.adapt:
            from ..nodes.adapter import ModelAdapter

            return run_adapted(config, options, run_node_set, adapter_type=ModelAdapter, extra_nodes=extra)
        return run_node_set(config, options(extra_nodes=extra, stall_timeout_s=STALL_TIMEOUT_S)), None
    except NodeSetError as exc:
        raise CommandError(str(exc), code=1) from None
    finally:
        if recording is not None:
            recording.close()


def _on_model(config: PmrConfig, adapter: Any):
    """The configuration with the controller's model at the end of an adapted run (for --write-model)."""
    from ..contract.model_topics import with_system

    return with_system(config, adapter.models[-1][1], f"{config.source} (the controller's model at the end)")


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros run``; the exit code (0 verdicts, 3 insufficient data)."""
    from ..report import format_table

    overrides = run_overrides(args)
    if args.wait_for_subscribers is not None:
        overrides["simulation"] = {"wait_for_subscribers": args.wait_for_subscribers}
    config = load_checked_config(args.config, overrides)
    check_outputs(args, inputs=(args.config,), files=("json", "write_model"))
    check_model_output(args)
    _check_before_running(args, config)
    diagnosed = config.run.samples if args.batch else min(config.run.samples, config.diagnostician.window_samples)
    short = run_samples_shortfall(config, samples=diagnosed)
    notes: list[str] = []  # why the control impact was skipped, if it was
    if short is not None:  # known before simulating: no minute spent on a run that cannot be diagnosed
        diagnosis, report = not_run(config, short)
    else:
        diagnosis, report = _batch_run(args, config, notes) if args.batch else _node_set_run(args, config, notes)
    sys.stdout.write(format_table(diagnosis, report, wide=args.wide))
    for note in notes:
        print(f"note: {note}")
    for line in adaptation_lines(report):
        print(line)
    if args.json:
        _write_json(report, args.json)
    return 0 if diagnosis.status == "ok" else EXIT_INSUFFICIENT


def _batch_run(args: argparse.Namespace, config: PmrConfig, notes: list[str]) -> tuple:
    """The closed loop and its diagnosis in this process (``--batch``); the diagnosis and the report."""
    from ..report import build_report
    from ..service.batch_run import simulate_and_diagnose

    diagnosis = simulate_and_diagnose(config, model_path=getattr(args, "write_model", None), notes=notes)
    report = build_report(config, diagnosis, command="run", scenario=config.run.scenario, seed=config.run.seed)
    report["path"] = "batch"
    return diagnosis, report


def _node_set_run(args: argparse.Namespace, config: PmrConfig, notes: list[str]) -> tuple:
    """The node set's run (adapted with ``--adapt``, recorded with ``--bag``); the diagnosis and the report."""
    from ..report import build_report

    recording = start_recording(args, adapt_config(config) if args.adapt else config) if args.bag else None
    result, adapter = _run_nodes(args, config, recording)
    adaptation = None
    if adapter is not None:
        final, adaptation = adapted_report(adapter)
        on_model = _on_model(config, adapter)
        diagnosis = close_and_write(on_model, final, model_path=getattr(args, "write_model", None), notes=notes)
    else:
        diagnosis = close_and_write(
            config, result.diagnosis, model_path=getattr(args, "write_model", None), notes=notes
        )
    report = build_report(config, diagnosis, command="run", scenario=config.run.scenario, seed=config.run.seed)
    report["path"] = "nodes"
    if adaptation is not None:
        report["adaptation"] = adaptation
    report["node_set"] = _node_set_section(result)
    if recording is not None:
        report["bag"] = {
            "path": str(recording.writer.path),
            "storage": recording.writer.storage,
            "messages": recording.writer.counts,
        }
    return diagnosis, report


def _node_set_section(result: NodeSetRun) -> dict:
    """The report's ``node_set`` object: the levels, messages and window of the final verdicts, the timing."""
    return {
        "levels": result.info["levels"],
        "messages": result.info["messages"],
        "window": {k: result.info.get(k) for k in ("window_samples", "first_sample", "last_sample")},
        "estimates": result.estimates,
        "wall_time_s": result.wall_time_s,
        "samples_per_second": result.samples_per_second,
        "diagnostician_warnings": result.warnings,
    }


def _write_json(report: dict, path: str) -> None:
    """``--json``: the report, or one line saying why it cannot be written."""
    from ..report import write_json

    try:
        write_json(report, path)
    except OSError as exc:
        raise CommandError(f"--json {path}: cannot write: {exc.strerror or exc}") from None
