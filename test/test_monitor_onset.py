"""Onset of a change in window estimates: when, step or drift, its interval; and the lasting mismatch.

The records are built the way the monitor sees them: a year of the parameter's
true path at daily resolution, 14-day windows stepped by one day, each
window's estimate the mean of the path over the window plus the mean of white
noise over the same window (so neighbouring windows' errors correlate through
their shared days, as real overlapping windows do).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import norm

from pmr_ros.core.monitor import (
    OnsetSettings,
    detect_onset,
    first_lasting_mismatch,
    standard_errors,
    window_plan,
    window_views,
)

DAYS, WINDOW = 365, 14
PLAN = window_plan(n_samples=DAYS, window=WINDOW, step=1)
ENDS = np.array([last + 1.0 for _, last in PLAN])
"""The instant each window ends [days]: the end of its last day."""

RAMP_DAY, STEP_DAY = 150, 240
GAIN_ERROR, DELAY_ERROR = 0.5, 0.2
"""Standard errors of a 14-day window's dK [%] and dD [samples].

The README's baseline spread of dK is 0.26-0.38 % at 16,384 one-minute samples;
a 14-day window holds 20,160 of them.
"""


def ramp_path(onset: float, rise: float, size: float) -> np.ndarray:
    """Daily means of a path rising linearly by ``size`` from ``onset`` over ``rise`` days, then flat."""

    def integral(t):
        x = np.maximum(t - onset, 0.0)
        return np.where(x < rise, x * x / (2 * rise), x - rise / 2)

    days = np.arange(DAYS, dtype=float)
    return size * (integral(days + 1) - integral(days))


def step_path(day: int, size: float) -> np.ndarray:
    return size * (np.arange(DAYS) >= day)


def window_estimates(path: np.ndarray, *, error: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Each window's mean of the path plus the mean of daily white noise (window standard error ``error``)."""
    daily = np.random.default_rng(seed).standard_normal(DAYS) * error * np.sqrt(WINDOW)
    estimates = np.array([view.mean() for view in window_views(path + daily, PLAN)])
    return estimates, np.full(estimates.size, error)


def _onset(estimates, errors, **kwargs):
    return detect_onset(estimates=estimates, errors=errors, end_times=ENDS, window=WINDOW, **kwargs)


GAIN_RAMP = ramp_path(RAMP_DAY, 14, 20.0)
DELAY_STEP = step_path(STEP_DAY, 2.0)


@pytest.mark.parametrize("seed", range(8))
def test_a_gain_ramp_is_a_drift_from_its_first_day(seed):
    found = _onset(*window_estimates(GAIN_RAMP, error=GAIN_ERROR, seed=seed))
    print(f"ramp seed {seed}: onset error {found.time - RAMP_DAY:+.0f} d, interval {found.interval}")
    assert found.kind == "drift"
    np.testing.assert_allclose(found.time, RAMP_DAY, atol=3)
    np.testing.assert_allclose(found.end, RAMP_DAY + 14, atol=4)
    np.testing.assert_allclose([found.size, found.level], [20.0, 0.0], atol=1.5)
    np.testing.assert_allclose(found.rate, 20.0 / 14, rtol=0.3)


@pytest.mark.parametrize("seed", range(8))
def test_a_delay_step_is_a_step_on_its_day(seed):
    found = _onset(*window_estimates(DELAY_STEP, error=DELAY_ERROR, seed=100 + seed))
    print(f"step seed {seed}: onset error {found.time - STEP_DAY:+.0f} d, interval {found.interval}")
    assert found.kind == "step"
    assert found.end is None and found.rate is None
    np.testing.assert_allclose(found.time, STEP_DAY, atol=3)
    np.testing.assert_allclose([found.size, found.level], [2.0, 0.0], atol=0.25)


def test_no_change_is_none_in_at_least_95_of_100_records():
    # the level and the error scale do not matter: a mismatch that is constant all year is no onset
    alarms = []
    for seed in range(100):
        found = _onset(*window_estimates(np.full(DAYS, 7.0), error=1.0, seed=1000 + seed))
        assert found.kind in ("none", "step", "drift")
        if found.kind == "none":
            np.testing.assert_allclose(found.level, 7.0, atol=1.0)
            assert found.time is None and found.interval is None
            assert found.statistic < found.threshold
        else:
            alarms.append(seed)
    print(f"false alarms: {len(alarms)} of 100 (significance 0.01)")
    assert len(alarms) <= 5


def test_intervals_too_narrow_are_seen_and_scaling_the_errors_keeps_the_false_alarm_rate():
    # the windows scatter twice as much as their intervals say: half the true standard error is given
    plain, scaled = [], []
    for seed in range(20):
        estimates, errors = window_estimates(np.zeros(DAYS), error=1.0, seed=4000 + seed)
        # no nugget: the noise here is purely overlap-correlated, and the error scale is then exact
        plain.append(_onset(estimates, errors / 2, settings=OnsetSettings(nugget=0.0)))
        scaled.append(_onset(estimates, errors / 2, settings=OnsetSettings(scale_errors=True, nugget=0.0)))
    np.testing.assert_allclose(np.median([found.error_scale for found in plain]), 2.0, rtol=0.1)
    alarms = [sum(found.kind != "none" for found in run) for run in (plain, scaled)]
    print(f"false alarms with intervals half as wide as the scatter: {alarms[0]} of 20, scaled {alarms[1]} of 20")
    assert alarms[0] >= 10 and alarms[1] <= 2
    # stated right, the scale is about one and a ramp is still found with scaling on
    estimates, errors = window_estimates(GAIN_RAMP, error=GAIN_ERROR, seed=5)
    found = _onset(estimates, errors, settings=OnsetSettings(scale_errors=True, nugget=0.0))
    np.testing.assert_allclose(found.error_scale, 1.0, atol=0.15)
    assert found.kind == "drift"
    np.testing.assert_allclose(found.time, RAMP_DAY, atol=3)


def test_no_change_with_windows_left_out_keeps_its_false_alarm_rate():
    # the threshold is simulated on the windows kept: a third left out changes the law of the largest ratio
    left_out = np.random.default_rng(11).random(ENDS.size) < 0.3
    alarms = 0
    for seed in range(60):
        estimates, errors = window_estimates(np.zeros(DAYS), error=1.0, seed=3000 + seed)
        estimates[left_out] = np.nan
        alarms += _onset(estimates, errors, settings=OnsetSettings(significance=0.05)).kind != "none"
    print(f"false alarms with 30 % of the windows left out: {alarms} of 60 (significance 0.05)")
    assert alarms <= 8  # 3 expected


@pytest.mark.parametrize(
    ("path", "truth", "error"), [(GAIN_RAMP, RAMP_DAY, GAIN_ERROR), (DELAY_STEP, STEP_DAY, DELAY_ERROR)]
)
def test_the_onset_interval_covers_the_truth_in_most_records(path, truth, error):
    covered, errors = 0, []
    for seed in range(40):
        found = _onset(*window_estimates(path, error=error, seed=2000 + seed))
        low, high = found.interval
        assert low <= found.time <= high
        covered += low <= truth <= high
        errors.append(found.time - truth)
    print(f"onset {truth}: coverage {covered}/40, errors {np.percentile(errors, [0, 50, 100])}")
    assert covered >= 32  # 95 % intervals: 38 expected


def test_inconclusive_windows_are_left_out():
    estimates, errors = window_estimates(GAIN_RAMP, error=GAIN_ERROR, seed=7)
    rng = np.random.default_rng(8)
    estimates[rng.random(estimates.size) < 0.3] = np.nan  # a third of the windows inconclusive
    estimates[RAMP_DAY + 20 : RAMP_DAY + 40] = np.nan  # and three weeks after the ramp
    errors[::17] = np.nan  # some with an estimate but no interval
    found = _onset(estimates, errors)
    assert found.windows == np.sum(np.isfinite(estimates) & np.isfinite(errors))
    assert found.kind == "drift"
    np.testing.assert_allclose(found.time, RAMP_DAY, atol=3)


def test_unequal_errors_and_clock_seconds():
    # errors that vary window to window, noise drawn with exactly that covariance; times in seconds
    from pmr_ros.core.monitor.changepoint import overlap_correlation

    errors = DELAY_ERROR * (1 + 0.5 * np.sin(np.arange(ENDS.size) / 9.0))
    covariance = overlap_correlation(end_times=ENDS, window=WINDOW) * np.outer(errors, errors)
    noise = np.linalg.cholesky(covariance) @ np.random.default_rng(9).standard_normal(ENDS.size)
    estimates = np.array([view.mean() for view in window_views(DELAY_STEP, PLAN)]) + noise
    found = detect_onset(estimates=estimates, errors=errors, end_times=86400 * ENDS, window=86400 * WINDOW)
    assert found.kind == "step"
    np.testing.assert_allclose(found.time / 86400, STEP_DAY, atol=3)
    json.dumps(found.to_dict())


def test_a_drift_still_rising_reports_how_far_it_has_come_and_its_rate():
    # fouling: +1 % a day from day 300 to the end of the year, no plateau yet (in 2 of 20 seeds the noise of
    # the last windows makes a plateau in their last days fit better at 95 %: then ``end`` is given)
    path = ramp_path(300, 1000, 1000.0)
    found = _onset(*window_estimates(path, error=GAIN_ERROR, seed=0))
    assert isinstance(found.size, float) and isinstance(found.rate, float)
    assert found.kind == "drift" and found.end is None
    np.testing.assert_allclose(found.time, 300, atol=3)
    np.testing.assert_allclose(found.rate, 1.0, rtol=0.15)
    np.testing.assert_allclose(found.size, ENDS[-1] - 300, rtol=0.15)  # 65 days at 1 % a day


def test_an_estimate_that_jumps_half_a_window_late_follows_the_midpoint():
    # an estimate that takes the value of most of the window jumps when the window's middle passes the change,
    # with now and then a window one sample off (an integer delay does not: it is the window's mean rounded)
    middle = ENDS - WINDOW / 2
    estimates = np.where(middle >= STEP_DAY, 2.0, 0.0)
    off = np.random.default_rng(13).random(ENDS.size) < 0.03
    estimates[off] += 1.0
    errors = np.full(ENDS.size, 0.3)
    midpoint = _onset(estimates, errors, settings=OnsetSettings(follow="midpoint", scale_errors=True))
    assert midpoint.kind == "step"
    np.testing.assert_allclose(midpoint.time, STEP_DAY, atol=3)
    # read as window means, the same estimates put the change days late
    mean = _onset(estimates, errors, settings=OnsetSettings(follow="mean", scale_errors=True))
    assert mean.error_scale > midpoint.error_scale
    with pytest.raises(ValueError, match="follow: 'median' is not one of"):
        _onset(estimates, errors, settings=OnsetSettings(follow="median"))
    with pytest.raises(ValueError, match=r"nugget: 1.0 must be in \[0, 1\)"):
        _onset(estimates, errors, settings=OnsetSettings(nugget=1.0))
    with pytest.raises(ValueError, match="resolution: 0.0 must be positive"):
        _onset(estimates, errors, settings=OnsetSettings(resolution=0.0))


def test_too_few_windows_are_insufficient():
    estimates, errors = window_estimates(DELAY_STEP, error=DELAY_ERROR, seed=3)
    estimates[5:] = np.nan
    found = _onset(estimates, errors)
    assert (found.kind, found.windows, found.time) == ("insufficient", 5, None)
    assert _onset(np.full(ENDS.size, np.nan), errors).kind == "insufficient"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"estimates": np.zeros(5), "errors": np.ones(4), "end_times": np.arange(5.0)}, "shapes"),
        ({"estimates": np.zeros(3), "errors": np.ones(3), "end_times": [0.0, 2.0, 1.0]}, "end_times"),
        ({"estimates": np.zeros(3), "errors": np.ones(3), "end_times": [0.0, 1.0, 2.0], "window": 0.0}, "window: 0.0"),
    ],
)
def test_bad_input_is_one_clear_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        detect_onset(**{"window": 14.0, **kwargs})


def test_standard_errors_from_95_percent_intervals():
    center, scale = np.array([1.0, -3.0, 20.0]), np.array([0.5, 2.0, 0.1])
    low, high = norm.interval(0.95, loc=center, scale=scale)
    np.testing.assert_allclose(standard_errors(low=low, high=high), scale, rtol=1e-12)
    low, high = norm.interval(0.9, loc=center, scale=scale)
    np.testing.assert_allclose(standard_errors(low=low, high=high, level=0.9), scale, rtol=1e-12)
    assert np.isnan(standard_errors(low=[np.nan], high=[1.0])[0])


@pytest.mark.parametrize(
    ("verdicts", "first"),
    [
        (["ok", "mismatch", "ok", "mismatch", "inconclusive", "mismatch"], 3),
        (["mismatch", "mismatch"], 0),
        (["mismatch", "ok"], None),
        (["mismatch", "mismatch", "inconclusive"], 0),
        (["ok", "inconclusive", "mismatch"], 2),
        ([], None),
        (["inconclusive"], None),
    ],
)
def test_first_window_from_which_the_verdict_stays_mismatch(verdicts, first):
    assert first_lasting_mismatch(verdicts) == first


def test_lasting_mismatch_with_inconclusive_windows_breaking_the_run():
    verdicts = ["mismatch", "inconclusive", "mismatch"]
    assert first_lasting_mismatch(verdicts, ignore=()) == 2
