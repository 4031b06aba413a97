"""``pmr-ros record DIR``: record the contract's topics of a live ROS graph into a rosbag2 bag.

For nodes running as separate processes (or a ``pmr-ros replay``): the
recorder subscribes to every contract topic of the node set in
``--namespace`` and writes until Ctrl-C/SIGTERM (or ``--duration``).  It is a
lockstep consumer (it reports its progress, so a lockstep plant or player
never outruns it); when stopped it takes what is still on its way, then
closes the bag (:func:`pmr_ros.nodes.bag_recorder.drain`).  The bag is flushed
every ``--flush-period`` seconds, so a killed recorder leaves a readable bag
up to its last flush.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING, Any

from . import (
    CommandError,
    add_namespace_argument,
    add_system_arguments,
    load_checked_config,
    positive_float,
    run_overrides,
)

if TYPE_CHECKING:
    from ..config import PmrConfig


def add_storage_arguments(parser: argparse.ArgumentParser) -> None:
    """--storage/--force, shared with ``pmr-ros run --bag``."""
    parser.add_argument(
        "--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage plugin (default: mcap)"
    )
    parser.add_argument("--force", action="store_true", help="overwrite an existing bag at the path")


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros record`` to the sub-command parsers."""
    p = sub.add_parser(
        "record",
        help="record the contract's topics of a live ROS graph into a rosbag2 bag",
        description=(
            "Subscribe to every topic of the pmr_ros contract (r, u, y, /clock, /diagnostics, /pmr/estimates, "
            "/pmr/run_config) "
            "and write them into a rosbag2 bag until Ctrl-C/SIGTERM. The run's configuration is taken from --config, "
            "else from /pmr/run_config, else from the live pmr_diagnostician's parameters."
        ),
    )
    p.add_argument("bag", metavar="DIR", help="bag directory to create")
    add_storage_arguments(p)
    add_system_arguments(p)
    p.add_argument(
        "--no-parameters", action="store_true", help="do not fetch the configuration from the live pmr_diagnostician"
    )
    p.add_argument(
        "--flush-period",
        type=positive_float,
        default=None,
        metavar="S",
        help="seconds between flushes to disk (default: 0.5)",
    )
    p.add_argument(
        "--duration", type=positive_float, default=None, metavar="S", help="stop after S seconds of wall time"
    )
    add_namespace_argument(p, "record the node set in this namespace (default: the root namespace)")
    p.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros record`` until Ctrl-C, SIGTERM or ``--duration``; the exit code."""
    from ..bag.storage import BagError, RunConfig, recorded_topics
    from ..bag.writer import DEFAULT_FLUSH_PERIOD_S, BagWriter

    run_config = None
    if args.config is not None or run_overrides(args):
        config = load_checked_config(args.config, run_overrides(args))
        run_config = RunConfig(config.parameters, source=str(config.source))
    try:
        from ..nodes.bag_recorder import BagRecorderNode
        from ..ros.signals import rclpy_session
    except ImportError as exc:
        raise CommandError(f"recording needs rclpy ({exc}); install pmr_ros[ros]") from None
    flush = args.flush_period or DEFAULT_FLUSH_PERIOD_S
    namespace = args.namespace or "/"
    try:
        writer = BagWriter(
            args.bag, storage=args.storage, force=args.force, flush_period_s=flush, topics=recorded_topics(namespace)
        )
    except BagError as exc:
        raise CommandError(str(exc)) from None
    node = None
    with rclpy_session() as stop:
        try:
            node = BagRecorderNode(
                writer,
                run_config=run_config,
                parameter_source=None if args.no_parameters else "pmr_diagnostician",
                flush_period_s=flush,
                namespace=namespace,
            )
            _record(node, args, stop)
        finally:
            if node is not None:
                node.close()
                node.destroy_node()
            else:
                writer.close()
    if writer.failure is not None:
        raise CommandError(writer.failure, code=1)
    counts = ", ".join(f"{name} {n}" for name, n in writer.counts.items())
    print(f"pmr-ros record: {writer.message_count} messages in {writer.path} ({counts})", file=sys.stderr)
    return 0


def _record(node: Any, args: argparse.Namespace, stop: list[int]) -> None:
    """Spin the recorder until a stop request or ``--duration``, then take what is on its way."""
    from rclpy.executors import SingleThreadedExecutor

    from ..nodes.bag_recorder import drain

    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        print(
            f"pmr-ros record: recording into {node.writer.path} ({args.storage}); Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        deadline = time.monotonic() + args.duration if args.duration else None
        while not stop and (deadline is None or time.monotonic() < deadline) and node.failure is None:
            executor.spin_once(timeout_sec=0.1)
        drain(node, lambda timeout: executor.spin_once(timeout_sec=timeout))
    finally:
        executor.shutdown(timeout_sec=1.0)


def start_recording(args: argparse.Namespace, config: PmrConfig):
    """The recording of ``pmr-ros run --bag``: the bag is created now (fails before the run)."""
    from ..bag.storage import BagError, recorded_topics
    from ..bag.writer import BagWriter
    from ..nodes.bag_recorder import RunRecording

    namespace = getattr(args, "namespace", None) or "/"
    try:
        writer = BagWriter(args.bag, storage=args.storage, force=args.force, topics=recorded_topics(namespace))
    except BagError as exc:
        raise CommandError(str(exc)) from None
    return RunRecording(writer, str(config.source), config.run.samples, namespace=namespace)
