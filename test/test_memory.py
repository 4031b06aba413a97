"""The memory estimates the commands refuse runs with are upper bounds of what is measured, and not far above."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from pmr_ros.config import config_dir, load_config
from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.memory import (
    DIAGNOSIS_BYTES_PER_CHANNEL,
    available_bytes,
    diagnosis_bytes,
    format_bytes,
    simulation_bytes,
    window_bytes,
)

SAMPLES = 8192


def _peak(run) -> tuple[int, object]:
    """Peak bytes ``tracemalloc`` sees above what was held before ``run()``, and its result."""
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        result = run()
        return tracemalloc.get_traced_memory()[1] - base, result
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("system", ["wood_berry.yaml", "three_by_three.yaml"])
def test_simulation_and_diagnosis_estimates_bound_what_they_allocate(system):
    config = load_config(config_dir() / system)
    simulated, record = _peak(lambda: simulate(config, samples=SAMPLES))
    assert simulated <= simulation_bytes(config.model, SAMPLES) <= 2.5 * simulated
    for method in ("classic", "parametric"):
        diagnosed, diagnosis = _peak(
            lambda m=method: diagnose(
                record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric, method=m
            )
        )
        assert diagnosis.status == "ok"
        assert diagnosed <= diagnosis_bytes(config.model, SAMPLES) <= 2.5 * diagnosed, (method, diagnosed)


def test_the_window_estimate_bounds_what_the_aligner_holds(wood_berry):
    model = wood_berry.model
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}

    def fill():
        aligner = SampleAligner(1.0, names, {s: s for s in "ruy"}, SAMPLES, 64)
        for k in range(SAMPLES):
            for s in "ruy":
                aligner.add(s, float(k), (), np.zeros(2))
        return aligner

    held, aligner = _peak(fill)
    assert aligner.held == SAMPLES
    assert held <= window_bytes(model, SAMPLES) <= 2.5 * held


def test_dither_adds_instruments_and_runs_add_up(wood_berry):
    model = wood_berry.model
    assert (
        diagnosis_bytes(model, 100, dither=True) - diagnosis_bytes(model, 100) == DIAGNOSIS_BYTES_PER_CHANNEL * 2 * 100
    )
    assert simulation_bytes(model, 100, runs=5) == 5 * simulation_bytes(model, 100) == 5 * 16 * 8 * 100


def test_available_memory_and_sizes_for_people():
    have = available_bytes()
    assert have is None or have > 0
    assert format_bytes(1.28e12) == "1.28 TB" and format_bytes(10_485_760) == "10.5 MB" and format_bytes(12) == "12 B"
