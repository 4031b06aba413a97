"""``pmr-ros replay BAG``: publish a bag's messages on their topics for live nodes.

Sample by sample in simulated-time lockstep (the clock first), as fast as the
slowest lockstep consumer (a diagnostician, a recorder, in any process) takes
them: they report their progress and the player never runs more than
``--max-samples-ahead`` samples ahead of one (:mod:`pmr_ros.ros.flow`), so
none loses a sample.  ``--max-samples-per-second`` adds a pace for subscribers
that do not report progress; ``--rate`` replays at the recorded pace times R.
``--namespace`` publishes into another node set's namespace.  The
diagnostician's own outputs are left out unless ``--all-topics``: a live
``pmr_diagnostician`` listening to the replay reacts as it did to the run.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from . import CommandError, add_namespace_argument, declared_int, nonnegative_float, nonnegative_int, positive_float
from .arguments import add_options, option

EXIT_MISSED = 5
"""Exit code with ``--strict`` when a subscriber may have missed samples."""


OPTIONS = (
    option("bag", metavar="BAG", help="rosbag2 bag directory (or a .mcap file)"),
    option(
        "--rate",
        type=positive_float,
        default=None,
        metavar="R",
        help="replay at R times the recorded pace (default: lockstep, paced by --max-samples-per-second)",
    ),
    option(
        "--max-samples-per-second",
        type=nonnegative_float,
        default=None,
        metavar="N",
        help="lockstep: also at most N samples per second (default: unbounded; the consumers' progress paces it)",
    ),
    option(
        "--max-samples-ahead",
        type=declared_int("simulation.max_samples_ahead"),
        default=None,
        metavar="N",
        help="lockstep: publish a sample only once every consumer has taken the one N samples back "
        "(default: simulation.max_samples_ahead)",
    ),
)
"""The options of ``pmr-ros replay`` before ``--namespace``."""

MORE_OPTIONS = (
    option(
        "--all-topics",
        action="store_true",
        help="also replay the diagnostician's outputs, diagnostics, pmr/estimates and pmr/proposed_model (left out by "
        "default)",
    ),
    option(
        "--wait",
        type=nonnegative_int,
        default=10,
        metavar="S",
        help="wait up to S seconds for subscribers of r, u and y before starting, and at least "
        "simulation.discovery_settle_s (3 s) for DDS to discover every one of them (default: 10; 0: start at once)",
    ),
    option(
        "--linger",
        type=nonnegative_float,
        default=1.0,
        metavar="S",
        help="keep publishers alive S seconds after the last message (default: 1)",
    ),
    option(
        "--strict",
        action="store_true",
        help=f"exit with {EXIT_MISSED} when a subscriber may have missed samples (one that does not report progress, "
        "or a consumer that did not take the last sample); default: a warning, exit 0",
    ),
)
"""The options of ``pmr-ros replay`` after ``--namespace``."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros replay`` to the sub-command parsers."""
    p = sub.add_parser(
        "replay",
        help="publish a recorded bag's messages on their topics (lockstep simulated time)",
        description=(
            "Publish the messages of a pmr_ros bag on their topics with the contract's QoS: /clock and r, u, y sample "
            "by sample, "
            "in lockstep, paced by --max-samples-per-second so that subscribers in other processes keep up, or at the "
            "recorded pace times --rate."
        ),
    )
    add_options(p, OPTIONS)
    add_namespace_argument(p, "publish into this node set's namespace (default: the root namespace)")
    add_options(p, MORE_OPTIONS)
    p.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros replay``; the exit code (130 when stopped early)."""
    from ..bag.reader import open_bag
    from ..bag.storage import BagError

    try:
        bag = open_bag(args.bag)
    except BagError as exc:
        raise CommandError(str(exc)) from None
    try:
        from rclpy.executors import SingleThreadedExecutor

        from ..nodes.bag_player import BagPlayerNode
        from ..ros.signals import rclpy_session
    except ImportError as exc:
        raise CommandError(f"replaying needs rclpy ({exc}); install pmr_ros[ros]") from None
    node = None
    with rclpy_session() as stop:
        try:
            try:
                node = BagPlayerNode(
                    bag, include_outputs=args.all_topics, max_ahead=args.max_samples_ahead, namespace=args.namespace
                )
            except BagError as exc:
                raise CommandError(str(exc)) from None
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            missed = _replay(node, executor, args, stop)
        finally:
            if node is not None:
                node.destroy_node()
    if stop:
        return 130
    return EXIT_MISSED if missed and args.strict else 0


FINAL_REPORT_WAIT_S = 3.0
"""After the last sample, how long the consumers' final progress reports are waited for [s]."""


def _wait_for_peers(node: Any, executor: Any, wait_s: float) -> None:
    """Wait for subscribers of r, u, y and for each of them to report progress; say who never did."""
    from ..nodes.bag_player import discovery_settle_s

    signals = node.signal_topics()
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    # consumers started before the replay (a diagnostician and a recorder) are discovered one by one, in up to
    # seconds: one found first must not start the replay before the others are known
    settled = time.monotonic() + min(discovery_settle_s(), wait_s)
    while time.monotonic() < settled:
        spin()
    if not node.wait_for_subscribers(signals, wait_s, spin):
        missing = ", ".join(node.resolve_topic_name(node.topics[n].name) for n in signals if node.subscribers(n) == 0)
        print(f"pmr-ros replay: no subscriber on {missing} after {wait_s:g} s; replaying anyway", file=sys.stderr)
        silent = node.silent_subscribers()  # a subscriber of one signal alone is named too
    else:
        silent = node.wait_for_consumers(wait_s, spin)
    if silent:
        print(
            f"pmr-ros replay: {', '.join(silent)} subscribe(s) to the signals without reporting progress on "
            "pmr/progress: the replay does not wait for them (--max-samples-per-second paces it)",
            file=sys.stderr,
        )


def _replay(node: Any, executor: Any, args: argparse.Namespace, stop: list[int]) -> bool:
    """Replay the bag; whether a subscriber may have missed samples (each one named on stderr)."""
    if args.wait:
        _wait_for_peers(node, executor, float(args.wait))
    started = time.monotonic()
    count = node.play(
        rate=args.rate,
        max_samples_per_s=args.max_samples_per_second or None,
        spin=lambda timeout: executor.spin_once(timeout_sec=timeout),
        should_stop=lambda: bool(stop),
    )
    wall = time.monotonic() - started
    end = time.monotonic() + max(args.linger, 0.0)
    while time.monotonic() < end and not stop:
        executor.spin_once(timeout_sec=0.05)
    total = sum(node.published.values())
    waits = f", held back {node.gate.waits} time(s) by the consumers" if node.gate.waits else ""
    print(
        f"pmr-ros replay: {count} samples, {total} messages from {node.bag.path} in {wall:.2f} s "
        f"({count / wall if wall > 0 else 0:.0f} samples/s{waits})",
        file=sys.stderr,
    )
    # the consumers' last reports may still be on their way: give them a moment before naming one behind
    settle = time.monotonic() + FINAL_REPORT_WAIT_S
    while not node.followers.caught_up() and time.monotonic() < settle and not stop:
        executor.spin_once(timeout_sec=0.05)
    lines = node.followers.lines()
    for line in lines:
        print(f"pmr-ros replay: warning: {line}", file=sys.stderr)
    return bool(lines)
