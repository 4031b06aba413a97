"""The peers' common shape: the classic PMR adapter, a project diagnosis as outcomes, tolerances, evidence."""

from __future__ import annotations

import math

import pytest
from numpy.testing import assert_allclose

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.peers import PeerOutcome, Tolerances, classic_pmr, from_diagnosis
from pmr_ros.peers.outcome import overall_verdict

NAMES = ("G11", "G12", "G21", "G22")


@pytest.fixture(scope="module")
def run():
    config = load_config(overrides={"run": {"samples": 8192, "scenario": "gain"}})
    return config, simulate(config)


def test_classic_pmr_reports_the_classic_diagnosis_per_element(run):
    config, record = run
    out = classic_pmr(record.r, record.u, record.y, model=config.model, settings=config.pmr)
    reference = diagnose(
        record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric, method="classic"
    )
    assert list(out) == list(NAMES)
    for name in NAMES:
        classic = reference.elements[name].classic
        assert out[name].method == "classic"
        assert_allclose(out[name].gain_pct, 100.0 * (classic.gain_ratio - 1.0), rtol=1e-12)
        assert out[name].detected == (reference.elements[name].verdict == "mismatch")
    # the gain scenario's injected dK (+10, +15, -15, -10 %): the classic M(0) reads it within a few points
    assert_allclose([out[n].gain_pct for n in NAMES], config.mismatch.gain_pct.ravel(), atol=4.0)


def test_a_parametric_diagnosis_keeps_its_numbers_and_verdicts(run):
    config, record = run
    diagnosis = diagnose(
        record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric,
        method="parametric",
    )  # fmt: skip
    out = from_diagnosis(diagnosis)
    for name in NAMES:
        part = diagnosis.elements[name].parametric
        assert out[name].verdict == part.verdict
        assert out[name].gain_interval == part.gain_mismatch_pct_interval
        assert out[name].score > 0.0 and out[name].score_kind == "statistic"
    assert_allclose([out[n].gain_pct for n in NAMES], config.mismatch.gain_pct.ravel(), atol=2.0)


def test_tolerances_are_read_from_the_parametric_settings():
    settings = load_config().parametric
    tol = Tolerances.from_settings(settings)
    assert (tol.gain_pct, tol.tau_pct) == (settings.gain_tolerance_pct, settings.tau_tolerance_pct)
    assert (tol.ok_band_factor, tol.confidence_level) == (settings.ok_band_factor, settings.confidence_level)


def test_evidence_orders_p_values_and_statistics_alike():
    p = PeerOutcome("G11", 0, 0, "partial_correlation", True, 1e-4, "p_value", "mismatch")
    s = PeerOutcome("G11", 0, 0, "pem_oe", True, 7.5, "statistic", "mismatch")
    assert_allclose(p.evidence, 4.0, rtol=1e-12)
    assert s.evidence == 7.5
    assert math.isnan(PeerOutcome("G11", 0, 0, "x", False, math.nan, "p_value", "inconclusive").evidence)


def test_overall_verdict_mismatch_beats_inconclusive_beats_ok():
    assert overall_verdict("ok", "inconclusive", "mismatch") == "mismatch"
    assert overall_verdict("ok", None, "inconclusive") == "inconclusive"
    assert overall_verdict("ok", None, "ok") == "ok"
