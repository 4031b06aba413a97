"""Benchmark of the sweep: lockstep batch vs one simulate() per run, and the full default sweep.

    .venv/bin/python benchmarks/bench_sweep.py            # one sweep point (25 runs), both ways
    .venv/bin/python benchmarks/bench_sweep.py --full     # plus the whole default sweep (pmr-ros sweep)

Prints wall times; nothing is asserted (timing depends on the machine and its load).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from pmr_ros.cli import main as cli_main
from pmr_ros.config import load_config
from pmr_ros.core.sim.batch import run_lockstep
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import SCENARIOS


def one_point(samples: int, seeds: int) -> None:
    config = load_config()
    runs = [(s, seed) for s in SCENARIOS for seed in range(1, seeds + 1)]
    t0 = time.perf_counter()
    result = run_lockstep(config, runs, samples)
    lockstep = time.perf_counter() - t0
    t0 = time.perf_counter()
    for scenario, seed in runs:
        simulate(config, samples=samples, seed=seed, scenario=scenario)
    serial = time.perf_counter() - t0
    solves = sum(s.solves for s in result.statistics)
    print(
        f"one point, {len(runs)} runs x {samples} samples: lockstep {lockstep:.2f} s, simulate() per run {serial:.2f} "
        "s "
        f"(x{serial / lockstep:.1f}); OSQP solves {solves} ({100 * solves / (len(runs) * samples):.0f} % of steps)"
    )


def full_sweep(jobs: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        code = cli_main(["sweep", "--out", f"{tmp}/sweep", "--jobs", str(jobs), "--no-report"])
        wall = time.perf_counter() - t0
    print(
        f"default sweep (2 x 37 nu x 5 scenarios x 5 seeds x 16384 samples) on {jobs} processes: {wall:.0f} s (exit "
        f"{code})"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--full", action="store_true", help="also time the whole default sweep")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    one_point(args.samples, args.seeds)
    if args.full:
        full_sweep(args.jobs)
