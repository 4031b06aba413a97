"""``pmr-ros replay BAG``: publish a bag's messages on their topics for live nodes.

Sample by sample in simulated-time lockstep (/clock first), by default paced so
subscribers in other processes keep up (at most 1000 samples/s,
``--max-samples-per-second``; see :data:`pmr_ros.nodes.bag_player.DEFAULT_MAX_SAMPLES_PER_S`
for why acknowledgements cannot do it), or at the recorded pace times ``--rate``.
The diagnostician's own outputs are left out unless ``--all-topics``: a live
``pmr_diagnostician`` listening to the replay reacts as it did to the run.
"""

from __future__ import annotations

import argparse
import sys
import time

from . import CommandError, nonnegative_float, nonnegative_int, positive_float


def register(sub) -> None:
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
    p.add_argument("bag", metavar="BAG", help="rosbag2 bag directory (or a .mcap file)")
    p.add_argument(
        "--rate",
        type=positive_float,
        default=None,
        metavar="R",
        help="replay at R times the recorded pace (default: lockstep, paced by --max-samples-per-second)",
    )
    p.add_argument(
        "--max-samples-per-second",
        type=nonnegative_float,
        default=None,
        metavar="N",
        help="lockstep pace limit (default: 1000; 0: unbounded, only if every subscriber keeps up)",
    )
    p.add_argument(
        "--all-topics", action="store_true", help="also replay /diagnostics and /pmr/estimates (left out by default)"
    )
    p.add_argument(
        "--wait",
        type=nonnegative_int,
        default=10,
        metavar="S",
        help="wait up to S seconds for subscribers of r, u and y before starting (default: 10)",
    )
    p.add_argument(
        "--linger",
        type=nonnegative_float,
        default=1.0,
        metavar="S",
        help="keep publishers alive S seconds after the last message (default: 1)",
    )
    p.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros replay``; the exit code (130 when stopped early)."""
    from ..bag.reader import open_bag
    from ..bag.schema import BagError

    try:
        bag = open_bag(args.bag)
    except BagError as exc:
        raise CommandError(str(exc)) from None
    try:
        from rclpy.executors import SingleThreadedExecutor

        from ..contract.topics import topic
        from ..nodes.bag_player import DEFAULT_MAX_SAMPLES_PER_S, BagPlayerNode
        from ..ros.signals import rclpy_session
    except ImportError as exc:
        raise CommandError(f"replaying needs rclpy ({exc}); install pmr_ros[ros]") from None
    node = None
    with rclpy_session() as stop:
        try:
            try:
                node = BagPlayerNode(bag, include_outputs=args.all_topics)
            except BagError as exc:
                raise CommandError(str(exc)) from None
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            signals = [topic(k).name for k in ("setpoint", "manipulated_input", "measured_output")]
            if args.wait and not node.wait_for_subscribers(
                signals, float(args.wait), lambda: executor.spin_once(timeout_sec=0.05)
            ):
                print(
                    f"pmr-ros replay: no subscriber on {', '.join(n for n in signals if node.subscribers(n) == 0)} "
                    f"after {args.wait} s; replaying anyway",
                    file=sys.stderr,
                )
            started = time.monotonic()
            limit = (
                DEFAULT_MAX_SAMPLES_PER_S
                if args.max_samples_per_second is None
                else (args.max_samples_per_second or None)
            )
            count = node.play(rate=args.rate, max_samples_per_s=limit, should_stop=lambda: bool(stop))
            wall = time.monotonic() - started
            end = time.monotonic() + max(args.linger, 0.0)
            while time.monotonic() < end and not stop:
                executor.spin_once(timeout_sec=0.05)
            total = sum(node.published.values())
            print(
                f"pmr-ros replay: {count} samples, {total} messages from {bag.path} in {wall:.2f} s "
                f"({total / wall if wall > 0 else 0:.0f} msgs/s)",
                file=sys.stderr,
            )
        finally:
            if node is not None:
                node.destroy_node()
    return 130 if stop else 0
