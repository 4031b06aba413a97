"""The diagnostician's window over several unbroken stretches (pmr_ros.contract.windowing, no ROS)."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.contract.windowing import (
    INSUFFICIENT,
    VERDICT,
    evaluate_window,
    useful_data,
    window_info,
    without_verdict,
)
from pmr_ros.core.pmr.diagnosis import shortest_useful_stretch, useful_stretches
from pmr_ros.core.records import Record
from pmr_ros.core.sim.closed_loop import simulate

WINDOW = 16384
GAPS = {"u": range(5400, 5420), "y": range(10900, 10905)}
"""Two gaps: 20 samples of u lost, 5 samples of y rejected (NaN)."""


@cache
def _config(scenario: str):
    config = load_config(overrides={"run": {"scenario": scenario}})
    return replace(config, diagnostician=replace(config.diagnostician, window_samples=WINDOW))


@cache
def _record(scenario: str):
    extra = sum(len(g) for g in GAPS.values())
    return simulate(_config(scenario), samples=WINDOW + extra)


def _aligner(config, capacity: int = WINDOW) -> SampleAligner:
    model = config.model
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    return SampleAligner(model.sample_time, names, {s: s for s in "ruy"}, capacity, 64)


def _feed(aligner: SampleAligner, record, samples: int, gaps: dict[str, range]) -> None:
    for k in range(samples):
        for signal, data in (("r", record.r), ("y", record.y), ("u", record.u)):
            values = data[k]
            if k in gaps.get(signal, ()):
                if signal == "u":
                    continue  # lost
                values = np.full_like(values, np.nan)  # rejected
            aligner.add(signal, float(k), (), values)


def _widths(element) -> np.ndarray:
    p = element.parametric
    return np.array([np.diff(p.gain_mismatch_pct_interval)[0], np.diff(p.tau_mismatch_pct_interval)[0]])


@pytest.mark.parametrize("scenario", ["full", "none"])
def test_a_stream_with_gaps_gives_the_verdicts_of_the_gap_free_stream(scenario):
    """Same clean length in three stretches: same verdicts, intervals within 10 % of the gap-free width."""
    config, record = _config(scenario), _record(scenario)
    clean = _aligner(config)
    _feed(clean, record, WINDOW, {})
    gappy = _aligner(config)
    _feed(gappy, record, record.samples, GAPS)
    assert [(s.first, s.last) for s in gappy.stretches(WINDOW)] == [(0, 5399), (5420, 10899), (10905, 16408)]
    a, b = evaluate_window(clean, config), evaluate_window(gappy, config)
    assert a.kind == b.kind == VERDICT
    assert b.window == {"window_samples": WINDOW, "first_sample": 0, "last_sample": record.samples - 1}
    for name, whole in a.diagnosis.elements.items():
        broken = b.diagnosis.elements[name]
        p, q = whole.parametric, broken.parametric
        assert (q.gain_verdict, q.tau_verdict, q.delay_verdict) == (p.gain_verdict, p.tau_verdict, p.delay_verdict)
        assert broken.verdict == whole.verdict and q.delay_mismatch_samples == p.delay_mismatch_samples
        np.testing.assert_allclose(_widths(broken), _widths(whole), rtol=0.10, err_msg=name)
        # the two estimates are of the same data less a few samples: far closer than their half width
        assert abs(q.gain_mismatch_pct - p.gain_mismatch_pct) < _widths(whole)[0] / 4, name


def test_stretches_too_short_to_add_a_segment_are_left_out_not_an_error():
    config, record = _config("full"), _record("full")
    # a 200-sample stretch between two gaps adds nothing to a Welch segment of 1024 after 176 samples of settling
    aligner = _aligner(config)
    _feed(aligner, record, 12000, {"u": range(9000, 9001), "y": range(9201, 9202)})
    data = useful_data(aligner, config)
    assert data.held_stretches == 3 and [(p.first, p.last) for p in data.pieces] == [(0, 8999), (9202, 11999)]
    assert data.samples == 9000 + 2798 and data.shortest == config.model.settling_samples() + 1024
    outcome = evaluate_window(aligner, config)
    assert outcome.kind == VERDICT and outcome.window["window_samples"] == 11798
    assert outcome.diagnosis.samples == 11798


def test_min_samples_counts_the_samples_of_useful_stretches():
    config, record = _config("full"), _record("full")
    strict = replace(config, diagnostician=replace(config.diagnostician, min_samples=12000))
    aligner = _aligner(config)
    _feed(aligner, record, 12200, {"u": range(9000, 9001), "y": range(9201, 9202)})
    outcome = evaluate_window(aligner, strict)
    assert outcome.kind == INSUFFICIENT
    assert outcome.reason == (
        "11998 unbroken samples, need 12000 (the window holds 12198 samples in 3 stretches; 1 shorter than "
        f"{config.model.settling_samples() + 1024} samples add nothing)"
    )
    # the window the status names is what is held: 0 .. 12199 less the two lost samples
    assert (
        outcome.window
        == window_info(aligner, WINDOW)
        == {
            "window_samples": 12198,
            "first_sample": 0,
            "last_sample": 12199,
        }
    )


def test_one_stretch_too_short_for_a_segment_is_explained_by_the_core():
    config, record = _config("full"), _record("full")
    lenient = replace(config, diagnostician=replace(config.diagnostician, min_samples=100))
    aligner = _aligner(config)
    _feed(aligner, record, 300, {})  # four segments of the least 54 after 176 of settling need 311
    outcome = evaluate_window(aligner, lenient)
    assert outcome.kind == INSUFFICIENT and outcome.reason.startswith("window too short: 300 samples")


def test_useful_stretches_follow_the_method_segment(wood_berry):
    config = wood_berry
    settle = config.model.settling_samples()
    pieces = [Record(*(np.zeros((n, 2)) for _ in range(3))) for n in (settle + 511, settle + 512, 9000)]
    classic = useful_stretches(
        pieces, model=config.model, pmr=config.pmr, parametric=config.parametric, method="classic"
    )
    assert [p.samples for p in classic] == [settle + 512, 9000]
    shortest = shortest_useful_stretch(pieces, model=config.model, pmr=config.pmr, parametric=config.parametric)
    assert shortest == settle + config.parametric.welch(config.model, 9000, config.pmr).segment_length == settle + 1024
    parametric = useful_stretches(pieces, model=config.model, pmr=config.pmr, parametric=config.parametric)
    assert [p.samples for p in parametric] == [9000]


def test_a_window_too_large_for_memory_is_refused_naming_the_parameter(monkeypatch, wood_berry):
    import pmr_ros.contract.windowing as windowing
    from pmr_ros.config import ConfigError

    huge = replace(wood_berry, diagnostician=replace(wood_berry.diagnostician, window_samples=2_000_000_000))
    monkeypatch.setattr(windowing, "available_bytes", lambda: 24_000_000_000)
    with pytest.raises(ConfigError) as err:
        windowing.check_window_memory(huge, "parameters of node /pmr_diagnostician")
    assert str(err.value) == (
        "parameters of node /pmr_diagnostician: diagnostician.window_samples = 2000000000: a full window needs about "
        "2.06 TB of memory (samples 1.5 TB, diagnosis 560 GB); 24 GB available"
    )
    windowing.check_window_memory(wood_berry, "x")  # 16384 samples: 21 MB


def test_after_a_model_switch_only_the_samples_from_it_count():
    from pmr_ros.contract.windowing import window_stretches

    config = _config("full")
    record = _record("full")
    aligner = _aligner(config)
    _feed(aligner, record, 12000, GAPS)
    pieces = window_stretches(aligner, WINDOW, since=6000)
    assert pieces[0].first == 6000 and all(p.first >= 6000 for p in pieces)
    full = {p.first: p for p in aligner.stretches(WINDOW)}
    np.testing.assert_array_equal(pieces[0].y, full[5420].y[6000 - 5420 :])  # the rows of those samples
    assert window_stretches(aligner, WINDOW, since=20000) == []
    outcome = evaluate_window(aligner, config, since=6000)
    assert outcome.kind == INSUFFICIENT and "since the model switch at sample 6000" in outcome.reason
    assert window_info(aligner, WINDOW, since=6000)["first_sample"] == 6000


def test_a_window_without_a_verdict_names_its_window_and_newest_sample():
    config, record = _config("full"), _record("full")
    aligner = _aligner(config)
    _feed(aligner, record, 9000, {})
    outcome = without_verdict("failed", "diagnosis failed: ValueError: x", aligner, config, since=3000)
    assert outcome.kind == "failed" and outcome.reason == "diagnosis failed: ValueError: x"
    assert outcome.window == {"window_samples": 6000, "first_sample": 3000, "last_sample": 8999}
    assert outcome.stamp_s == 8999 * config.model.sample_time
    assert outcome.diagnosis.samples == 6000 and outcome.diagnosis.reason == outcome.reason
    assert {e.verdict for e in outcome.diagnosis.elements.values()} == {"inconclusive"}
    empty = without_verdict("stale", "no y", _aligner(config), config)
    assert empty.window == {"window_samples": 0} and empty.stamp_s == 0.0 and empty.diagnosis.samples == 0
