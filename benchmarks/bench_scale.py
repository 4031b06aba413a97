"""Benchmark of the diagnosis and the closed loop against model size (prints a table; not a test).

For 2, 4, 8, 16 and 32 inputs, square (n x n) and 1:2 non-square (n/2 x n, more MVs than
CVs, MV dither on every input so that the rows are identifiable), with half of the cells
empty (every output keeps one element; the others are drawn at random, seeded): the
closed loop of the core (``core.closed_loop.simulate``: PRBS setpoints, the MPC on main,
the plant with the model's mismatch) runs 16,384 samples, then the record is diagnosed
by the classic method alone and by the parametric one (which keeps the classic numbers
beside its own: that is the whole diagnosis).  Printed per size: closed-loop steps/s,
both diagnosis times, and how many modeled elements come out within the specification
(dK 3 pp, dtau 5 pp, dD exact) and how many elements are inconclusive; on a second line the CPU
times, the peak memory of the process so far, how many modelled elements are decided (ok or
mismatch) and the estimates' errors against the injected mismatch (median and largest).  Big
units need more samples than the default: ``--sizes 32,48 --shapes square --samples 65536``
(a 48x48 half-empty unit needs 49,797 unbroken samples; its closed loop takes about 20 min of
CPU); ``--cache DIR`` keeps each record and reuses it (with the times of the run that made it).

Run: .venv/bin/python benchmarks/bench_scale.py [--sizes 2,4,8,16,32] [--samples 16384] [--shapes square,wide]
[--empty 0.5] [--cache DIR]
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from pmr_ros.config import PmrConfig, load_config
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.records import Record
from pmr_ros.core.results import Diagnosis
from pmr_ros.core.sim.closed_loop import simulate


def industrial_system(n_out: int, n_in: int, *, empty: float = 0.5, seed: int = 0) -> dict:
    """Parameter blocks of an n_out x n_in model, ``empty`` of its cells empty, with a mismatch in some elements.

    Each output has a strong element on "its" input (so the controller can move every output) and
    random others; gains 0.5 .. 2 of random sign, time constants 6 .. 16, delays 0 .. 4 samples.
    """
    rng = np.random.default_rng(seed)
    present = np.zeros((n_out, n_in), dtype=bool)
    own = [(i * n_in) // n_out for i in range(n_out)]
    present[np.arange(n_out), own] = True
    free = np.flatnonzero(~present.ravel())
    rng.shuffle(free)
    present.ravel()[free[: max(0, round((1.0 - empty) * n_out * n_in) - n_out)]] = True
    gain = rng.uniform(0.5, 2.0, (n_out, n_in)) * rng.choice([-1.0, 1.0], (n_out, n_in))
    gain[np.arange(n_out), own] = 2.0 * np.abs(gain[np.arange(n_out), own])
    tau = rng.uniform(6.0, 16.0, (n_out, n_in))
    delay = rng.integers(0, 5, (n_out, n_in)).astype(float)
    kinds = np.where(present, "foptd", "none")
    mismatch = {
        "gain_pct": np.where(present, rng.choice([-12.0, 0.0, 10.0], present.shape), 0.0),
        "time_constant_pct": np.where(present, rng.choice([-10.0, 0.0, 12.0], present.shape), 0.0),
        "delay_samples": np.where(present, rng.choice([0, 0, 1], present.shape), 0),
    }
    return {
        "system": {
            "name": f"industrial_{n_out}x{n_in}",
            "sample_time": 1.0,
            "output_names": [f"y{i + 1}" for i in range(n_out)],
            "input_names": [f"u{k + 1}" for k in range(n_in)],
            "element_type": kinds.ravel().tolist(),
            "gain": np.where(present, gain, 0.0).ravel().tolist(),
            "time_constant": np.where(present, tau, 0.0).ravel().tolist(),
            "delay": np.where(present, delay, 0.0).ravel().tolist(),
        },
        "mismatch": {key: value.ravel().tolist() for key, value in mismatch.items()},
        "excitation": {"mv_dither_amplitude": 0.3 if n_in > n_out else 0.0},
    }


def load(tree: dict, folder: Path) -> PmrConfig:
    """The configuration of ``tree`` through a params file, as a user would give it."""
    path = folder / f"{tree['system']['name']}.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": tree}}))
    return load_config(path)


@dataclass
class Row:
    shape: str
    present: int
    steps_per_s: float
    classic_s: float
    parametric_s: float
    within: int
    inconclusive: int
    simulation_cpu_s: float = float("nan")
    parametric_cpu_s: float = float("nan")
    peak_mb: float = float("nan")
    errors: dict | None = None


def within_specification(config: PmrConfig, diagnosis: Diagnosis) -> tuple[int, int]:
    """Modeled elements within dK 3 pp, dtau 5 pp, dD exact; and elements inconclusive."""
    mm = config.mismatch.for_scenario("full")
    good = 0
    for e in diagnosis:
        p = e.parametric
        if e.model.kind == "none" or p is None or p.gain_mismatch_pct is None:
            continue
        i, k = e.row, e.column
        tau_ok = p.tau_mismatch_pct is None or abs(p.tau_mismatch_pct - mm.time_constant_pct[i, k]) <= 5.0
        gain_ok = abs(p.gain_mismatch_pct - mm.gain_pct[i, k]) <= 3.0
        good += int(gain_ok and tau_ok and p.delay_mismatch_samples == mm.delay_samples[i, k])
    return good, sum(e.verdict == "inconclusive" for e in diagnosis)


def estimate_errors(config: PmrConfig, diagnosis: Diagnosis) -> dict:
    """Of the modelled elements: how many are decided, and their estimates' errors against the injected mismatch.

    ``decided``: verdict ok or mismatch; ``gain_pp``/``tau_pp``: (median, largest) absolute error [pp] of the
    elements with an estimate; ``delay_exact``: share of them whose delay change is the injected one.
    """
    mm = config.mismatch.for_scenario("full")
    decided, gain, tau, delay = 0, [], [], []
    for e in diagnosis:
        p = e.parametric
        if e.model.kind == "none" or p is None:
            continue
        decided += int(e.verdict in ("ok", "mismatch"))
        if p.gain_mismatch_pct is None:
            continue
        i, k = e.row, e.column
        gain.append(abs(p.gain_mismatch_pct - mm.gain_pct[i, k]))
        if p.tau_mismatch_pct is not None:
            tau.append(abs(p.tau_mismatch_pct - mm.time_constant_pct[i, k]))
        delay.append(p.delay_mismatch_samples == mm.delay_samples[i, k])

    def spread(values: list) -> tuple[float, float]:
        return (float(np.median(values)), float(np.max(values))) if values else (float("nan"), float("nan"))

    share = float(np.mean(delay)) if delay else float("nan")
    return {"decided": decided, "gain_pp": spread(gain), "tau_pp": spread(tau), "delay_exact": share}


def closed_loop(config: PmrConfig, samples: int, cache: Path | None = None) -> tuple[Record, float, float]:
    """The closed-loop record, its simulation's wall and CPU time [s]; kept in (read from) ``cache`` if given.

    A record read from the cache reports the times of the run that made it.
    """
    path = None if cache is None else cache / f"{config.model.name}_{int(config.model.present.sum())}el_{samples}.npz"
    if path is not None and path.exists():
        held = np.load(path)
        dither = held["dither"] if "dither" in held else None
        record = Record(held["r"], held["u"], held["y"], dither)
        return record, float(held["simulation_wall_s"]), float(held["simulation_cpu_s"])
    start, cpu = time.perf_counter(), time.process_time()
    record = simulate(config, samples=samples)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    if path is not None:
        extra = {} if record.dither is None else {"dither": record.dither}
        np.savez(path, r=record.r, u=record.u, y=record.y, simulation_wall_s=wall, simulation_cpu_s=cpu, **extra)
    return record, wall, cpu


def measure(config: PmrConfig, samples: int, cache: Path | None = None) -> Row:
    """Simulate, diagnose with each method, time both and check the numbers against the injected mismatch."""
    record, simulation_s, simulation_cpu = closed_loop(config, samples, cache)
    times, cpu = {}, 0.0
    for method in ("classic", "parametric"):
        start, cpu = time.perf_counter(), time.process_time()
        diagnosis = diagnose(
            record.r,
            record.u,
            record.y,
            model=config.model,
            pmr=config.pmr,
            parametric=config.parametric,
            method=method,
            dither=record.dither,
        )
        times[method], cpu = time.perf_counter() - start, time.process_time() - cpu
    within, inconclusive = within_specification(config, diagnosis)
    m = config.model
    return Row(
        f"{m.n_outputs}x{m.n_inputs}",
        int(m.present.sum()),
        samples / simulation_s,
        times["classic"],
        times["parametric"],
        within,
        inconclusive,
        simulation_cpu_s=simulation_cpu,
        parametric_cpu_s=cpu,
        peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        errors=estimate_errors(config, diagnosis),
    )


def details(row: Row) -> str:
    """The second line of a size: CPU times, peak memory, decided elements and the estimates' errors."""
    e = row.errors or {}
    gain, tau = e.get("gain_pp", (np.nan, np.nan)), e.get("tau_pp", (np.nan, np.nan))
    return (
        f"{'':>7s} CPU: closed loop {row.simulation_cpu_s:.0f} s, parametric {row.parametric_cpu_s:.1f} s; "
        f"peak memory {row.peak_mb:.0f} MB; decided {e.get('decided', 0)}/{row.present}; |error| median/max: "
        f"dK {gain[0]:.2f}/{gain[1]:.1f} pp, dtau {tau[0]:.2f}/{tau[1]:.1f} pp; "
        f"dD exact {100 * e.get('delay_exact', np.nan):.0f} %"
    )


def growth(rows: list[Row], attribute: str) -> float:
    """Exponent p of ``time ~ elements^p`` fitted over the rows (log-log least squares)."""
    x = np.log([row.present for row in rows])
    y = np.log([getattr(row, attribute) for row in rows])
    return float(np.polyfit(x, y, 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2,4,8,16,32", help="numbers of inputs")
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--shapes", default="square,wide", help="square: n x n; wide: n/2 x n")
    parser.add_argument("--empty", type=float, default=0.5, help="fraction of the cells that are empty")
    parser.add_argument("--cache", type=Path, default=None, help="keep (and reuse) each closed-loop record here")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    print(
        f"pmr_ros scale benchmark on {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.1f}, Python {platform.python_version()}, {args.samples} samples, "
        f"{100 * args.empty:.0f} % of the cells empty"
    )
    print(
        f"{'model':>7s} {'elements':>8s} {'loop steps/s':>12s} {'classic s':>9s} {'parametric s':>12s} "
        f"{'within spec':>11s} {'inconclusive':>12s}"
    )
    with tempfile.TemporaryDirectory() as folder:
        for shape in args.shapes.split(","):
            rows = []
            for n_in in sizes:
                n_out = n_in if shape == "square" else max(1, n_in // 2)
                config = load(industrial_system(n_out, n_in, empty=args.empty), Path(folder))
                row = measure(config, args.samples, args.cache)
                rows.append(row)
                print(
                    f"{row.shape:>7s} {row.present:8d} {row.steps_per_s:12,.0f} {row.classic_s:9.2f} "
                    f"{row.parametric_s:12.2f} {row.within:>6d}/{row.present:<4d} {row.inconclusive:12d}",
                    flush=True,
                )
                print(details(row), flush=True)
            if len(rows) > 2:
                print(
                    f"  {shape}: parametric time ~ elements^{growth(rows, 'parametric_s'):.2f}, "
                    f"classic ~ elements^{growth(rows, 'classic_s'):.2f}, "
                    f"loop steps/s ~ elements^{growth(rows, 'steps_per_s'):.2f}"
                )


if __name__ == "__main__":
    main()
