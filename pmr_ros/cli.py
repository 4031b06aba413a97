"""The ``pmr-ros`` command line.

Each sub-command lives in its own module of :mod:`pmr_ros.commands` with a
``register(subparsers)`` function, listed in ``COMMANDS``.  Errors in the
user's input end with one clear line on stderr and a non-zero exit, never a
traceback.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType
from typing import NoReturn

from . import __version__
from .commands import EXIT_INTERRUPTED, EXIT_USAGE, CommandError
from .config import ConfigError
from .outputs import OutputError
from .ros.signals import RosInitError
from .service.refusal import ServiceError

COMMANDS = ["run", "sweep", "benchmark", "record", "replay", "diagnose", "reindex", "model_files"]
"""Modules of :mod:`pmr_ros.commands`, in the order ``--help`` lists them."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (and a pointer to ``--help``), exit code 2."""

    def error(self, message: str) -> NoReturn:
        """Print ``prog: error: message (see prog --help)`` on stderr and exit with code 2."""
        self.exit(EXIT_USAGE, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``pmr-ros`` argument parser with every sub-command of :data:`COMMANDS`."""
    parser = OneLineParser(
        prog="pmr-ros",
        description="Model-plant mismatch diagnosis for MPC with the plant-model ratio (PMR).",
    )
    parser.add_argument("--version", action="version", version=f"pmr-ros {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.commands.{name}").register(sub)
    return parser


def _interrupt_on_sigterm() -> None:
    """Let SIGTERM unwind like Ctrl-C, so open bags and nodes are closed on the way out."""

    def handler(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pmr-ros`` console script; returns the exit code."""
    args = build_parser().parse_args(argv)
    _interrupt_on_sigterm()
    try:
        return args.handler(args)
    except (ConfigError, CommandError, OutputError, ServiceError, RosInitError) as exc:
        print(f"pmr-ros: error: {' '.join(str(exc).split())}", file=sys.stderr)  # one line, whatever the cause
        return getattr(exc, "code", EXIT_USAGE)
    except KeyboardInterrupt:
        print("pmr-ros: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
