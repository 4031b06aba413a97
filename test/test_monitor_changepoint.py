"""The GLS machinery of the onset fit, each piece against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import cho_factor, cho_solve, cholesky, cholesky_banded, solve_triangular

from pmr_ros.core.monitor import window_plan, window_views
from pmr_ros.core.monitor.changepoint import (
    _band,
    candidate_shapes,
    fine_shapes_for,
    fit_shapes,
    overlap_correlation,
    ramp_shapes,
    whiten,
    window_means,
    window_shapes,
)
from pmr_ros.core.monitor.nochange import null_quantile


def test_overlap_correlation_is_that_of_window_means_of_white_noise():
    length, stride, samples, runs = 14, 3, 80, 20000
    plan = window_plan(n_samples=samples, window=length, step=stride)
    noise = np.random.default_rng(1).standard_normal((samples, runs))
    means = np.array([view.mean(axis=0) for view in window_views(noise, plan)])
    empirical = np.corrcoef(means)
    ends = np.array([last + 1.0 for _, last in plan])
    np.testing.assert_allclose(overlap_correlation(end_times=ends, window=length), empirical, atol=0.03)


@pytest.mark.parametrize(("onset", "duration"), [(37.3, 0.0), (37.3, 5.5), (10.0, 60.0), (-3.0, 2.0)])
def test_window_means_equal_the_mean_of_the_path_over_each_window(onset, duration):
    window, ends = 14.0, np.arange(20.0, 80.0, 2.5)
    fine = np.linspace(0.0, 1.0, 20001)[1:]
    for index, end in enumerate(ends):
        t = end - window + window * fine
        path = np.clip((t - onset) / duration, 0.0, 1.0) if duration else (t >= onset).astype(float)
        got = window_means(ends=ends, window=window, onset=np.array([onset]), duration=np.array([duration]))
        np.testing.assert_allclose(got[index, 0], path.mean(), atol=2e-4)


def _covariance(ends, errors, window, nugget=0.0):
    return overlap_correlation(end_times=ends, window=window, nugget=nugget) * np.outer(errors, errors)


@pytest.mark.parametrize("nugget", [0.0, 0.02, 0.5])
def test_whiten_equals_the_dense_cholesky_solve(nugget):
    rng = np.random.default_rng(2)
    ends = np.sort(rng.choice(np.arange(200.0), size=120, replace=False))  # irregular: missing windows
    errors = rng.uniform(0.5, 2.0, ends.size)
    columns = rng.standard_normal((ends.size, 7))
    dense = solve_triangular(cholesky(_covariance(ends, errors, 14.0, nugget), lower=True), columns, lower=True)
    np.testing.assert_allclose(whiten(_band(ends, errors, 14.0, nugget), columns), dense, rtol=1e-8, atol=1e-8)


def _row_by_row(band, columns):
    """The forward substitution a row at a time, each row's factor entries gathered as it comes."""
    chol = cholesky_banded(band, lower=True)
    width, n = chol.shape
    out = np.empty(columns.shape)
    for i in range(n):
        lo = max(0, i - width + 1)
        earlier = np.arange(lo, i)
        out[i] = (columns[i] - chol[i - earlier, earlier] @ out[lo:i]) / chol[0, i]
    return out


@pytest.mark.parametrize("spacing", [1.0, 3.0, 20.0])  # 20: windows apart, a diagonal covariance (band of one)
def test_whiten_keeps_the_bits_of_the_row_by_row_substitution(spacing):
    rng = np.random.default_rng(4)
    ends = spacing * np.arange(60.0)
    band = _band(ends, rng.uniform(0.5, 2.0, ends.size), 14.0, 0.02)
    columns = np.column_stack([rng.standard_normal(ends.size), np.ones(ends.size), rng.random((ends.size, 300))])
    whitened = whiten(band, columns)
    assert whitened.view(np.int64).tolist() == _row_by_row(band, columns).view(np.int64).tolist()


def test_fit_shapes_equals_dense_generalized_least_squares():
    rng = np.random.default_rng(3)
    ends = np.arange(1.0, 120.0) + 14
    errors = rng.uniform(0.5, 1.5, ends.size)
    shapes = candidate_shapes(ends=ends, window=14.0, resolution=1.0, durations=4)
    estimates = 2.0 + 5.0 * shapes.matrix[:, 300] + rng.standard_normal(ends.size)
    fit = fit_shapes(estimates=estimates, errors=errors, ends=ends, window=14.0, shapes=shapes, nugget=0.02)
    factor = cho_factor(_covariance(ends, errors, 14.0, 0.02))

    def gls(design):
        beta = np.linalg.solve(design.T @ cho_solve(factor, design), design.T @ cho_solve(factor, estimates))
        residual = estimates - design @ beta
        return beta, residual @ cho_solve(factor, residual)

    (mean,), rss_none = gls(np.ones((ends.size, 1)))
    np.testing.assert_allclose([fit.rss_none, fit.mean], [rss_none, mean], rtol=1e-8)
    for index in (5, 120, 300, 411):
        (level, size), rss = gls(np.column_stack([np.ones(ends.size), shapes.matrix[:, index]]))
        np.testing.assert_allclose(fit.drop[index], rss_none - rss, rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose([fit.level[index], fit.size[index]], [level, size], rtol=1e-7, atol=1e-9)


def test_candidate_and_refined_shapes_cover_steps_and_ramps():
    ends = np.arange(15.0, 100.0)
    coarse = candidate_shapes(ends=ends, window=14.0, resolution=1.0, durations=8)
    steps = coarse.duration == 0
    np.testing.assert_allclose(np.diff(coarse.onset[steps]), 1.0)
    assert coarse.onset[steps][0] > ends[0] - 14 and coarse.onset[steps][-1] < ends[-1]
    assert coarse.duration[~steps].max() >= ends[-1] - ends[0] + 14  # one ramp still rising at the end
    fine = ramp_shapes(ends=ends, window=14.0, onsets=np.array([40.0, 41.0]), resolution=1.0)
    assert set(np.arange(2.0, 41.0)) <= set(fine.duration)
    np.testing.assert_allclose(
        fine.matrix[:, 0],
        window_means(ends=ends, window=14.0, onset=np.array([40.0]), duration=fine.duration[:1])[:, 0],
    )


def test_fine_shapes_of_some_onsets_are_those_of_every_onset():
    ends = np.arange(15.0, 100.0)
    coarse = candidate_shapes(ends=ends, window=14.0, resolution=1.0)
    every_onset = coarse.onset[coarse.duration == 0]
    every = ramp_shapes(ends=ends, window=14.0, onsets=every_onset, resolution=1.0)
    near = np.array([40.0, 41.0, 63.0, 1000.0])  # an onset off the grid is none
    fine = fine_shapes_for(tuple(ends.tolist()), 14.0, 1.0, "mean", near)
    chosen = np.isin(every.onset, near)
    assert set(fine.onset) == {40.0, 41.0, 63.0} and fine.onset.size == np.count_nonzero(chosen)
    np.testing.assert_array_equal(fine.matrix, every.matrix[:, chosen])  # elementwise in the onset: the same bits
    np.testing.assert_array_equal(fine.duration, every.duration[chosen])


def test_null_quantile_is_the_false_alarm_rate_of_the_largest_drop():
    # fresh no-change records, fitted as the onset fit does: the largest drop beats the 10 % quantile one time in ten
    ends = np.arange(15.0, 115.0)
    threshold, maxima = null_quantile(grid=ends, window=14.0, resolution=1.0, significance=0.10, draws=2000)
    assert maxima.size == 2000 and np.all(np.diff(maxima) >= 0)
    shapes = candidate_shapes(ends=ends, window=14.0, resolution=1.0)
    chol = cholesky(overlap_correlation(end_times=ends, window=14.0), lower=True)
    rng = np.random.default_rng(6)
    alarms = 0
    for _ in range(300):
        record = 3.0 + 0.7 * chol @ rng.standard_normal(ends.size)
        fit = fit_shapes(estimates=record, errors=np.full(ends.size, 0.7), ends=ends, window=14.0, shapes=shapes)
        alarms += fit.drop.max() >= threshold
    assert 15 <= alarms <= 47  # binomial(300, 0.10): 30 expected, limits at about +-3 standard deviations


def test_midpoint_shapes_are_the_path_at_each_window_middle():
    ends, onset = np.arange(20.0, 80.0, 2.5), np.array([37.3, 37.3])
    got = window_shapes(ends=ends, window=14.0, onset=onset, duration=np.array([0.0, 5.5]), follow="midpoint")
    middle = ends - 7.0
    np.testing.assert_array_equal(got[:, 0], middle >= 37.3)
    np.testing.assert_allclose(got[:, 1], np.clip((middle - 37.3) / 5.5, 0, 1), rtol=1e-12)
    means = window_shapes(ends=ends, window=14.0, onset=onset, duration=np.array([0.0, 5.5]))
    np.testing.assert_allclose(means, window_means(ends=ends, window=14.0, onset=onset, duration=np.array([0.0, 5.5])))
