"""The ``pmr-ros`` command line.

Each sub-command is a small function registered in ``COMMANDS``; later
commands (record, replay, diagnose, sweep) plug in the same way.  Errors in the
user's input end with one clear line on stderr and a non-zero exit, never a
traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from . import __version__
from .core.config import ConfigError, load_config
from .core.foptd import SCENARIOS

EXIT_USAGE = 2
EXIT_INSUFFICIENT = 3
EXIT_INTERRUPTED = 130


class CommandError(Exception):
    """A user-facing failure: printed as ``pmr-ros: error: ...``, exit code attached."""

    def __init__(self, message: str, code: int = EXIT_USAGE) -> None:
        super().__init__(message)
        self.code = code


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{value} must be > 0")
    return value


def _nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} must be >= 0")
    return value


def _add_run_parser(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run the closed loop (PRBS setpoints, MPC, plant) and diagnose it",
        description="Run the closed loop for N samples on a configured system and print the per-element PMR verdicts.",
    )
    p.add_argument("--config", metavar="FILE", help="ROS 2 params file of the system (default: the shipped Wood-Berry column)")
    p.add_argument("--scenario", choices=SCENARIOS, help="which part of the configured mismatch the plant gets (default: run.scenario)")
    p.add_argument("--samples", type=_positive_int, metavar="N", help="closed-loop samples (default: run.samples)")
    p.add_argument("--seed", type=_nonnegative_int, metavar="S", help="seed of noise and PRBS phase (default: run.seed)")
    p.add_argument("--json", metavar="FILE", help="also write the report as JSON")
    p.set_defaults(handler=cmd_run)


def _run_overrides(args: argparse.Namespace) -> dict:
    run = {}
    if args.samples is not None:
        run["samples"] = args.samples
    if args.seed is not None:
        run["seed"] = args.seed
    if args.scenario is not None:
        run["scenario"] = args.scenario
    return {"run": run} if run else {}


def cmd_run(args: argparse.Namespace) -> int:
    from .core.closed_loop import simulate
    from .core.pmr import diagnose
    from .core.report import build_report, format_table, write_json

    config = load_config(args.config, _run_overrides(args))
    record = simulate(config)
    diagnosis = diagnose(record.r, record.u, record.y, config.model, config.pmr)
    report = build_report(config, diagnosis, command="run", scenario=config.run.scenario, seed=config.run.seed)
    sys.stdout.write(format_table(report))
    if args.json:
        try:
            write_json(report, args.json)
        except OSError as exc:
            raise CommandError(f"--json {args.json}: cannot write: {exc.strerror or exc}") from None
    return 0 if diagnosis.status == "ok" else EXIT_INSUFFICIENT


COMMANDS: list[Callable] = [_add_run_parser]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pmr-ros",
        description="Model-plant mismatch diagnosis for MPC with the plant-model ratio (PMR).",
    )
    parser.add_argument("--version", action="version", version=f"pmr-ros {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in COMMANDS:
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pmr-ros`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.handler(args)
    except (ConfigError, CommandError) as exc:
        print(f"pmr-ros: error: {exc}", file=sys.stderr)
        return getattr(exc, "code", EXIT_USAGE)
    except KeyboardInterrupt:
        print("pmr-ros: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
