"""The peer methods beside the project's PMR on Wood-Berry with the paper's mismatch (prints tables; not a test).

Per record length, case (white measurement noise; or that plus the coloured
output disturbance of bench_disturbance, std 0.3 through 1/(1 - 0.97 z^-1))
and seed: each method's per-element outcome (detected, verdict, score, dK %
with its interval, dtau %, dD) and its CPU time; with several seeds, a summary
per method: median |dK error|, gain-interval coverage, detection rate.

Methods: partial correlation (Badwe et al. 2009), prediction-error fits of
each row (output error, Box-Jenkins ARMA(1,1)), the classic PMR and the
project's parametric PMR.

Measured (8 seeds, --max-delay-shift 10, 2 shared cores; median |dK error| pp / gain-interval coverage / CPU s):

    case, samples        pem_oe             pem_bj            parametric        classic
    white, 8,192         0.33 / 88 % / 3.2  0.32 / 88 % / 10  0.22 / 88 % / 0.12  0.94 / - / 0.02
    white, 16,384        0.18 / 97 % / 6.3  0.17 / 97 % / 17  0.19 / 97 % / 0.15  0.52 / - / 0.03
    coloured, 8,192      14.7 /  0 % / 3.3  1.07 / 91 % / 7.9 1.35 / 91 % / 0.12  19.8 / - / 0.02
    coloured, 16,384     15.6 /  0 % / 5.8  0.83 / 97 % / 14  0.95 / 97 % / 0.13  10.1 / - / 0.03

The partial correlation flags every element in every run here (all four are mismatched), 0.2-0.6 s.

Run: .venv/bin/python benchmarks/bench_peers.py [--samples 8192,16384] [--cases white,coloured] [--seeds 1]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from collections.abc import Callable

import numpy as np

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.peers import PeerOutcome, Tolerances, classic_pmr, from_diagnosis, partial_correlation_test, pem_diagnosis

CASES = {"white": 0.0, "coloured": 0.3}
"""Standard deviation of the coloured output disturbance per case (pole 0.97; 0: none)."""

DISTURBANCE_POLE = 0.97

Method = Callable[..., dict[str, PeerOutcome]]


def methods(config, max_shift: int) -> dict[str, Method]:
    """Each method as ``f(record) -> outcomes`` with this configuration's model and settings."""
    model, tol = config.model, Tolerances.from_settings(config.parametric)

    def parametric(rec):
        d = diagnose(
            rec.r, rec.u, rec.y, model=model, pmr=config.pmr, parametric=config.parametric, method="parametric"
        )
        return from_diagnosis(d)

    return {
        "partial_corr": lambda rec: partial_correlation_test(rec.u, rec.y, model=model),
        "pem_oe": lambda rec: pem_diagnosis(
            rec.u, rec.y, model=model, noise_model="output_error", tolerances=tol, max_delay_shift=max_shift
        ),
        "pem_bj": lambda rec: pem_diagnosis(
            rec.u, rec.y, model=model, noise_model="box_jenkins", tolerances=tol, max_delay_shift=max_shift
        ),
        "classic": lambda rec: classic_pmr(rec.r, rec.u, rec.y, model=model, settings=config.pmr),
        "parametric": parametric,
    }


def _number(value: float | None, fmt: str = "{:+7.2f}") -> str:
    return " " * 7 if value is None else fmt.format(value)


def row_text(name: str, o: PeerOutcome) -> str:
    interval = "" if o.gain_interval is None else f"[{o.gain_interval[0]:+6.1f}, {o.gain_interval[1]:+6.1f}]"
    delay = "  " if o.delay_samples is None else f"{o.delay_samples:+d}"
    return (
        f"  {name:<12} {o.element:<4} {'yes' if o.detected else 'no ':<3} {o.verdict:<12} "
        f"{o.score:10.3g} {o.score_kind:<9} dK {_number(o.gain_pct)} {interval:<17} "
        f"dtau {_number(o.tau_pct)} dD {delay}"
    )


def run_case(samples: int, case: str, seed: int, max_shift: int) -> dict[str, tuple[dict[str, PeerOutcome], float]]:
    """Every method on one simulated record: outcomes and CPU seconds."""
    overrides: dict = {"run": {"samples": samples, "scenario": "full", "seed": seed}}
    if CASES[case] > 0:
        overrides["noise"] = {"disturbance_std": [CASES[case]] * 2, "disturbance_pole": DISTURBANCE_POLE}
    config = load_config(overrides=overrides)
    record = simulate(config)
    out = {}
    for name, method in methods(config, max_shift).items():
        start = time.process_time()
        outcomes = method(record)
        out[name] = (outcomes, time.process_time() - start)
    return out


def summary(runs: list[dict[str, tuple[dict[str, PeerOutcome], float]]], truth: np.ndarray) -> None:
    """Median |dK error|, gain-interval coverage, detection rate and CPU time per method over the runs."""
    print(f"  {'method':<12} {'median |dK err| pp':>18} {'coverage':>9} {'detected':>9} {'CPU s':>7}")
    for name in runs[0]:
        errors, covered, intervals, detected, cpu = [], 0, 0, 0, []
        for run in runs:
            outcomes, seconds = run[name]
            cpu.append(seconds)
            for o, true in zip(outcomes.values(), truth, strict=True):
                detected += o.detected
                if o.gain_pct is not None:
                    errors.append(abs(o.gain_pct - true))
                if o.gain_interval is not None:
                    intervals += 1
                    covered += o.gain_interval[0] <= true <= o.gain_interval[1]
        median = f"{statistics.median(errors):18.2f}" if errors else f"{'-':>18}"
        coverage = f"{covered / intervals:9.0%}" if intervals else f"{'-':>9}"
        elements = len(runs) * len(truth)
        print(f"  {name:<12} {median} {coverage} {detected / elements:9.0%} {statistics.median(cpu):7.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", default="8192,16384", help="record lengths, comma-separated")
    parser.add_argument("--cases", default="white,coloured", help=f"of {', '.join(CASES)}")
    parser.add_argument("--seeds", type=int, default=1, help="seeds 1..n per length and case")
    parser.add_argument("--max-delay-shift", type=int, default=10, help="PEM delay search range [samples]")
    parser.add_argument("--quiet", action="store_true", help="summaries only, no per-element rows")
    args = parser.parse_args()
    truth = load_config().mismatch.gain_pct.ravel()
    print(f"peer methods on Wood-Berry (paper's mismatch: dK {truth.tolist()} %), {platform.machine()}")
    for case in args.cases.split(","):
        for samples in (int(s) for s in args.samples.split(",")):
            runs = []
            for seed in range(1, args.seeds + 1):
                run = run_case(samples, case, seed, args.max_delay_shift)
                runs.append(run)
                if args.quiet:
                    continue
                print(f"\n{case}, {samples} samples, seed {seed}")
                for name, (outcomes, seconds) in run.items():
                    for o in outcomes.values():
                        print(row_text(name, o))
                    print(f"  {name:<12} CPU {seconds:.2f} s")
            print(f"\nsummary: {case}, {samples} samples, {args.seeds} seed(s)")
            summary(runs, truth)


if __name__ == "__main__":
    main()
