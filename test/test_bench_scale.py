"""The helpers of ``benchmarks/bench_scale.py``: errors against the injected mismatch, the record cache, the lines."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from benchmark_scripts import load_benchmark
from numpy.testing import assert_allclose

bench = load_benchmark("bench_scale")


def _config(gain, tau, delay):
    full = SimpleNamespace(gain_pct=np.array(gain), time_constant_pct=np.array(tau), delay_samples=np.array(delay))
    return SimpleNamespace(mismatch=SimpleNamespace(for_scenario=lambda name: full))


def _element(row, column, verdict, gain=None, tau=None, delay=0, kind="foptd"):
    parametric = SimpleNamespace(gain_mismatch_pct=gain, tau_mismatch_pct=tau, delay_mismatch_samples=delay)
    model = SimpleNamespace(kind=kind)
    return SimpleNamespace(row=row, column=column, verdict=verdict, model=model, parametric=parametric)


def test_estimate_errors_count_decided_elements_and_measure_against_the_injected_mismatch():
    config = _config([[10.0, 0.0], [-12.0, 0.0]], [[0.0, 0.0], [12.0, 0.0]], [[1, 0], [0, 0]])
    diagnosis = [
        _element(0, 0, "mismatch", gain=11.0, tau=0.5, delay=1),  # errors 1.0 pp, 0.5 pp, delay right
        _element(1, 0, "ok", gain=-12.5, tau=10.0, delay=1),  # errors 0.5 pp, 2.0 pp, delay wrong
        _element(0, 1, "inconclusive", gain=3.0, tau=None, delay=0),  # error 3.0 pp, no tau
        _element(1, 1, "ok", kind="none"),  # an empty cell: not counted
    ]
    errors = bench.estimate_errors(config, diagnosis)
    assert errors["decided"] == 2
    assert_allclose(errors["gain_pp"], (1.0, 3.0), rtol=1e-12)
    assert_allclose(errors["tau_pp"], (1.25, 2.0), rtol=1e-12)
    assert_allclose(errors["delay_exact"], 2 / 3, rtol=1e-12)
    assert bench.within_specification(config, diagnosis) == (2, 1)  # 3.0 pp is within, the wrong delay is not


def test_the_closed_loop_record_is_kept_and_read_back_with_its_times(tmp_path):
    config = bench.load(bench.industrial_system(2, 2, seed=1), tmp_path)
    record, wall, cpu = bench.closed_loop(config, 400, tmp_path)
    assert wall > 0 and cpu > 0 and record.y.shape == (400, 2)
    again, wall_again, cpu_again = bench.closed_loop(config, 400, tmp_path)  # from the cache now
    np.testing.assert_array_equal(again.y, record.y)
    np.testing.assert_array_equal(again.u, record.u)
    assert (wall_again, cpu_again) == (wall, cpu) and again.dither is None


def test_details_print_times_memory_decided_and_errors():
    errors = {"decided": 5, "gain_pp": (0.14, 1.5), "tau_pp": (0.18, 2.1), "delay_exact": 1.0}
    row = bench.Row("4x4", 8, 100.0, 1.0, 2.0, 5, 3, 12.0, 3.5, 250.0, errors)
    line = bench.details(row)
    for text in ("closed loop 12 s", "parametric 3.5 s", "250 MB", "decided 5/8", "dK 0.14/1.5 pp", "dD exact 100 %"):
        assert text in line, text
