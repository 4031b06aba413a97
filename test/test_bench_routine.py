"""The pure helpers of ``benchmarks/bench_routine.py``: the 'decided' rule, the decided fraction, prefix cutting."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from benchmark_scripts import load_benchmark
from numpy.testing import assert_allclose

from pmr_ros.core.records import Record

bench = load_benchmark("bench_routine")


def _element(verdict, gain_pct=0.0):
    return SimpleNamespace(verdict=verdict, parametric=SimpleNamespace(gain_mismatch_pct=gain_pct))


def test_decided_needs_g11_mismatch_within_3_pp_and_no_other_mismatch():
    good = {"G11": _element("mismatch", 12.5), "G12": _element("ok"), "G21": _element("inconclusive")}
    assert bench.decided(good)
    assert not bench.decided({**good, "G11": _element("mismatch", 13.5)})  # 3.5 pp off
    assert not bench.decided({**good, "G11": _element("ok", 10.0)})
    assert not bench.decided({**good, "G12": _element("mismatch", -4.0)})  # a false alarm elsewhere
    assert not bench.decided({"G12": _element("ok")})


def test_decided_fraction_counts_the_elements_not_inconclusive():
    elements = {"G11": _element("mismatch", 10.0), "G12": _element("ok"), "G21": _element("inconclusive")}
    assert_allclose(bench.decided_fraction(elements), 2 / 3, rtol=1e-12)
    assert_allclose(bench.decided_fraction({}), 0.0, atol=0.0)


def test_prefix_cuts_every_per_sample_field_alike():
    n = 10
    record = Record(
        np.arange(n * 2.0).reshape(n, 2),
        np.ones((n, 2)),
        np.zeros((n, 2)),
        dv=np.arange(n * 1.0)[:, None],
        manual=np.zeros((n, 2), bool),
    )
    cut = bench.prefix(record, 4)
    assert cut.samples == 4 and cut.dither is None
    assert_allclose(cut.r, record.r[:4], atol=0.0)
    assert_allclose(cut.dv, record.dv[:4], atol=0.0)
    assert cut.manual.shape == (4, 2)


def test_overrides_inject_g11_only_and_move_what_the_setting_names():
    steps = bench.overrides("wood_berry", "steps", seed=3, samples=100)
    assert steps["mismatch"]["gain_pct"] == [10.0, 0.0, 0.0, 0.0]
    assert not any(steps["mismatch"]["time_constant_pct"]) and not any(steps["mismatch"]["delay_samples"])
    assert not any(steps["excitation"]["mv_dither_amplitude"])
    assert not any(steps["disturbance_signal"]["amplitude"])
    dvs = bench.overrides("wood_berry", "dvs", seed=3, samples=100)
    assert all(dvs["excitation"]["mv_dither_amplitude"]) and all(dvs["disturbance_signal"]["amplitude"])
