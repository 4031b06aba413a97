"""Memory per sample, measured, beside the estimates the commands refuse runs with (a script, not a test).

    .venv/bin/python benchmarks/bench_memory.py [--samples N]

* simulation and diagnosis: the peak ``tracemalloc`` sees, per sample, for the
  shipped 2x2 and 3x3 systems, beside :func:`pmr_ros.core.sim.memory.simulation_bytes`
  and :func:`~pmr_ros.core.sim.memory.diagnosis_bytes`;
* a live window: the resident memory an aligner holding N complete samples
  adds, per sample, beside :func:`~pmr_ros.core.sim.memory.window_bytes`;
* the node set: the peak resident memory of ``pmr-ros run`` (four nodes in
  one process) at N and 4N samples; the difference per sample is what each
  sample costs (window, diagnosis, middleware).
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np

from pmr_ros.config import config_dir, load_config
from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.memory import diagnosis_bytes, simulation_bytes, window_bytes


def traced_peak(run) -> tuple[int, object]:
    """Peak traced bytes above the start, and the result."""
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    result = run()
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    return peak, result


def core(samples: int) -> None:
    """Simulation and diagnosis of the shipped systems."""
    print(f"{'system':22s} {'simulation B/sample':>22s} {'estimate':>9s} {'diagnosis B/sample':>20s} {'estimate':>9s}")
    for name in ("wood_berry.yaml", "three_by_three.yaml"):
        config = load_config(config_dir() / name)
        sim, record = traced_peak(lambda c=config: simulate(c, samples=samples))
        diag, _ = traced_peak(
            lambda c=config, r=record: diagnose(r.r, r.u, r.y, model=c.model, pmr=c.pmr, parametric=c.parametric)
        )
        print(
            f"{name:22s} {sim / samples:22.0f} {simulation_bytes(config.model, 1):9d} {diag / samples:20.0f} "
            f"{diagnosis_bytes(config.model, 1):9d}"
        )


def window(samples: int) -> None:
    """Resident memory of an aligner holding ``samples`` complete samples."""
    config = load_config()
    model = config.model
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    aligner = SampleAligner(1.0, names, {s: s for s in "ruy"}, samples, 64)
    for k in range(samples):
        for s in "ruy":
            aligner.add(s, float(k), (), np.zeros(2))
    grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) * 1024
    print(f"live window (2x2): {grown / samples:.0f} B/sample resident; estimate {window_bytes(model, 1)}")


def node_set(samples: int) -> None:
    """Peak resident memory of ``pmr-ros run`` at ``samples`` and 4 x ``samples``."""
    peaks = []
    for n in (samples, 4 * samples):
        code = (
            "import resource, sys; from pmr_ros.cli import main; main(['run', '--samples', sys.argv[1]]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)"
        )
        proc = subprocess.run(
            [sys.executable, "-c", code, str(n)], capture_output=True, text=True, check=False, cwd=Path.cwd()
        )
        peaks.append(int(proc.stderr.strip().splitlines()[-1]) * 1024)
    per_sample = (peaks[1] - peaks[0]) / (3 * samples)
    model = load_config().model
    estimate = window_bytes(model, 1) + diagnosis_bytes(model, 1)
    print(
        f"node set (pmr-ros run): peak {peaks[0] / 1e6:.0f} MB at {samples}, {peaks[1] / 1e6:.0f} MB at {4 * samples} "
        f"samples: {per_sample:.0f} B/sample; estimate {estimate} (window + diagnosis)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=16384)
    args = parser.parse_args()
    core(args.samples)
    window(4 * args.samples)
    node_set(args.samples)


if __name__ == "__main__":
    main()
