"""The rolling-window plan: windows end at the last sample, step back by S, are views of one record."""

from __future__ import annotations

import numpy as np
import pytest

from pmr_ros.core.monitor import parse_span, window_plan, window_views

MINUTE, DAY = 60.0, 86400.0


def _check_regular(plan, *, n_samples, length, stride):
    firsts, lasts = np.array(plan).T
    assert lasts[-1] == n_samples - 1
    assert firsts[0] >= 0 and firsts[0] < stride  # no room for one more window before the first
    np.testing.assert_array_equal(lasts - firsts + 1, length)
    np.testing.assert_array_equal(np.diff(lasts), stride)
    assert len(plan) == (n_samples - length) // stride + 1


@pytest.mark.parametrize(("n_samples", "length", "stride"), [(10, 4, 3), (100, 100, 1), (1000, 140, 10), (50, 7, 20)])
def test_sample_windows_end_at_the_last_sample_and_step_back(n_samples, length, stride):
    plan = window_plan(n_samples=n_samples, window=length, step=stride)
    _check_regular(plan, n_samples=n_samples, length=length, stride=stride)
    assert window_plan(n_samples=n_samples, window=str(length), step=str(stride)) == plan


def test_sample_windows_of_a_small_record():
    # by hand: ends 9, 6, 3; four samples each
    assert window_plan(n_samples=10, window=4, step=3) == [(0, 3), (3, 6), (6, 9)]


def test_clock_windows_of_minute_data_hold_fourteen_days_and_step_one_day():
    n_samples = 30 * 1440
    times = 1.7e9 + MINUTE * np.arange(n_samples)
    plan = window_plan(n_samples=n_samples, window="14d", step="1d", times=times)
    _check_regular(plan, n_samples=n_samples, length=14 * 1440, stride=1440)
    firsts, lasts = np.array(plan).T
    np.testing.assert_allclose(times[lasts] - times[firsts], 14 * DAY - MINUTE, rtol=0, atol=1e-6)
    # the same plan in other units, and from date-times
    assert window_plan(n_samples=n_samples, window="336h", step="1440min", times=times) == plan
    stamps = np.datetime64("2026-01-01T00:00") + np.arange(n_samples) * np.timedelta64(1, "m")
    assert window_plan(n_samples=n_samples, window="14d", step="24h", times=stamps) == plan


def test_a_window_as_long_as_the_clock_record_is_the_whole_record():
    times = 10.0 * np.arange(360)
    assert window_plan(n_samples=360, window="1h", step="1h", times=times) == [(0, 359)]


def test_clock_windows_across_a_gap_hold_fewer_samples_and_empty_ones_are_left_out():
    # ten days of hourly samples with days 3 and 4 missing
    hours = np.arange(10 * 24)
    kept = hours[(hours < 72) | (hours >= 120)]
    plan = window_plan(n_samples=kept.size, window="1d", step="1d", times=3600.0 * kept)
    counts = [last - first + 1 for first, last in plan]
    assert len(plan) == 8  # ten one-day windows, the two wholly inside the gap left out
    assert counts == [24] * 8
    ends = 3600.0 * kept[[last for _, last in plan]]
    assert np.all(np.diff(ends) >= DAY)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_samples": 100, "window": 101, "step": 1}, r"window: 101 samples is longer than the data \(100 samples\)"),
        ({"n_samples": 100, "window": 10, "step": 0}, r"step: 0 must be positive"),
        ({"n_samples": 100, "window": 10, "step": -5}, r"step: -5 must be positive"),
        ({"n_samples": 100, "window": 0, "step": 1}, r"window: 0 must be positive"),
        ({"n_samples": 100, "window": "14d", "step": 1}, r"window: '14d' has a clock unit but the data have no clock"),
        ({"n_samples": 100, "window": 10, "step": "1h"}, r"step: '1h' has a clock unit but the data have no clock"),
        ({"n_samples": 100, "window": "14 fortnights", "step": 1}, r"window: '14 fortnights' is not a length"),
        ({"n_samples": 100, "window": 10.5, "step": 1}, r"window: 10.5 samples is not a whole number"),
        ({"n_samples": 100, "window": "2h", "step": 5, "times": 60.0 * np.arange(100)}, r"step: '5' and window '2h'"),
        (
            {"n_samples": 100, "window": "2h", "step": "1h", "times": 60.0 * np.arange(100)},
            r"window: 2h is longer than the data \(1.667 h\)",
        ),
        ({"n_samples": 100, "window": "1h", "step": "1h", "times": np.arange(99.0)}, r"times: 99 stamps for 100"),
        ({"n_samples": 3, "window": "1s", "step": "1s", "times": [0.0, 2.0, 1.0]}, r"times: .*non-decreasing"),
    ],
)
def test_bad_window_options_give_one_line_naming_the_option_and_value(kwargs, message):
    with pytest.raises(ValueError, match=message) as caught:
        window_plan(**kwargs)
    assert "\n" not in str(caught.value)


def test_spans_in_samples_and_clock_units():
    assert parse_span(20160, option="window").value == 20160
    assert not parse_span("20160", option="window").seconds
    for text, seconds in (("14d", 14 * DAY), ("1.5h", 5400.0), ("90min", 5400.0), ("30s", 30.0), ("2e1 min", 1200.0)):
        span = parse_span(text, option="window")
        assert span.seconds
        np.testing.assert_allclose(span.value, seconds, rtol=1e-12)


def test_window_views_share_the_record_memory_and_hold_its_samples():
    rng = np.random.default_rng(0)
    record = rng.standard_normal((5000, 3))
    plan = window_plan(n_samples=5000, window=700, step=250)
    views = list(window_views(record, plan))
    assert len(views) == len(plan)
    for (first, last), view in zip(plan, views, strict=True):
        assert np.shares_memory(view, record)
        assert view.base is record
        np.testing.assert_array_equal(view, record[first : last + 1])
    # samples along the second axis (channels first)
    wide = np.ascontiguousarray(record.T)
    for (first, last), view in zip(plan, window_views(wide, plan, axis=1), strict=True):
        assert np.shares_memory(view, wide)
        assert view.shape == (3, last - first + 1)
