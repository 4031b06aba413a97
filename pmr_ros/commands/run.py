"""``pmr-ros run``: run the closed loop and print the per-element verdicts."""

from __future__ import annotations

import argparse
import sys

from . import EXIT_INSUFFICIENT, CommandError, add_system_arguments, run_overrides


def register(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run the closed loop (PRBS setpoints, MPC, plant) and diagnose it",
        description="Run the closed loop for N samples on a configured system and print the per-element PMR verdicts.",
    )
    add_system_arguments(p)
    p.add_argument("--json", metavar="FILE", help="also write the report as JSON")
    p.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> int:
    from ..core.closed_loop import simulate
    from ..core.config import load_config
    from ..core.pmr import diagnose
    from ..core.report import build_report, format_table

    config = load_config(args.config, run_overrides(args))
    record = simulate(config)
    diagnosis = diagnose(record.r, record.u, record.y, config.model, config.pmr)
    report = build_report(config, diagnosis, command="run", scenario=config.run.scenario, seed=config.run.seed)
    sys.stdout.write(format_table(report))
    if args.json:
        try:
            from ..core.report import write_json

            write_json(report, args.json)
        except OSError as exc:
            raise CommandError(f"--json {args.json}: cannot write: {exc.strerror or exc}") from None
    return 0 if diagnosis.status == "ok" else EXIT_INSUFFICIENT
