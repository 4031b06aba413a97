"""``pmr-ros reindex BAG``: write a bag whose recorder was killed again as a complete bag.

``pmr-ros diagnose`` and ``replay`` read such a bag as it is; ``reindex``
makes a complete copy (MCAP summary, ``metadata.yaml``) for tools that need
one, such as stock ``ros2 bag``.  The original stays untouched.
"""

from __future__ import annotations

import argparse
import sys

from . import CommandError
from .arguments import FORCE, add_options


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros reindex`` to the sub-command parsers."""
    p = sub.add_parser(
        "reindex",
        help="copy a bag whose recorder was killed into a complete bag (summary, metadata.yaml)",
        description=(
            "Read every message a killed recording committed (an MCAP file without its summary, a sqlite3 bag "
            "without metadata.yaml) and write them, unchanged, into a new complete bag that stock ros2 bag reads. "
            "The original is not modified."
        ),
    )
    p.add_argument("bag", metavar="BAG", help="rosbag2 bag directory (or a .mcap file)")
    p.add_argument("--out", metavar="DIR", help="the complete bag to write (default: BAG_reindexed)")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), help="storage of the copy (default: the bag's own)")
    add_options(p, [FORCE.but(help="overwrite an existing bag at --out")])
    p.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros reindex``; the exit code."""
    from ..bag.reader import open_bag
    from ..bag.repair import reindex
    from ..bag.storage import BagError

    out = args.out or f"{str(args.bag).rstrip('/')}_reindexed"
    try:
        bag = open_bag(args.bag)
        writer = reindex(bag, out, storage=args.storage, force=args.force)
    except BagError as exc:
        raise CommandError(str(exc)) from None
    state = "complete already" if bag.complete else "not closed by its recorder"
    print(
        f"pmr-ros reindex: {writer.message_count} messages of {bag.path} ({state}) written to {writer.path} "
        f"({writer.storage}, complete)",
        file=sys.stderr,
    )
    return 0
