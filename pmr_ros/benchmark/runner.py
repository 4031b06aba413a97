"""One benchmark run: simulated on the lockstep batch core, diagnosed by every method, as flat result rows.

Each method sees only what a user has: ``r, u, y`` (and the MV dither, which
the parametric PMR takes as a known excitation) and the controller's model;
its CPU time is the process time of its call.  A method that fails on a run
(an exception) leaves every element of that run inconclusive with the reason,
so one unstable loop does not stop the benchmark.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..config import PmrConfig
from ..core.pmr.diagnosis import diagnose
from ..core.records import Record
from ..core.sim.batch import run_lockstep
from ..peers import PeerOutcome, Tolerances, classic_pmr, from_diagnosis, partial_correlation_test, pem_diagnosis
from .scenarios import truth_arrays
from .units import run_config

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["METHODS", "RunTask", "diagnose_all", "method_rows", "run_one", "simulate_run"]

Method = Callable[[Record, PmrConfig], dict[str, PeerOutcome]]


def _parametric(record: Record, config: PmrConfig) -> dict[str, PeerOutcome]:
    d = diagnose(
        record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric,
        method="parametric", dither=record.dither,
    )  # fmt: skip
    return from_diagnosis(d)


def _pem(noise_model: str) -> Method:
    def fit(record: Record, config: PmrConfig) -> dict[str, PeerOutcome]:
        return pem_diagnosis(
            record.u, record.y, model=config.model, noise_model=noise_model,
            tolerances=Tolerances.from_settings(config.parametric),
            max_delay_shift=int(config.pmr.max_delay_samples),
        )  # fmt: skip

    return fit


METHODS: dict[str, Method] = {
    "parametric": _parametric,
    "classic": lambda rec, cfg: classic_pmr(rec.r, rec.u, rec.y, model=cfg.model, settings=cfg.pmr),
    "partial_correlation": lambda rec, cfg: partial_correlation_test(rec.u, rec.y, model=cfg.model),
    "pem_oe": _pem("output_error"),
    "pem_bj": _pem("box_jenkins"),
}
"""Method name -> ``f(record, config) -> {element: PeerOutcome}``; ours (``parametric``) first."""


@dataclass(frozen=True)
class RunTask:
    """One labelled run to do: its line of the run table and its elements' truth lines."""

    run: int
    unit: str
    samples: int
    disturbance: bool
    seed: int
    truth: pd.DataFrame
    methods: tuple[str, ...]
    record: Record | None = None
    """The simulated record, where a cluster worker sends it back with the task."""


def simulate_run(task: RunTask) -> tuple[PmrConfig, Record]:
    """The run's configuration (its mismatch, its disturbance) and its closed-loop record."""
    config = run_config(task.unit, disturbance=task.disturbance, **truth_arrays(task.unit, task.truth))
    record = run_lockstep(config, [("full", task.seed)], task.samples).records[0]
    return config, record


def _interval(value: tuple[float, float] | None) -> tuple[float, float]:
    return (math.nan, math.nan) if value is None else (float(value[0]), float(value[1]))


def _number(value: float | None) -> float:
    return math.nan if value is None else float(value)


def method_rows(run: int, method: str, outcomes: dict[str, PeerOutcome], cpu_s: float) -> list[dict]:
    """One result row per element: the outcome's fields flat (NaN where the method says nothing)."""
    rows = []
    for o in outcomes.values():
        gain_lo, gain_hi = _interval(o.gain_interval)
        tau_lo, tau_hi = _interval(o.tau_interval)
        rows.append(
            {
                "run": run, "method": method, "element": o.element,
                "detected": bool(o.detected), "verdict": o.verdict, "evidence": float(o.evidence),
                "gain_pct": _number(o.gain_pct), "gain_lo": gain_lo, "gain_hi": gain_hi,
                "tau_pct": _number(o.tau_pct), "tau_lo": tau_lo, "tau_hi": tau_hi,
                "delay_samples": _number(o.delay_samples), "cpu_s": cpu_s,
                "reasons": "; ".join(o.reasons),
            }
        )  # fmt: skip
    return rows


def _failed(truth: pd.DataFrame, method: str, why: str) -> dict[str, PeerOutcome]:
    return {
        name: PeerOutcome(name, int(i), int(k), method, False, math.nan, "statistic", "inconclusive", reasons=(why,))
        for name, i, k in zip(truth["element"], truth["row"], truth["column"], strict=True)
    }


def diagnose_all(task: RunTask, config: PmrConfig, record: Record) -> list[dict]:
    """Every method of ``task.methods`` on ``record``: the result rows of :func:`method_rows`."""
    rows = []
    finite = bool(np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.u)))
    for method in task.methods:
        start = time.process_time()
        try:
            if not finite:
                raise FloatingPointError("the closed loop diverged (non-finite u or y)")
            outcomes = METHODS[method](record, config)
        except Exception as exc:  # a benchmark scores a failure as inconclusive, it does not stop
            outcomes = _failed(task.truth, method, f"failed: {type(exc).__name__}: {exc}")
        rows += method_rows(task.run, method, outcomes, time.process_time() - start)
    return rows


def run_one(task: RunTask) -> tuple[RunTask, list[dict], Record]:
    """Simulate and diagnose one run: the task, its result rows and its record (for the export)."""
    config, record = simulate_run(task)
    return task, diagnose_all(task, config, record), record
