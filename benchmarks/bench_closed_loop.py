"""Closed-loop speed against size (prints figures; not a test).

Systems of 2, 4, 8, 16 and 32 inputs, square and 1:2 (half as many outputs as
inputs), half the cells empty, one output in eight integrating, every input
dithered, the default MPC (Np = 40, Nc = 8): steps per second of the batch
core (``simulate``: PRBS, plant, MPC), how often a limit binds and the QP is
solved, and the controller's set-up time.  BLAS threads spin-wait on a shared
machine; set OPENBLAS_NUM_THREADS=1 for figures that do not depend on the load.

Run: .venv/bin/python benchmarks/bench_closed_loop.py [--samples N] [--sizes 2,4,8,16,32]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from pmr_ros.config import parse_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.batch import run_lockstep


def scaled_system(n_out: int, n_in: int, seed: int = 0) -> dict:
    """The ``system`` block of a random n_out x n_in unit, half empty, one output in eight integrating."""
    rng = np.random.default_rng(seed)
    present = rng.random((n_out, n_in)) < 0.5
    present[np.arange(n_out), np.arange(n_out) % n_in] = True  # every output is moved ...
    present[np.arange(n_in) % n_out, np.arange(n_in)] = True  # ... and every input moves something
    integrating = np.zeros(n_out, dtype=bool)
    integrating[::8] = n_out > 1
    kinds = np.where(present, np.where(integrating[:, None], "integrating", "foptd"), "none")
    gain = rng.uniform(0.5, 2.0, (n_out, n_in)) * rng.choice([-1.0, 1.0], (n_out, n_in))
    gain = np.where(integrating[:, None], 0.05 * gain, gain)
    tau = np.where(kinds == "foptd", rng.uniform(5.0, 20.0, (n_out, n_in)), 0.0)
    delay = np.where(present, rng.integers(0, 6, (n_out, n_in)), 0).astype(float)
    return {
        "name": f"random_{n_out}x{n_in}",
        "sample_time": 1.0,
        "output_names": [f"y{i + 1}" for i in range(n_out)],
        "input_names": [f"u{k + 1}" for k in range(n_in)],
        "element_type": kinds.ravel().tolist(),
        "gain": np.where(present, gain, 0.0).ravel().tolist(),
        "time_constant": tau.ravel().tolist(),
        "delay": delay.ravel().tolist(),
    }


def measure(n_out: int, n_in: int, samples: int) -> dict:
    """Steps/s (wall and CPU), QP share and set-up time of one closed-loop run of ``samples``."""
    tree = {
        "system": scaled_system(n_out, n_in),
        "mismatch": {"gain_pct": 10.0},
        "prbs": {"amplitude": 0.5},
        "excitation": {"mv_dither_amplitude": 0.1},
    }
    config = parse_config(tree, "bench")
    t0 = time.perf_counter()
    LinearMpc(config.model, config.mpc)
    setup = time.perf_counter() - t0
    wall, cpu = time.perf_counter(), time.process_time()
    result = run_lockstep(config, [("full", 1)], samples)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    stats = result.statistics[0]
    return {
        "steps_per_s": samples / wall,
        "cpu_steps_per_s": samples / cpu,
        "qp_share": stats.solves / samples,
        "fallbacks": stats.fallbacks,
        "setup_s": setup,
        "states": config.model.state_space().A.shape[0],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4096)
    parser.add_argument("--sizes", default="2,4,8,16,32")
    args = parser.parse_args()
    print(
        f"pmr_ros closed-loop scaling on {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, "
        f"load {os.getloadavg()[0]:.1f}, {args.samples} samples per run"
    )
    print(f"{'shape':>7} {'states':>6} {'steps/s':>9} {'CPU steps/s':>11} {'QP share':>8} {'set-up s':>8}")
    for n_in in (int(s) for s in args.sizes.split(",")):
        for n_out in dict.fromkeys((n_in, max(n_in // 2, 1))):
            m = measure(n_out, n_in, args.samples)
            print(
                f"{n_out:>3}x{n_in:<3} {m['states']:>6} {m['steps_per_s']:>9,.0f} {m['cpu_steps_per_s']:>11,.0f} "
                f"{m['qp_share']:>8.2f} {m['setup_s']:>8.2f}"
                + (f"  ({m['fallbacks']} fallbacks)" if m["fallbacks"] else "")
            )


if __name__ == "__main__":
    main()
