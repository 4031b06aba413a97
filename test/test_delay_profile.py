"""The delay profile repeats its passes over a row until no delay moves (profile.PROFILE_PASSES).

Benchmark run 575 (the debutanizer 4x8, 8,192 samples, white noise) is the case that showed it: after one
pass over the integrating drum-level row, three of its four delays were a sample off, each with delay
confidence 1 -- two clean elements called mismatched -- and the row's chi-square 416 units above the
true delays'.
"""

from __future__ import annotations

import pytest
from numpy.testing import assert_allclose

from pmr_ros.benchmark.runner import RunTask, simulate_run
from pmr_ros.benchmark.scenarios import read_scenarios, run_table
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.pmr.parametric import profile


@pytest.fixture(scope="module")
def run_575():
    scenarios = read_scenarios()
    line = run_table(scenarios).set_index("run").loc[575]
    truth = scenarios[scenarios["run"] == 575].reset_index(drop=True)
    task = RunTask(575, line["unit"], int(line["samples"]), bool(line["disturbance"]), int(line["seed"]), truth, ())
    config, record = simulate_run(task)
    return config, record, truth.set_index("element")


def _diagnosis(config, record):
    return diagnose(
        record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric,
        method="parametric", dither=record.dither,
    )  # fmt: skip


def test_every_delay_of_run_575_is_found_and_no_clean_element_is_called_mismatched(run_575):
    config, record, truth = run_575
    found = _diagnosis(config, record)
    for name, element in found.elements.items():
        p = element.parametric
        if p is None or p.delay_mismatch_samples is None:
            continue
        assert p.delay_mismatch_samples == truth.loc[name, "delay_samples"], name
        clean = (truth.loc[name, ["gain_pct", "tau_pct", "delay_samples"]] == 0).all()
        if clean:
            assert element.verdict != "mismatch", name
        assert_allclose(p.gain_mismatch_pct, truth.loc[name, "gain_pct"], atol=2.0, err_msg=name)  # [pp]


def test_one_pass_of_the_profile_leaves_the_integrating_row_a_sample_off(run_575, monkeypatch):
    """The same run with a single pass: the defect the passes mend (so the test above can fail)."""
    config, record, truth = run_575
    monkeypatch.setattr(profile, "PROFILE_PASSES", 1)
    found = _diagnosis(config, record)
    wrong = [
        name for name, e in found.elements.items()
        if e.row == 2 and e.parametric is not None and e.parametric.delay_mismatch_samples is not None
        and e.parametric.delay_mismatch_samples != truth.loc[name, "delay_samples"]
    ]  # fmt: skip
    assert wrong  # measured here: G31, G32 and G33
