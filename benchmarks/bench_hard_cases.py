"""Benchmark of the parametric method on hard systems (prints a table; not a test).

For each case of ``test/hard_cases.py`` (an ill-conditioned column whose controller moves its
inputs together, a near-collinear 2x2, a near-zero model gain), with and without the injected
mismatch, over ``--seeds`` seeds: the share of confidently wrong parameter verdicts (a
``mismatch`` on a parameter that did not change, ``ok`` on one that changed by more than twice its
tolerance, a wrong sign, a decisive delay other than the true one; must be <= 5 %), the 95 %
interval coverage over the parameters that are not inconclusive (must be >= 90 %) and over all
parameters with an interval (the intervals' own calibration), and the share of inconclusive verdicts.  Two processes.

Run: .venv/bin/python benchmarks/bench_hard_cases.py [--seeds 20] [--cases ogunnaike_ray,...] [--examples]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "test"))

from hard_cases import CASES, Score, run, score  # noqa: E402

from pmr_ros.core.sim.workers import worker_context  # noqa: E402


def _runs(job: tuple[str, bool, list[int]]) -> Score:
    name, mismatch, seeds = job
    case = CASES[name]
    config = case.config()
    total = Score()
    for seed in seeds:
        total.add(score(run(case, seed, mismatch=mismatch, config=config), config, mismatch=mismatch))
    return total


def _line(name: str, mismatch: bool, total: Score, seconds: float) -> str:
    wrong = 100.0 * total.wrong / max(total.verdicts, 1)
    covered = 100.0 * total.covered / max(total.intervals, 1)
    undecided = 100.0 * total.inconclusive / max(total.verdicts, 1)
    covered_all = 100.0 * total.covered_all / max(total.intervals_all, 1)
    flag = "" if wrong <= 5.0 and covered >= 90.0 else "   <-- out of specification"
    return (
        f"{name:<16} {'full' if mismatch else 'none':<5} {total.verdicts:>8} {wrong:>9.1f} % "
        f"{covered:>9.1f} % ({total.intervals:>4}) {covered_all:>7.1f} % {undecided:>9.1f} % {seconds:>7.1f}{flag}"
    )


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--examples", action="store_true", help="print the confidently wrong verdicts")
    args = parser.parse_args()
    seeds = list(range(1, args.seeds + 1))
    print(f"load average {os.getloadavg()[0]:.1f}, {args.seeds} seeds per line, two processes")
    print(
        f"{'case':<16} {'scen':<5} {'verdicts':>8} {'wrong':>11} {'coverage':>18} {'(all)':>9} "
        f"{'inconclusive':>11} {'time s':>7}"
    )
    with ProcessPoolExecutor(2, mp_context=worker_context()) as pool:
        for name in args.cases.split(","):
            for mismatch in (False, True):
                start = time.perf_counter()
                jobs = [(name, mismatch, seeds[h::2]) for h in range(2)]
                total = Score()
                for part in pool.map(_runs, jobs):
                    total.add(part)
                print(_line(name, mismatch, total, time.perf_counter() - start), flush=True)
                if args.examples:
                    for example in total.wrong_examples:
                        print(f"    {example}")


if __name__ == "__main__":
    main()
