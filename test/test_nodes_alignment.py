"""Aligning r, u and y by stamp, and rejecting bad traffic (pmr_ros.contract.alignment, no ROS)."""

from __future__ import annotations

import numpy as np
import pytest

from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.contract.samples import check_signal, sample_index

NAMES = {"r": ("x_D", "x_B"), "u": ("reflux", "steam"), "y": ("x_D", "x_B")}
LABELS = {"r": "r on /pmr/setpoint", "u": "u on /pmr/manipulated_input", "y": "y on /pmr/measured_output"}


def _aligner(capacity: int = 100, lag: int = 5) -> SampleAligner:
    return SampleAligner(1.0, NAMES, LABELS, capacity, lag)


def _feed(al: SampleAligner, k: int, order=("y", "r", "u")):
    results = []
    for s in order:
        results.append(al.add(s, float(k), NAMES[s], [k + 0.1, k + 0.2]))
    return results


def test_sample_index_rounds_and_reports_the_offset():
    assert sample_index(7.0, 1.0) == (7, 0.0)
    k, off = sample_index(7.1, 1.0)
    assert k == 7 and off == pytest.approx(0.1)
    assert sample_index(120.0, 60.0)[0] == 2


def test_check_signal_names_topic_and_value():
    assert check_signal("y on /t", ("a", "b"), [1.0, 2.0], ("a", "b")) is None
    assert check_signal("y on /t", (), [1.0, 2.0], ("a", "b")) is None
    assert "3 values" in check_signal("y on /t", (), [1.0, 2.0, 3.0], ("a", "b"))
    assert "channel names ['b', 'a']" in check_signal("y on /t", ("b", "a"), [1.0, 2.0], ("a", "b"))
    text = check_signal("y on /t", ("a", "b"), [float("nan"), float("inf")], ("a", "b"))
    assert text.startswith("y on /t: non-finite value a=nan, b=inf")


def test_samples_complete_whatever_the_arrival_order():
    al = _aligner()
    _feed(al, 0, ("u", "y", "r"))
    res = _feed(al, 1, ("r", "u", "y"))
    assert res[-1].completed == [1]
    r, u, y, first = al.window(10)
    assert first == 0 and r.shape == (2, 2) and al.stretch_length == 2
    assert np.array_equal(u[1], [1.1, 1.2])


def test_duplicates_and_out_of_order_stamps_are_dropped_with_a_warning():
    al = _aligner()
    for k in range(3):
        _feed(al, k)
    dup = al.add("y", 2.0, NAMES["y"], [9.0, 9.0])
    assert not dup.accepted and "duplicated stamp 2 s" in dup.warnings[0] and "/pmr/measured_output" in dup.warnings[0]
    old = al.add("u", 0.0, NAMES["u"], [9.0, 9.0])
    assert not old.accepted and "out-of-order" in old.warnings[0]
    assert al.window(10)[2][2].tolist() == [2.1, 2.2]  # the first y(2) stands
    assert al.rejected == {"r": 0, "u": 1, "y": 1}


def test_bad_values_and_off_grid_stamps_are_rejected():
    al = _aligner()
    assert not al.add("y", 0.0, NAMES["y"], [np.nan, 1.0]).accepted
    assert not al.add("u", 0.0, NAMES["u"], [1.0]).accepted
    off = al.add("r", 0.4, NAMES["r"], [1.0, 1.0])
    assert not off.accepted and "off the sample grid" in off.warnings[0]
    assert not al.add("r", float("nan"), NAMES["r"], [1.0, 1.0]).accepted
    assert al.stretch_length == 0


def test_a_gap_starts_a_new_stretch_and_the_window_keeps_both():
    al = _aligner()
    for k in range(5):
        _feed(al, k)
    res = _feed(al, 8)
    assert any("samples 5..7 missing" in w for r in res for w in r.warnings)
    assert any(
        "samples 5..7 incomplete (missing r, u, y): a new stretch starts at sample 8 after 5 samples" in w
        for w in res[-1].warnings
    )
    assert al.stretch_first == 8 and al.stretch_length == 1 and al.gaps == 1
    assert [(s.first, s.last) for s in al.stretches(100)] == [(0, 4), (8, 8)] and al.held == 6
    # A rejected y(9) also breaks the stretch: sample 9 never completes.
    al.add("y", 9.0, NAMES["y"], [np.inf, 0.0])
    al.add("r", 9.0, NAMES["r"], [0.0, 0.0])
    al.add("u", 9.0, NAMES["u"], [0.0, 0.0])
    res = _feed(al, 10)
    assert any("samples 9..9 incomplete (missing y)" in w for w in res[-1].warnings)
    assert al.stretch_first == 10 and al.gaps == 2


def test_a_stopped_signal_is_reported_as_lagging():
    al = _aligner(lag=5)
    for k in range(3):
        _feed(al, k)
    assert al.lagging() is None
    for k in range(3, 10):
        al.add("r", float(k), NAMES["r"], [0.0, 0.0])
        al.add("y", float(k), NAMES["y"], [0.0, 0.0])
    assert al.lagging() == "u on /pmr/manipulated_input stopped at sample 2 while the other signals reached sample 9"
    fresh = _aligner(lag=5)
    for k in range(7):
        fresh.add("y", float(k), NAMES["y"], [0.0, 0.0])
    assert fresh.lagging().startswith("no r on /pmr/setpoint received")


def test_window_keeps_the_newest_capacity_samples_and_resizes():
    al = _aligner(capacity=4)
    for k in range(10):
        _feed(al, k)
    r, u, y, first = al.window(100)
    assert first == 6 and y.shape == (4, 2) and al.stretch_length == 10
    al.resize(2)
    assert al.window(100)[3] == 8
    assert al.window(1)[3] == 9


def test_pending_samples_stay_bounded_by_memory_not_by_arrival_order():
    al = _aligner(capacity=100, lag=5)
    warnings = []
    for k in range(1000):
        warnings += al.add("y", float(k), NAMES["y"], [0.0, 0.0]).warnings
    assert al.pending_limit == 100 + 4 * 5 + 16 and len(al._pending) <= al.pending_limit
    assert al.given_up == 1000 - len(al._pending)
    assert "more than 136 partial samples held: samples 0..34 given up (missing r, u)" in warnings[0]


def test_a_late_signal_completes_every_sample_still_pending():
    """A late-discovered publisher's backlog arrives after the other signals moved on: nothing is lost."""
    al = _aligner(capacity=1000, lag=5)
    for k in range(600):  # r and y run ahead by 600 samples, far beyond max_lag_samples
        al.add("r", float(k), NAMES["r"], [k, k])
        al.add("y", float(k), NAMES["y"], [k, -k])
    assert al.lagging().startswith("no u on /pmr/manipulated_input received")
    completed = []
    for k in range(600):  # the transient-local backlog of u
        result = al.add("u", float(k), NAMES["u"], [k, 2 * k])
        completed += result.completed
        assert result.warnings == []
    assert completed == list(range(600)) and al.gaps == 0 and al.given_up == 0
    (stretch,) = al.stretches(1000)
    assert stretch.first == 0 and stretch.samples == 600
    np.testing.assert_array_equal(stretch.u[:, 1], 2 * np.arange(600))
    np.testing.assert_array_equal(stretch.y[:, 1], -np.arange(600))


def test_a_partial_sample_is_given_up_once_a_signal_it_lacks_moved_past_it():
    al = _aligner(capacity=1000, lag=500)
    for k in range(10):
        al.add("r", float(k), NAMES["r"], [0.0, 0.0])
        al.add("y", float(k), NAMES["y"], [0.0, 0.0])
    al.add("u", 5.0, NAMES["u"], [0.0, 0.0])  # u starts at 5: samples 0..4 can never complete
    assert sorted(al._pending) == list(range(6, 10))
    for k in range(6, 10):
        al.add("u", float(k), NAMES["u"], [0.0, 0.0])
    assert [(s.first, s.last) for s in al.stretches(1000)] == [(5, 9)] and not al._pending


def test_stretches_of_the_window_are_the_newest_capacity_samples():
    al = _aligner(capacity=10)
    for k in [*range(0, 6), *range(8, 12), *range(20, 24)]:
        _feed(al, k)
    pieces = al.stretches(100)
    assert [(s.first, s.last) for s in pieces] == [(4, 5), (8, 11), (20, 23)]
    assert sum(s.samples for s in pieces) == al.held == 10
    np.testing.assert_array_equal(pieces[1].y[:, 0], np.arange(8, 12) + 0.1)
    assert [(s.first, s.last) for s in al.stretches(5)] == [(11, 11), (20, 23)]
    assert al.window(100)[3] == 20 and al.window(100)[0].shape == (4, 2)
    assert _aligner().stretches(10) == []
