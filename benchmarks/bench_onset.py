"""Time of the onset fit for a year of daily-stepped 14-day windows of a 32-element controller (a script, not a test).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_onset.py [--windows 365] [--elements 32] [--seed 0]

Every element has three parameters (dK, dtau, dD); one in four of them steps
or ramps somewhere in the year, the rest stay put.  The window estimates are
built as the monitor sees them (the path's mean over each window plus white
noise averaged over the same window).  Printed: the one-off no-change
simulation (shared by every fit with the same window times), the fits' wall
time in total and per fit (and the process's CPU time, which a loaded machine
does not inflate), and how many changes were found against injected.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from pmr_ros.core.monitor import detect_onset, window_plan, window_views
from pmr_ros.core.monitor.changepoint import shapes_for
from pmr_ros.core.monitor.nochange import null_quantile

WINDOW = 14


def records(windows: int, fits: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Window estimates (fits x windows), their standard errors, window end times [days], injected kinds.

    The standard errors vary +-30 % from window to window (the noise keeps a common scale).
    """
    days = windows + WINDOW - 1
    plan = window_plan(n_samples=days, window=WINDOW, step=1)
    ends = np.array([last + 1.0 for _, last in plan])
    rng = np.random.default_rng(seed)
    t = np.arange(days)
    estimates, kinds = np.empty((fits, len(plan))), np.zeros(fits, dtype=int)
    errors = 1 + 0.3 * np.sin(np.arange(len(plan)) / 11.0 + np.arange(fits)[:, None])
    for index in range(fits):
        kinds[index] = rng.choice([0, 0, 0, 0, 0, 0, 1, 2])  # 0 none, 1 step, 2 ramp
        onset = rng.uniform(30, days - 30)
        path = [np.zeros(days), 3.0 * (t >= onset), 20.0 * np.clip((t - onset) / 14, 0, 1)][kinds[index]]
        daily = rng.standard_normal(days) * np.sqrt(WINDOW)
        # window means of unit white noise, scaled by each window's error: the overlap correlation stays exact
        noise = np.array([view.mean() for view in window_views(daily, plan)]) * errors[index]
        estimates[index] = [view.mean() for view in window_views(path, plan)] + noise
    return estimates, errors, ends, kinds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=365)
    parser.add_argument("--elements", type=int, default=32)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--missing", type=float, default=0.0, help="share of each element's windows inconclusive (own pattern each)"
    )
    args = parser.parse_args()
    fits = 3 * args.elements
    estimates, errors, ends, kinds = records(args.windows, fits, args.seed)
    rng = np.random.default_rng(args.seed + 1)
    for element in range(args.elements):
        # an element's windows are inconclusive together: its three parameters share the pattern
        estimates[3 * element : 3 * element + 3, rng.random(ends.size) < args.missing] = np.nan

    start = time.perf_counter()
    shapes_for(tuple(ends.tolist()), float(WINDOW), 1.0)
    null_quantile(grid=ends, window=WINDOW, resolution=1.0, significance=0.01)
    once = time.perf_counter() - start
    start, cpu = time.perf_counter(), time.process_time()
    found = [
        detect_onset(estimates=estimates[i], errors=errors[i], end_times=ends, window=WINDOW).kind for i in range(fits)
    ]
    fitting, cpu = time.perf_counter() - start, time.process_time() - cpu

    names = ["none", "step", "drift"]
    print(f"{args.windows} windows x {args.elements} elements x 3 parameters = {fits} onset fits", end="")
    print(f", {100 * args.missing:.0f} % of each element's windows inconclusive" if args.missing else "")
    print(f"  candidates and no-change simulation on the full grid: {once:6.2f} s")
    extra = " (each element's windows left out: one more simulation per element)" if args.missing else ""
    print(f"  fits: {fitting:6.2f} s in all, {1000 * fitting / fits:6.1f} ms per fit (CPU time {cpu:.2f} s){extra}")
    print(f"  total: {once + fitting:6.2f} s")
    print("  injected -> found: " + ", ".join(f"{name:>6s}" for name in names))
    for index, name in enumerate(names):
        counts = [sum(1 for f, k in zip(found, kinds, strict=True) if k == index and f == other) for other in names]
        print(f"  {name:>17s}: " + ", ".join(f"{count:6d}" for count in counts))


if __name__ == "__main__":
    main()
