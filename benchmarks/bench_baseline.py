"""docs/results.md's baseline table: Wood-Berry with the paper's mismatch over seeds, both methods (prints a table).

Per element, the mean +/- standard deviation over ``--seeds`` runs of the shipped configuration
(``config/wood_berry.yaml``, scenario ``full``, 16,384 samples) of the classic gain ratio M(0), its
time-constant index and delay, and of the parametric dK %, dtau % and dD (the delay as its
distinct values), beside the injected mismatch.  Then how often each parametric verdict was right
(``mismatch`` on every changed parameter, ``ok`` on the unchanged delays).

Run: .venv/bin/python benchmarks/bench_baseline.py [--seeds 20] [--samples 16384]
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from bench_disturbance import run_case  # the same simulation and diagnosis (this folder is on sys.path)

from pmr_ros.config import config_dir, load_config


def _spread(values: list[float], digits: int, sign: bool = True) -> str:
    fmt = f"{{:{'+' if sign else ''}.{digits}f}}"
    return f"{fmt.format(np.mean(values))} ± {np.std(values, ddof=1):.{digits}f}"


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--samples", type=int, default=16384)
    args = parser.parse_args(argv)
    config = load_config(config_dir() / "wood_berry.yaml")
    truth = config.mismatch.for_scenario("full")
    _, diagnoses = run_case(config, "full", range(1, args.seeds + 1), args.samples)
    per: dict[str, dict[str, list]] = {}
    for diagnosis in diagnoses:
        for e in diagnosis:
            c, p = e.classic, e.parametric
            row = per.setdefault(e.name, {})
            for key, value in (
                ("M0", c.gain_ratio),
                ("index", c.tau_index),
                ("cD", c.delay_mismatch_samples),
                ("dK", p.gain_mismatch_pct),
                ("dtau", p.tau_mismatch_pct),
                ("pD", p.delay_mismatch_samples),
                ("verdicts", (p.gain_verdict, p.tau_verdict, p.delay_verdict)),
            ):
                row.setdefault(key, []).append(value)
    print(
        f"load {os.getloadavg()[0]:.1f}; Wood-Berry, scenario full, {args.seeds} seeds x {args.samples} samples; "
        "mean ± standard deviation"
    )
    print(
        "| element | injected ΔK, Δτ, ΔD | classic M(0) | classic τ index | classic ΔD | parametric ΔK % | "
        "parametric Δτ % | param. ΔD | parametric verdicts right |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, row in per.items():
        e = next(e for e in diagnosis if e.name == name)
        i, k = e.row, e.column
        injected = (truth.gain_pct[i, k], truth.time_constant_pct[i, k], int(truth.delay_samples[i, k]))
        expected = ("mismatch", "mismatch", "mismatch" if injected[2] else "ok")
        right = sum(v == expected for v in row["verdicts"])
        delays = ", ".join(f"{d:+d}" for d in sorted(set(row["pD"])))
        classic_delays = ", ".join(f"{d:+d}" for d in sorted(set(row["cD"])))
        print(
            f"| {name} | {injected[0]:+.0f} %, {injected[1]:+.0f} %, {injected[2]:+d} | "
            f"{_spread(row['M0'], 3, False)} | "
            f"{_spread(row['index'], 1)} | {classic_delays} | {_spread(row['dK'], 2)} | {_spread(row['dtau'], 2)} | "
            f"{delays} | {right} of {len(row['verdicts'])} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
