"""Benchmark of the numerical core (prints figures; not a test).

- closed-loop steps per second of plant + PRBS + MPC on Wood-Berry (target >= 3,000)
- median QP solve time of the MPC (dual active set), when a constraint binds and when forced every step
- diagnosis time for 8,192 samples of the 2x2 (target <= 50 ms)
- a bumpless model switch of the MPC (QP rebuilt, state from the kept input history), and the control impact

Run: .venv/bin/python benchmarks/bench_core.py
"""

from __future__ import annotations

import platform
import statistics
import time

from pmr_ros.config import load_config
from pmr_ros.core.loop.impact import loop_figures
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.excitation import PrbsGenerator
from pmr_ros.core.sim.true_plant import FoptdPlant


def closed_loop_rate(config, samples: int, always_solve_qp: bool) -> tuple[float, LinearMpc]:
    plant = FoptdPlant(config.plant("full"), config.noise_std, 1)
    mpc = LinearMpc(config.model, config.mpc, record_solve_times=True, always_solve_qp=always_solve_qp)
    prbs = PrbsGenerator(config.prbs, 1)
    t0 = time.perf_counter()
    for k in range(samples):
        y = plant.measure()
        plant.advance(mpc.step(y, prbs.value(k)))
    return samples / (time.perf_counter() - t0), mpc


def main() -> None:
    config = load_config()
    print(f"pmr_ros core benchmark on {platform.processor() or platform.machine()}, Python {platform.python_version()}")
    samples = 16384
    rate, mpc = closed_loop_rate(config, samples, always_solve_qp=False)
    solves = mpc.statistics.solve_time_s
    print(f"closed loop (Wood-Berry, default MPC): {rate:,.0f} steps/s  (target >= 3,000)")
    print(
        f"  QP solved on {len(solves)} of {samples} steps (a limit binds); median solve "
        f"{1e6 * statistics.median(solves):.0f} us"
    )
    rate_qp, mpc_qp = closed_loop_rate(config, samples, always_solve_qp=True)
    print(
        f"closed loop with the QP solved every step: {rate_qp:,.0f} steps/s; median solve "
        f"{1e6 * statistics.median(mpc_qp.statistics.solve_time_s):.0f} us"
    )

    for label, cfg in (("2x2", config), ("3x3", load_config("config/three_by_three.yaml"))):
        record = simulate(cfg, samples=8192)
        for method in ("classic", "parametric"):
            times = []
            for _ in range(10):
                t0 = time.perf_counter()
                diagnose(
                    record.r, record.u, record.y, model=cfg.model, pmr=cfg.pmr, parametric=cfg.parametric, method=method
                )
                times.append(time.perf_counter() - t0)
            target = "  (target <= 50 ms)" if (label, method) == ("2x2", "classic") else ""
            print(
                f"diagnosis of 8,192 samples ({label}, {method}): median {1e3 * statistics.median(times):.1f} ms, "
                f"best {1e3 * min(times):.1f} ms{target}"
            )

    switch_and_impact()


def switch_and_impact() -> None:
    """Time of a live model switch after a run, and of one simulation of the control impact."""
    for label, cfg in (("2x2", load_config()), ("3x3", load_config("config/three_by_three.yaml"))):
        _, mpc = closed_loop_rate(cfg, 2000, always_solve_qp=False)
        truth = cfg.plant("full")
        times = []
        for _ in range(10):
            t0 = time.perf_counter()
            mpc.switched(truth)
            times.append(time.perf_counter() - t0)
        print(
            f"model switch ({label}, {mpc.applied_inputs.shape[0]} inputs of history): median "
            f"{1e3 * statistics.median(times):.1f} ms"
        )
        t0 = time.perf_counter()
        loop_figures(cfg, truth, samples=cfg.impact.samples)
        elapsed = time.perf_counter() - t0
        elements = int(cfg.model.present.sum())
        print(
            f"control impact ({label}): one simulation of {cfg.impact.samples} samples {elapsed:.2f} s; "
            f"{elements + 2} per diagnosis with every element mismatched"
        )


if __name__ == "__main__":
    main()
