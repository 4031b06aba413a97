"""``pmr-ros benchmark``: every mismatch-detection method on the labelled scenario runs, scored side by side."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..outputs import check_outputs
from . import CommandError
from .arguments import add_options
from .benchmark_options import OPTIONS


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros benchmark`` to the sub-command parsers."""
    p = sub.add_parser(
        "benchmark",
        help="the peer methods beside ours on labelled runs: results.parquet, scores, a markdown report, the dataset",
        description=(
            "Simulate the labelled runs of the scenario file (Wood-Berry, the 3x3, the debutanizer 4x8, a 16x16 "
            "sparse unit; random per-element mismatch; 2,048 .. 32,768 samples; with and without a coloured "
            "output disturbance), diagnose each with our parametric PMR, the classic PMR, the partial correlation "
            "and the two prediction-error fits, and score them: detection at 1 % and 5 % false alarms, "
            "localisation, quantification error, interval coverage, inconclusive rate, CPU time.  "
            "See docs/benchmark.md."
        ),
    )
    add_options(p, OPTIONS)
    p.set_defaults(handler=handle)


def _list(text: str | None, option: str, convert: type = str) -> tuple | None:
    if text is None:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    try:
        values = tuple(convert(t) for t in items)
    except ValueError:
        raise CommandError(f"{option} {text!r}: not a comma-separated list of whole numbers") from None
    if not values:
        raise CommandError(f"{option} {text!r}: name at least one")
    return values


def _methods(text: str | None) -> tuple[str, ...]:
    from ..benchmark.runner import METHODS

    chosen = _list(text, "--methods") or tuple(METHODS)
    unknown = [m for m in chosen if m not in METHODS]
    if unknown or len(set(chosen)) != len(chosen):
        raise CommandError(f"--methods {text!r}: give one or more of {', '.join(METHODS)}, each once")
    return chosen


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros benchmark``; the exit code."""
    from ..service.benchmark_run import BenchmarkRequest, rescore, run_benchmark

    if args.force and args.resume:
        raise CommandError("--force and --resume contradict each other: choose one")
    check_outputs(args, inputs=(args.scenarios,), files=("report",), folders=("out", "export"))
    out = Path(args.out)
    if args.scenarios is not None and not Path(args.scenarios).is_file():
        raise CommandError(f"--scenarios {args.scenarios}: no such file")
    request = BenchmarkRequest(
        out=out,
        report=Path(args.report) if args.report else out / "benchmark.md",
        quick=args.quick,
        units=_list(args.units, "--units"),
        lengths=_list(args.samples, "--samples", int),
        runs_per_cell=args.runs_per_cell,
        methods=_methods(args.methods),
        jobs=args.jobs,
        scheduler=args.scheduler,
        export=Path(args.export) if args.export else None,
        scenarios=Path(args.scenarios) if args.scenarios else None,
        pem_runs_per_cell=args.pem_runs_per_cell,
        progress=not args.quiet,
        resume=args.resume,
        force=args.force,
    )
    if args.report_only:
        summary = rescore(request)
        print(f"pmr-ros benchmark: {summary.runs} runs scored again; report {request.report}")
        return 0
    summary = run_benchmark(request)
    kept = summary.scored - summary.runs
    resumed = f" and {kept} from the journal" if kept > 0 else ""
    print(
        f"pmr-ros benchmark: {summary.runs} run{'' if summary.runs == 1 else 's'} in {summary.wall_s / 60:.1f} "
        f"min{resumed}; "
        f"{summary.scored} scored; report {request.report}"
    )
    return 0
