"""``pmr-ros sweep``: the paper's time-constant study (sections 3.4-3.6, Figs. 2-7)."""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from ..outputs import add_output_arguments, check_outputs
from . import (
    CommandError,
    check_memory,
    load_checked_config,
    writable_file,
)
from .arguments import add_options
from .sweep_options import OPTIONS

if TYPE_CHECKING:
    from ..config import PmrConfig
    from ..sweep.plan import SweepPlan


PLAN_BYTES_PER_RUN = 400
"""Memory of one planned run before it runs (its key, its place in a point's task) [bytes]."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``pmr-ros sweep`` to the sub-command parsers."""
    p = sub.add_parser(
        "sweep",
        help="sweep a time constant (paper's Figs. 2-7): CSV of every estimate, figures, report",
        description=(
            "Multiply an element's time constant by nu in both the plant and the controller's model "
            "(the mismatch of the paper's eq. 15 stays on the plant only), run the five scenarios of "
            "Table 2 for several seeds at each nu, diagnose every run, and write results.csv, figures "
            "and a markdown report.  Default: the paper's two sweeps, tau11 = 16.7 nu (eq. 18) and "
            "tau21 = 10.9 nu (eq. 19; the paper's figures call it G12), nu = 1, 1.25, ..., 10, 5 seeds."
        ),
    )
    add_options(p, OPTIONS)
    add_output_arguments(p)
    p.set_defaults(handler=handle)


def _seeds(args: argparse.Namespace, config: PmrConfig) -> tuple[int, int]:
    """First seed and count, within the declared range of ``run.seed``."""
    from ..config.schema import parameter

    first = config.run.seed if args.first_seed is None else args.first_seed
    highest = int(parameter("run.seed").maximum or 0)
    if first + args.seeds - 1 > highest:
        raise CommandError(
            f"--seeds {args.seeds} from seed {first}: the last seed {first + args.seeds - 1} exceeds run.seed's "
            f"maximum {highest}"
        )
    return first, args.seeds


def _nu_count(args: argparse.Namespace) -> int:
    """How many nu values the grid options ask for (before the grid is built)."""
    if args.nu is not None:
        return len(args.nu.split(","))
    start, stop, step = args.nu_start, args.nu_stop, args.nu_step
    if not all(math.isfinite(v) and v > 0 for v in (start, stop, step)) or stop < start:
        return 1  # nu_grid says what is wrong
    return int(math.floor((stop - start) / step + 1e-9)) + 1


def _check_size(args: argparse.Namespace, config: PmrConfig) -> None:
    """Refuse a sweep whose plan or runs in flight do not fit in memory, before building anything."""
    from ..core.sim.memory import diagnosis_bytes, simulation_bytes
    from ..core.sim.model import SCENARIOS

    _, seeds = _seeds(args, config)
    samples = config.run.samples if args.samples is None else args.samples
    elements = max(1, len([e for e in args.elements.split(",") if e.strip()]))
    per_point = len(SCENARIOS) * seeds
    total = elements * _nu_count(args) * per_point
    jobs = max(1, min(args.jobs, elements * _nu_count(args)))
    model = config.model
    in_flight = 2 * simulation_bytes(model, samples, runs=per_point) + diagnosis_bytes(model, samples)
    check_memory(
        {"plan": total * PLAN_BYTES_PER_RUN, f"{jobs} point(s) in flight": jobs * in_flight},
        cause=f"{total} runs of {samples} samples, {per_point} per point",
        advice="use fewer seeds, nu values or samples (or fewer --jobs)",
    )


def _plan(args: argparse.Namespace, config: PmrConfig):
    from ..core.pmr.diagnosis import METHODS
    from ..sweep.plan import PlanError, SweepPlan, element_index, nu_grid, parse_nu_list

    if config.explicit_plant is not None:
        raise CommandError(
            f"{config.source}: the sweep runs the mismatch scenarios of the Table 2 study on the model, and a "
            "plant block fixes the plant; remove the plant block (give a mismatch block instead) or use pmr-ros run"
        )
    try:
        nu = parse_nu_list(args.nu) if args.nu is not None else nu_grid(args.nu_start, args.nu_stop, args.nu_step)
        elements = tuple(e.strip() for e in args.elements.split(",") if e.strip())
        if not elements:
            raise PlanError("--elements: name at least one element to sweep")
        if len(set(elements)) != len(elements):
            raise PlanError(f"--elements: {args.elements!r} names an element twice")
        for element in elements:
            element_index(config.model, element)
        methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
        unknown = [m for m in methods if m not in METHODS]
        if not methods or unknown or len(set(methods)) != len(methods):
            raise PlanError(f"--methods: {args.methods!r}: give one or more of {', '.join(METHODS)}, each once")
    except PlanError as exc:
        raise CommandError(str(exc)) from None
    first, count = _seeds(args, config)
    samples = config.run.samples if args.samples is None else args.samples
    return SweepPlan(
        elements=elements, nu=nu, seeds=tuple(range(first, first + count)), samples=samples, methods=methods
    )


def _prepare_folder(args: argparse.Namespace, out: Path, manifest: dict) -> None:
    """Check ``--out`` against ``--force``/``--resume``, clear it for ``--force``, create it."""
    from ..sweep import store

    if out.exists() and not out.is_dir():
        raise CommandError(f"--out {out}: exists and is not a folder")
    has_sweep = out.is_dir() and any(out.iterdir())
    if args.force and args.resume:
        raise CommandError("--force and --resume contradict each other: choose one")
    if has_sweep and not (args.force or args.resume):
        raise CommandError(
            f"--out {out}: folder exists and is not empty; use --force to start afresh or --resume to continue"
        )
    if args.force:
        for name in (store.RESULTS_FILE, store.MANIFEST_FILE):
            (out / name).unlink(missing_ok=True)
    if args.resume:
        _continue_manifest(out, manifest)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CommandError(f"--out {out}: cannot create: {exc.strerror or exc}") from None


def _continue_manifest(out: Path, manifest: dict) -> None:
    """For ``--resume``: refuse a sweep of another configuration or sample count; carry its times on."""
    from ..sweep import store

    old = store.read_manifest(out)
    if old is None:
        return
    for key in ("config_fingerprint", "samples"):
        if old.get(key) != manifest[key]:
            raise CommandError(
                f"--resume: {out} holds a sweep with a different {key.replace('_', ' ')} "
                f"({old.get(key)} vs {manifest[key]}); use --force to start afresh"
            )
    manifest["wall_time_s"] = float(old.get("wall_time_s", 0.0))
    manifest["cpu_time_s"] = float(old.get("cpu_time_s", 0.0))


def handle(args: argparse.Namespace) -> int:
    """Run ``pmr-ros sweep``; the exit code."""
    from ..sweep import store

    config = load_checked_config(args.config)
    check_outputs(args, inputs=(args.config,), files=("report",), folders=("out",))
    out = Path(args.out)
    report_path = Path(args.report) if args.report else out / "reproduction.md"
    results = out / store.RESULTS_FILE
    if args.report and not args.no_report:
        writable_file(args.report, "--report")
    if args.report_only:
        _report_only(results, report_path, config)
        return 0
    manifest = _sweep(args, config, out, results)
    if not args.no_report:
        _write_report(results, report_path, config, manifest)
    return 0


def _report_only(results: Path, report_path: Path, config: PmrConfig) -> None:
    """``--report-only``: the report of the sweep in ``results``' folder, which must have run with ``config``."""
    from ..sweep import store

    if not results.is_file():
        raise CommandError(f"--report-only: {results} does not exist; run the sweep first")
    manifest = store.read_manifest(results.parent) or {}
    recorded = manifest.get("config_fingerprint")
    # The report quotes the configuration's settings beside the results: they must be the ones the sweep ran with.
    if recorded is not None and recorded != store.config_fingerprint(config.parameters):
        raise CommandError(
            f"--report-only: {results.parent} was swept with another configuration "
            f"({manifest.get('config', 'see its manifest')}); "
            "pass that file with --config"
        )
    _write_report(results, report_path, config, manifest)


def _sweep(args: argparse.Namespace, config: PmrConfig, out: Path, results: Path) -> dict:
    """Run the runs of the plan not yet in ``results``; the manifest, written beside it."""
    from ..sweep import store
    from ..sweep.execute import plan_tasks

    _check_size(args, config)
    plan = _plan(args, config)
    manifest = {
        "config": config.source,
        "config_fingerprint": store.config_fingerprint(config.parameters),
        "samples": plan.samples,
        "wall_time_s": 0.0,
        "cpu_time_s": 0.0,
    }
    if args.scheduler:
        _check_scheduler(args)  # before --force clears the folder or a manifest is written: a failure leaves nothing
    _prepare_folder(args, out, manifest)
    tasks = plan_tasks(config, plan, _done_runs(results, config.model.n_outputs * config.model.n_inputs))
    manifest.update(
        elements=list(plan.elements),
        nu=list(plan.nu),
        seeds=list(plan.seeds),
        scenarios=list(plan.scenarios),
        methods=list(plan.methods),
        jobs=args.jobs,
        scheduler=args.scheduler,
        cpu_count=os.cpu_count(),
    )
    store.write_manifest(out, manifest)
    todo = sum(len(t.runs) for t in tasks)
    if not args.quiet:
        _announce(args, plan, tasks, todo)
    try:
        _timed_execution(args, config, tasks, results, out=out, manifest=manifest)
    except CommandError:
        if args.scheduler and not results.exists():  # the cluster went away before the first row: no sweep to resume
            (out / store.MANIFEST_FILE).unlink(missing_ok=True)
        raise
    return manifest


def _check_scheduler(args: argparse.Namespace) -> None:
    """Refuse, in one line, a ``--scheduler`` where no Dask scheduler answers in ``--connect-timeout``."""
    from ..sweep.cluster import ClusterError, check_scheduler

    try:
        check_scheduler(args.scheduler, timeout_s=args.connect_timeout)
    except ClusterError as exc:
        raise CommandError(str(exc)) from None


def _announce(args: argparse.Namespace, plan: SweepPlan, tasks: list, todo: int) -> None:
    """What the sweep is about to do, and where, on stderr."""
    where = (
        f"the Dask cluster at {args.scheduler}"
        if args.scheduler
        else f"{min(args.jobs, max(len(tasks), 1))} process(es)"
    )
    print(
        f"pmr-ros sweep: {len(plan.elements)} sweep(s) x {len(plan.nu)} nu x {len(plan.scenarios)} scenarios x "
        f"{len(plan.seeds)} seeds = {plan.total_runs} runs of {plan.samples} samples; {todo} to do on {where}",
        file=sys.stderr,
    )


def _timed_execution(
    args: argparse.Namespace, config: PmrConfig, tasks: list, results: Path, *, out: Path, manifest: dict
) -> None:
    """Execute the tasks; the wall and CPU time go into the manifest (written even if the sweep is stopped)."""
    from ..sweep import store

    t0 = time.perf_counter()
    outcome = None
    try:
        outcome = _execute(args, config, tasks, results)
    finally:
        manifest["wall_time_s"] = round(manifest["wall_time_s"] + time.perf_counter() - t0, 2)
        if outcome is not None:
            manifest["cpu_time_s"] = round(manifest["cpu_time_s"] + outcome.cpu_time_s, 2)
        store.write_manifest(out, manifest)
    if not args.quiet:
        todo = sum(len(t.runs) for t in tasks)
        print(f"pmr-ros sweep: {todo} runs in {time.perf_counter() - t0:.1f} s; results in {results}", file=sys.stderr)


def _execute(args: argparse.Namespace, config: PmrConfig, tasks: list, results: Path):
    """Run the tasks locally or on the cluster of ``--scheduler``; a cluster that cannot be used is a clean error.

    So is a local worker process that ended mid-point (killed, out of memory): one line, exit code 1, saying
    where the points done by then are.
    """
    from ..core.sim.workers import WorkerEnded
    from ..sweep.cluster import ClusterError
    from ..sweep.execute import execute

    try:
        return execute(config, tasks, results, jobs=args.jobs, progress=not args.quiet, scheduler=args.scheduler)
    except ClusterError as exc:
        raise CommandError(str(exc)) from None
    except WorkerEnded as exc:
        raise CommandError(
            f"a sweep worker process ended before its points were done (killed? out of memory?): {exc.done} of "
            f"{exc.total} points done, their rows in {results}; continue with --resume",
            code=1,
        ) from None


def _done_runs(results: Path, n_elements: int) -> set[tuple]:
    """Keys (:func:`store.run_key`) of the complete runs in ``results``, which is rewritten without torn ones."""
    from ..sweep import store

    if not results.is_file():
        return set()
    try:
        rows = store.complete_rows(store.read_rows(results), n_elements)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    store.rewrite(results, rows)
    return {store.run_key(r) for r in rows}


def _write_report(results: Path, report_path: Path, config: PmrConfig, manifest: dict) -> None:
    from ..report.sweep_document import write_report
    from ..sweep import store

    try:
        rows = store.read_rows(results)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    if not rows:
        raise CommandError(f"{results}: no results to report")
    try:
        written = write_report(rows, report_path, config, manifest)
    except OSError as exc:
        raise CommandError(f"--report {report_path}: cannot write: {exc.strerror or exc}") from None
    print(f"pmr-ros sweep: report {report_path} ({len(written)} figures)", file=sys.stderr)
