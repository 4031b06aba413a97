"""Core results <-> the contract's messages (pmr_ros.ros.convert, pmr_ros.contract.layout)."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402

from pmr_ros.contract.failed_window import failure_reason
from pmr_ros.contract.layout import (
    FAILED,
    decode_value,
    diagnosis_from_array,
    encode_value,
    read_estimates,
    read_signal,
    status_values,
)  # noqa: E402
from pmr_ros.core.results import (
    ClassicResult,
    Diagnosis,
    ElementDiagnosis,
    ElementModel,
    ParametricResult,
    compare_diagnoses,
)  # noqa: E402
from pmr_ros.ros import convert  # noqa: E402

MODEL = ElementModel("foptd", 12.8, 16.7, 1)
WINDOW = {"window_samples": 4096, "first_sample": 10, "last_sample": 4105}
SUMMARY_NAME = "pmr/wood_berry/summary"


def _classic(gain_ratio, gain, tau_index, tau, delay) -> ClassicResult:
    return ClassicResult(gain_ratio, tau_index, delay, gain, tau, delay != 0)


def _diagnosis() -> Diagnosis:
    parts = {
        "G11": _classic(1.0123456789012345, False, 1.5, False, 0),
        "G12": _classic(1.15, True, 20.0, True, 1),
        "G21": _classic(0.85, True, -3.0, False, 0),
        "G22": _classic(0.9, True, -18.0, True, 0),
    }
    elements = {
        name: ElementDiagnosis(name, j // 2, j % 2, MODEL, "classic", classic=part)
        for j, (name, part) in enumerate(parts.items())
    }
    return Diagnosis("classic", "ok", "", 4096, elements)


def _parametric() -> Diagnosis:
    p = ParametricResult(
        gain_mismatch_pct=15.3,
        gain_mismatch_pct_interval=(14.8, 15.9),
        tau_mismatch_pct=-0.2,
        tau_mismatch_pct_interval=(-0.8, 0.4),
        delay_mismatch_samples=2,
        delay_confidence=0.999,
        gain_verdict="mismatch",
        tau_verdict="ok",
        delay_verdict="mismatch",
        reasons=("a | reason",),
        warnings=("row 1 mixes time constants",),
        quality={"coherence": 0.9, "segment_length": 1024},
    )
    element = ElementDiagnosis(
        "G21", 1, 0, MODEL, "parametric", classic=_classic(1.16, True, 21.0, True, 2), parametric=p
    )
    return Diagnosis("parametric", "ok", "", 4096, {"G21": element})


def test_stamps_round_trip_to_the_nanosecond():
    for seconds in (0.0, 1.0, 16383.0, 12.5, 1e-9 * 7):
        assert convert.stamp_from_seconds(seconds).sec + convert.stamp_from_seconds(
            seconds
        ).nanosec * 1e-9 == pytest.approx(seconds, abs=1e-12)
    stamp = convert.stamp_from_seconds(3.25)
    assert (stamp.sec, stamp.nanosec) == (3, 250_000_000)


def test_signal_message_is_lossless_and_carries_names_and_stamp():
    values = np.random.default_rng(0).standard_normal(3) * 1e3
    msg = convert.signal_message(values, ("a", "b", "c"), 17.0, "sys")
    stamp, names, back = read_signal(msg)
    assert stamp == 17.0 and names == ("a", "b", "c") and msg.header.frame_id == "sys"
    assert np.array_equal(back, values)


def test_element_level_counts_mismatched_properties():
    d = _diagnosis().elements
    assert convert.element_level(d["G11"]) == DiagnosticStatus.OK
    assert convert.element_level(d["G21"]) == DiagnosticStatus.WARN
    assert convert.element_level(d["G12"]) == DiagnosticStatus.ERROR
    assert convert.element_level(_parametric().elements["G21"]) == DiagnosticStatus.ERROR  # gain and delay


@pytest.mark.parametrize("make", [_diagnosis, _parametric], ids=["classic", "parametric"])
def test_verdicts_round_trip_exactly_through_diagnostic_array(make):
    diagnosis = make()
    statuses = convert.diagnosis_statuses(diagnosis, prefix="pmr/wood_berry", hardware_id="wood_berry", window=WINDOW)
    assert [s.name for s in statuses] == [*(f"pmr/wood_berry/{name}" for name in diagnosis.elements), SUMMARY_NAME]
    msg = convert.diagnostic_array(statuses, 4105.0)
    back, info = diagnosis_from_array(msg, prefix="pmr/wood_berry")
    assert back.status == "ok" and back.samples == 4096 and back.method == diagnosis.method
    assert back == diagnosis  # every field, every float to the last bit (lossless KeyValues)
    assert info["last_sample"] == 4105 and info["first_sample"] == 10 and info["status"] == "ok"
    assert set(info["levels"]) == set(diagnosis.elements)  # the summary is no element
    assert diagnosis_from_array(msg, prefix="pmr/column_a/wood_berry")[0].elements == {}


def test_summary_status_has_the_worst_level_and_the_verdict_counts():
    diagnosis = _diagnosis()
    statuses = convert.diagnosis_statuses(diagnosis, prefix="pmr/wood_berry", hardware_id="wood_berry", window=WINDOW)
    summary = statuses[-1]
    assert summary.name == SUMMARY_NAME and summary.hardware_id == "wood_berry"
    assert summary.level == max(s.level for s in statuses[:-1]) == DiagnosticStatus.ERROR  # G12: two properties off
    counts = Counter(e.verdict for e in diagnosis)
    assert summary.message.startswith(
        f"{counts['mismatch']} mismatch, {counts['inconclusive']} inconclusive, {counts['ok']} ok of 4 modeled"
    )
    assert status_values(summary) == {"status": "ok", "elements": 4}


def test_statuses_of_the_older_spelling_are_still_read():
    """Bags recorded before the path-like names hold ``<node>: <element>`` statuses: read, filtered by node."""
    diagnosis = _diagnosis()
    statuses = convert.diagnosis_statuses(diagnosis, prefix="pmr/wood_berry", hardware_id="wood_berry", window=WINDOW)
    for status in statuses[:-1]:
        status.name = f"pmr_diagnostician: {status.name.rsplit('/', 1)[1]}"
    msg = convert.diagnostic_array(statuses[:-1], 4105.0)
    assert diagnosis_from_array(msg, "pmr_diagnostician")[0] == diagnosis
    assert diagnosis_from_array(msg)[0] == diagnosis
    assert diagnosis_from_array(msg, "someone_else")[0].elements == {}


def test_status_message_and_values_are_readable():
    statuses = convert.diagnosis_statuses(_diagnosis(), prefix="pmr/s", hardware_id="s", window=WINDOW)
    assert statuses[1].message == "gain +15 %, τ larger (index +20), delay +1 samples"
    values = status_values(statuses[0])
    assert (
        values["classic.gain_ratio"] == 1.0123456789012345
        and values["verdict"] == "ok"
        and values["model.kind"] == "foptd"
    )
    parametric = status_values(
        convert.diagnosis_statuses(_parametric(), prefix="pmr/s", hardware_id="s", window=WINDOW)[0]
    )
    bounds = (parametric["parametric.gain_mismatch_pct_low"], parametric["parametric.gain_mismatch_pct_high"])
    assert bounds == (14.8, 15.9) and "parametric.gain_mismatch_pct_interval" not in parametric
    assert parametric["parametric.reasons"] == ["a | reason"]


def test_no_verdict_statuses_carry_the_reason_and_no_numbers():
    models = {"G11": (0, 0, MODEL), "G12": (0, 1, MODEL)}
    empty = Diagnosis.insufficient(method="parametric", models=models, reason="u stopped", samples=0)
    statuses = convert.diagnosis_statuses(
        empty, prefix="pmr/sys", hardware_id="sys", window={"window_samples": 0}, state="stale"
    )
    assert all(s.level == DiagnosticStatus.STALE and s.message == "stale: u stopped" for s in statuses)
    values = status_values(statuses[0])
    assert values["classic"] is None and values["parametric"] is None and values["reason"] == "u stopped"
    back, info = diagnosis_from_array(convert.diagnostic_array(statuses, 0.0))
    assert back.status == "insufficient_data" and back.reason == "u stopped" and info["status"] == "stale"
    assert all(e.result is None and e.verdict == "inconclusive" for e in back.elements.values())
    short = Diagnosis.insufficient(method="classic", models=models, reason="too short", samples=10)
    warn = convert.diagnosis_statuses(short, prefix="pmr/sys", hardware_id="sys", window={})
    assert warn[0].level == DiagnosticStatus.WARN and warn[0].message == "insufficient data: too short"


def test_a_failed_diagnosis_is_an_error_naming_the_exception_in_one_line():
    reason = failure_reason(ValueError("f(a) and f(b)\n  must have different signs"))
    assert reason == "ValueError: f(a) and f(b) must have different signs"
    assert failure_reason(KeyError()) == "KeyError"  # no message: the type alone
    models = {"G11": (0, 0, MODEL), "G12": (0, 1, MODEL)}
    empty = Diagnosis.insufficient(method="parametric", models=models, reason=reason, samples=0)
    statuses = convert.diagnosis_statuses(empty, prefix="pmr/sys", hardware_id="sys", window={}, state=FAILED)
    assert {(s.level, s.message) for s in statuses} == {(DiagnosticStatus.ERROR, f"diagnosis failed: {reason}")}
    back, info = diagnosis_from_array(convert.diagnostic_array(statuses, 0.0))
    assert info["status"] == "failed" and back.status == "insufficient_data" and back.reason == reason


def test_estimates_message_round_trip():
    msg = convert.estimates_message(_diagnosis(), 99.0, "wood_berry")
    assert msg.name[:3] == ["G11/classic.gain_ratio", "G11/classic.tau_index", "G11/classic.delay_mismatch_samples"]
    est = read_estimates(msg)
    assert est["G12"] == {"classic.gain_ratio": 1.15, "classic.tau_index": 20.0, "classic.delay_mismatch_samples": 1.0}
    parametric = read_estimates(convert.estimates_message(_parametric(), 99.0, ""))["G21"]
    assert parametric["parametric.gain_mismatch_pct_low"] == 14.8 and parametric["parametric.delay_confidence"] == 0.999
    empty = ElementDiagnosis("G11", 0, 0, MODEL, "parametric", parametric=ParametricResult(reasons=("no fit",)))
    values = read_estimates(convert.estimates_message(Diagnosis("parametric", "ok", "", 1, {"G11": empty}), 0.0, ""))[
        "G11"
    ]
    assert set(values) == set(parametric) and all(
        math.isnan(v) for v in values.values()
    )  # same names, NaN where no number


def test_key_value_encoding_is_lossless_and_keeps_strings():
    for value in (0.1 + 0.2, 1e-300, -3, True, None, [1.5, 2.0], "mismatch", "a | b"):
        assert decode_value(encode_value(value)) == value
    assert math.isnan(decode_value(encode_value(math.nan)))


def test_compare_diagnoses_is_exact_for_verdicts_and_tolerant_for_floats():
    a = _parametric()
    p = a.elements["G21"].parametric
    close = ParametricResult(**{**p.__dict__, "gain_mismatch_pct": p.gain_mismatch_pct * (1 + 1e-12)})
    b = Diagnosis(
        "parametric",
        "ok",
        "",
        4096,
        {
            "G21": ElementDiagnosis(
                "G21", 1, 0, MODEL, "parametric", classic=a.elements["G21"].classic, parametric=close
            )
        },
    )
    assert compare_diagnoses(a, b) == []
    far = ParametricResult(**{**p.__dict__, "gain_mismatch_pct": p.gain_mismatch_pct * (1 + 1e-4)})
    c = Diagnosis(
        "parametric",
        "ok",
        "",
        4096,
        {"G21": ElementDiagnosis("G21", 1, 0, MODEL, "parametric", classic=a.elements["G21"].classic, parametric=far)},
    )
    assert [d.split(":")[0] for d in compare_diagnoses(a, c)] == ["elements.G21.parametric.gain_mismatch_pct"]
    other = ParametricResult(**{**p.__dict__, "tau_verdict": "mismatch"})
    d = Diagnosis(
        "parametric",
        "ok",
        "",
        4096,
        {
            "G21": ElementDiagnosis(
                "G21", 1, 0, MODEL, "parametric", classic=a.elements["G21"].classic, parametric=other
            )
        },
    )
    assert [line.split(":")[0] for line in compare_diagnoses(a, d)] == [
        "elements.G21.parametric.tau_verdict"
    ]  # the verdict stays mismatch
