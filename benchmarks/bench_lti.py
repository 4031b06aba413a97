"""Building and sampling a large step-response model (a script, not a test).

    .venv/bin/python benchmarks/bench_lti.py [--outputs 10] [--inputs 20] [--coefficients 90] [--repeats 3]

A 10 x 20 model of second-order-plus-delay tf elements (one output in five a
ramp), each converted to a step-response curve of 90 coefficients; then, per
step: the curves written and read again as a DMCplus .mdl, the step_response
elements built, and each element sampled: its step response, frequency
response at 511 frequencies, state-space realization and a scaled copy; the
model realized as one system, and every element's output to 4096 samples;
the MPC built on the curves (the DMC form) and 1000 closed-loop samples of it
on the tf plant, setpoints held; and the parametric PMR diagnosis of the curve
model from ``--diagnose-samples`` samples (20,000: 20 MVs need about 10,600
unbroken ones) of a step test of the tf plant (every MV moved by +-1 steps held
15 samples, white output noise 0.05; 0 skips it).
Prints the best wall time of ``--repeats`` runs per step (the diagnosis: once).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pmr_ros.config import load_config
from pmr_ros.core.mpc.controller import LinearMpc, MpcTuning
from pmr_ros.core.pmr.parametric import diagnose_parametric
from pmr_ros.core.records import Record
from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.realize import element_outputs, realize
from pmr_ros.core.sim.step_curve import StepResponse, as_step_response
from pmr_ros.core.sim.true_plant import FoptdPlant
from pmr_ros.models.curve_set import CurveSet
from pmr_ros.models.mdl import read_mdl, write_mdl


def tf_model(n_out: int, n_in: int) -> list[list]:
    """Second-order tf elements with random gains, time constants and delays; every fifth output integrating."""
    rng = np.random.default_rng(0)
    rows = []
    for i in range(n_out):
        row = []
        for _ in range(n_in):
            t1, t2 = rng.uniform(3.0, 15.0), rng.uniform(0.5, 3.0)
            den = f"{t1 * t2}, {t1 + t2}, 1" + (", 0" if i % 5 == 4 else "")
            delay = int(rng.integers(0, 8))
            row.append(transfer_function(f"{rng.uniform(0.5, 2):.4f}", den, delay_samples=delay, sample_time=1.0))
        rows.append(row)
    return rows


def best_of(repeats: int, run) -> tuple[float, object]:
    """Shortest wall time of ``repeats`` calls [s] and the last result."""
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - start)
    return best, result


def _sample(elements: list[list[StepResponse]]) -> int:
    omega = np.linspace(0.0, np.pi, 512)[1:]
    states = 0
    for row in elements:
        for e in row:
            e.step_response(120)
            e.frequency_response(omega)
            states += e.state_space()[0].shape[0]
            e.scaled(gain_ratio=1.1, time_scale=1.2, delay_change=1)
    return states


def _loop(curves: list[list], tfs: list[list], samples: int) -> tuple[float, float]:
    """Seconds to build the MPC on ``curves``, and to run ``samples`` closed-loop samples on the plant ``tfs``."""
    n_out, n_in = len(tfs), len(tfs[0])
    inf = np.full(n_in, np.inf)
    tuning = MpcTuning(
        prediction_horizon=60,
        control_horizon=8,
        output_weight=np.ones(n_out),
        move_weight=np.ones(n_in),
        u_min=-inf,
        u_max=inf,
        du_max=inf,
        input_target=np.zeros(n_in),
        input_target_weight=np.ones(n_in),
        ramp_filter_samples=10.0,
    )
    start = time.perf_counter()
    mpc = LinearMpc(TransferMatrix.of_elements(curves, sample_time=1.0), tuning)
    built = time.perf_counter() - start
    plant, r = FoptdPlant(TransferMatrix.of_elements(tfs, sample_time=1.0), 0.0, 0), np.ones(n_out)
    start = time.perf_counter()
    for _ in range(samples):
        plant.advance(mpc.step(plant.measure(), r))
    return built, time.perf_counter() - start


def _diagnosis(curves: list[list], tfs: list[list], samples: int) -> tuple[float, str]:
    """Seconds to diagnose the curve model from a step test of the tf plant, and the count per verdict."""
    rng = np.random.default_rng(3)
    moves = rng.choice([-1.0, 1.0], size=(samples // 15 + 1, len(tfs[0])))
    u = np.repeat(moves, 15, axis=0)[:samples]
    y = element_outputs(tfs, u).sum(axis=2)
    y = y + 0.05 * rng.standard_normal(y.shape)
    record = Record(np.zeros_like(y), u, y, manual=np.ones(u.shape, dtype=bool))
    config = load_config()
    model = TransferMatrix.of_elements(curves, sample_time=1.0)
    start = time.perf_counter()
    diagnosis = diagnose_parametric([record], model=model, classic=config.pmr, settings=config.parametric)
    seconds = time.perf_counter() - start
    if diagnosis.status != "ok":
        return seconds, f"{diagnosis.status}: {diagnosis.reason}"
    verdicts = [e.verdict for e in diagnosis.elements.values()]
    return seconds, ", ".join(f"{verdicts.count(v)} {v}" for v in sorted(set(verdicts)))


def main() -> None:
    """Time each step and print it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--outputs", type=int, default=10)
    parser.add_argument("--inputs", type=int, default=20)
    parser.add_argument("--coefficients", type=int, default=90)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--diagnose-samples", type=int, default=20000)
    args = parser.parse_args()
    n_out, n_in, n = args.outputs, args.inputs, args.coefficients
    tfs = tf_model(n_out, n_in)
    t_curves, curves = best_of(args.repeats, lambda: [[as_step_response(g, n) for g in row] for row in tfs])
    names = (tuple(f"cv{i}" for i in range(n_out)), tuple(f"mv{k}" for k in range(n_in)))
    stack = np.array([[c.curve for c in row] for row in curves])
    ramp = np.array([[c.ramp for c in row] for row in curves])
    gains = np.array([[c.steady_state_gain for c in row] for row in curves])
    curve_set = CurveSet(1.0, *names, stack, ramp, gains)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.mdl"
        t_write, _ = best_of(args.repeats, lambda: write_mdl(curve_set, path))
        t_read, read = best_of(args.repeats, lambda: read_mdl(path))
    build = lambda: [  # noqa: E731
        [StepResponse(tuple(read.curves[i, k]), 0, 1.0, ramp=bool(read.ramp[i, k])) for k in range(n_in)]
        for i in range(n_out)
    ]
    t_build, elements = best_of(args.repeats, build)
    t_sample, states = best_of(args.repeats, lambda: _sample(elements))
    t_realize, (A, _, _) = best_of(args.repeats, lambda: realize(elements))
    u = np.random.default_rng(1).standard_normal((4096, n_in))
    t_outputs, _ = best_of(args.repeats, lambda: element_outputs(elements, u))
    print(f"{n_out} x {n_in} model, {n} coefficients per cell, best of {args.repeats}:")
    print(f"  tf -> step-response curves          {t_curves * 1e3:8.1f} ms")
    print(f"  write .mdl                          {t_write * 1e3:8.1f} ms")
    print(f"  read .mdl                           {t_read * 1e3:8.1f} ms")
    print(f"  build step_response elements        {t_build * 1e3:8.1f} ms")
    print(f"  each element: step, 511 freqs, state space, scaled  {t_sample * 1e3:8.1f} ms ({states} states in all)")
    print(f"  realize the model (shared input registers)  {t_realize * 1e3:8.1f} ms ({A.shape[0]} states)")
    print(f"  per-element outputs of 4096 samples         {t_outputs * 1e3:8.1f} ms")
    t_mpc, t_loop = _loop(curves, tfs, 1000)
    print(f"  MPC on the curves built in {t_mpc * 1e3:.1f} ms; 1000 loop samples on the tf plant {t_loop:.2f} s")
    if args.diagnose_samples:
        t_diagnosis, outcome = _diagnosis(curves, tfs, args.diagnose_samples)
        print(f"  parametric PMR of the curve model, {args.diagnose_samples} samples: {t_diagnosis:.1f} s ({outcome})")


if __name__ == "__main__":
    main()
