"""Message <-> numpy and core conversions (pmr_ros.ros.convert)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402

from pmr_ros.core.pmr import Diagnosis, ElementDiagnosis  # noqa: E402
from pmr_ros.ros import convert  # noqa: E402


def _diagnosis() -> Diagnosis:
    elements = {
        "G11": ElementDiagnosis("G11", 1.0123456789012345, False, 1.5, False, 0, False),
        "G12": ElementDiagnosis("G12", 1.15, True, 20.0, True, 1, True),
        "G21": ElementDiagnosis("G21", 0.85, True, -3.0, False, 0, False),
        "G22": ElementDiagnosis("G22", 0.9, True, -18.0, True, 0, False),
    }
    return Diagnosis(elements, "ok", "", 4096)


def test_stamps_round_trip_to_the_nanosecond():
    for seconds in (0.0, 1.0, 16383.0, 12.5, 1e-9 * 7):
        assert convert.seconds_from_stamp(convert.stamp_from_seconds(seconds)) == pytest.approx(seconds, abs=1e-12)
    stamp = convert.stamp_from_seconds(3.25)
    assert (stamp.sec, stamp.nanosec) == (3, 250_000_000)
    assert convert.seconds_from_stamp(convert.clock_message(42.0).clock) == 42.0


def test_signal_message_is_lossless_and_carries_names_and_stamp():
    values = np.random.default_rng(0).standard_normal(3) * 1e3
    msg = convert.signal_message(values, ("a", "b", "c"), 17.0, "sys")
    stamp, names, back = convert.read_signal(msg)
    assert stamp == 17.0 and names == ("a", "b", "c") and msg.header.frame_id == "sys"
    assert np.array_equal(back, values)


def test_element_level_counts_mismatched_properties():
    d = _diagnosis().elements
    assert convert.element_level(d["G11"]) == DiagnosticStatus.OK
    assert convert.element_level(d["G21"]) == DiagnosticStatus.WARN
    assert convert.element_level(d["G12"]) == DiagnosticStatus.ERROR


def test_verdicts_round_trip_through_diagnostic_array():
    diagnosis = _diagnosis()
    statuses = convert.verdict_statuses(diagnosis, "pmr_diagnostician", "wood_berry", {"window_samples": 4096, "first_sample": 10, "last_sample": 4105})
    assert [s.name for s in statuses] == ["pmr_diagnostician: G11", "pmr_diagnostician: G12", "pmr_diagnostician: G21", "pmr_diagnostician: G22"]
    assert statuses[1].message == "gain +15 %, τ larger (index +20), delay +1 samples"
    msg = convert.diagnostic_array(statuses, 4105.0)
    back, info = convert.diagnosis_from_array(msg, "pmr_diagnostician")
    assert back.status == "ok" and back.samples == 4096
    for name, element in diagnosis.elements.items():
        assert back.elements[name].to_dict() == element.to_dict()
    assert info["levels"] == {"G11": "OK", "G12": "ERROR", "G21": "WARN", "G22": "ERROR"}
    assert info["last_sample"] == 4105 and info["first_sample"] == 10
    assert convert.diagnosis_from_array(msg, "someone_else")[0].elements == {}
    assert convert.status_values(statuses[0])["gain_ratio"] == 1.0123456789012345


def test_no_verdict_statuses_carry_the_reason_and_no_numbers():
    statuses = convert.no_verdict_statuses(["G11", "G12"], DiagnosticStatus.STALE, "u stopped", "diag", "sys", {"window_samples": 0})
    assert all(s.level == DiagnosticStatus.STALE and s.message == "stale: u stopped" for s in statuses)
    values = convert.status_values(statuses[0])
    assert "gain_ratio" not in values and values["reason"] == "u stopped"
    back, info = convert.diagnosis_from_array(convert.diagnostic_array(statuses, 0.0))
    assert back.status == "insufficient_data" and back.reason == "u stopped"
    assert all(e.gain_ratio is None for e in back.elements.values())
    warn = convert.no_verdict_statuses(["G11"], DiagnosticStatus.WARN, "too short", "diag", "sys", {})
    assert warn[0].message == "insufficient data: too short"


def test_estimates_message_round_trip():
    diagnosis = _diagnosis()
    msg = convert.estimates_message(diagnosis, 99.0, "wood_berry")
    assert msg.name[:3] == ["G11/gain_ratio", "G11/tau_index", "G11/delay_mismatch_samples"]
    est = convert.read_estimates(msg)
    assert est["G12"] == {"gain_ratio": 1.15, "tau_index": 20.0, "delay_mismatch_samples": 1.0}
    empty = Diagnosis({"G11": ElementDiagnosis("G11")}, "insufficient_data", "x")
    assert math.isnan(convert.read_estimates(convert.estimates_message(empty, 0.0, ""))["G11"]["gain_ratio"])
