"""The parts of the diagnosis on industrial shapes, each against a closed form or an independent computation."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from hard_cases import SKOGESTAD_LV
from scipy.signal import csd, freqz

from pmr_ros.config import load_config
from pmr_ros.core.pmr.classic import gain_bin
from pmr_ros.core.pmr.delay import hamon_hannan_delay, search_limit_reason
from pmr_ros.core.pmr.implicit import Conditioning, implicit_row, instrument_factor, row_layout, whitened_row
from pmr_ros.core.pmr.parametric import ParametricSettings
from pmr_ros.core.pmr.parametric.fit import RowData, RowFit, column_models, interaction_delay_range, leakage_offset
from pmr_ros.core.pmr.parametric.guard import fitted_bins
from pmr_ros.core.pmr.parametric.interaction import interaction_result, interaction_verdict
from pmr_ros.core.pmr.parametric.lsq import RowParameters, RowProblem
from pmr_ros.core.pmr.parametric.parameterization import search_candidates
from pmr_ros.core.pmr.parametric.ratio import ColumnModel, RowSystem, column_moments, noise_spectrum, ratio_shape
from pmr_ros.core.pmr.parametric.search import (
    column_grids,
    column_search,
    conditional_target,
    move_delay,
    sweep_columns,
)
from pmr_ros.core.pmr.parametric.verdicts import element_result, trust_reasons
from pmr_ros.core.pmr.regressors import row_regressors
from pmr_ros.core.pmr.spectra import RowSpectra, WelchSettings, record_spectra
from pmr_ros.core.records import Record
from pmr_ros.core.results import ClassicResult, Diagnosis, ElementDiagnosis, ElementModel, ParametricResult
from pmr_ros.core.results.codec import diagnosis_from_json, diagnosis_to_json
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.report.table import format_classic_table, format_parametric_table

MIXED = TransferMatrix(
    gain=[[2.0, 0.0, 1.0], [0.05, 0.0, 0.8]],
    time_constant=[[10.0, 0.0, 12.0], [0.0, 0.0, 9.0]],
    delay=[[2.0, 0.0, 1.0], [1.0, 0.0, 3.0]],
    sample_time=1.0,
    element_type=[["foptd", "none", "foptd"], ["integrating", "none", "foptd"]],
)
"""Row 1 ordinary with an empty cell; row 2 a level (integrating in u1) with an empty cell."""


def _settings() -> ParametricSettings:
    """The declared defaults (config/parameters.yaml), the one source of them."""
    return load_config().parametric


# -- regressors and spectra ---------------------------------------------------------------------


def test_row_regressors_are_the_model_outputs_and_the_references_of_empty_cells():
    u = np.random.default_rng(0).standard_normal((400, 3))
    outputs = MIXED.element_outputs(u)
    first = row_regressors(MIXED, u, 0)
    np.testing.assert_allclose(first[:, [0, 2]], outputs[:, 0, [0, 2]], atol=1e-12)
    np.testing.assert_array_equal(first[1:, 1], u[:-1, 1])  # empty cell: u(t-1)
    level = row_regressors(MIXED, u, 1)
    np.testing.assert_allclose(level[:, [0, 2]], outputs[:, 1, [0, 2]], atol=1e-12)
    # in an integrating row the reference integrates: its difference is Ts u(t-1)
    np.testing.assert_allclose(np.diff(level[:, 1])[1:], u[1:-1, 1] * MIXED.sample_time, atol=1e-12)


def test_row_spectra_are_welch_cross_spectra_of_the_differenced_row():
    rng = np.random.default_rng(1)
    n = 6000
    r, u, y = rng.standard_normal((n, 2)), rng.standard_normal((n, 3)), np.cumsum(rng.standard_normal((n, 2)), axis=0)
    welch = WelchSettings("hann", 256, 0.5)
    spectra = record_spectra([Record(r, u, y)], MIXED, welch)
    assert spectra.differenced.tolist() == [False, True] and spectra.n_instruments == 2
    warmup = MIXED.settling_samples()
    level = spectra.row(1)
    assert level.differenced
    x = np.diff(row_regressors(MIXED, u, 1), axis=0, prepend=np.nan)[warmup:]
    dy = np.diff(y[:, 1], prepend=np.nan)[warmup:]
    z = r[warmup:]

    def scipy_csd(a, b):
        return csd(a - a.mean(), b - b.mean(), nperseg=256, noverlap=128, window="hann", detrend=False)[1]

    np.testing.assert_allclose(level.zy[:, 0], scipy_csd(z[:, 0], dy), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(level.zx[:, 1, 2], scipy_csd(z[:, 1], x[:, 2]), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(level.xx[:, 0, 1], scipy_csd(x[:, 0], x[:, 1]), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(spectra.rr[:, 0, 1], scipy_csd(z[:, 0], z[:, 1]), rtol=1e-9, atol=1e-12)


# -- the implicit regression -----------------------------------------------------------------------


def test_row_layout_takes_what_the_instruments_can_carry():
    dithered = np.array([False, True, False])
    full = row_layout(MIXED, 0, n_instruments=3, dithered=dithered)
    assert full.columns.tolist() == [0, 1, 2] and not full.reasons and not full.untested
    modeled = row_layout(MIXED, 0, n_instruments=2, dithered=dithered)
    assert modeled.columns.tolist() == [0, 2]
    assert modeled.untested.startswith("not tested: row y1 has 2 instruments for 3 inputs")
    assert "at least 1 of u1, u3" in modeled.untested  # u2 is dithered already
    none = row_layout(MIXED, 0, n_instruments=1, dithered=dithered)
    assert none.columns.size == 0 and none.reasons[0].startswith("row y1 not identifiable: 2 modeled inputs but 1")
    classic = row_layout(MIXED, 0, n_instruments=3, dithered=dithered, test_empty=False)
    assert classic.columns.tolist() == [0, 2]


def test_implicit_row_solves_the_overdetermined_equations_exactly():
    rng = np.random.default_rng(2)
    F, n_z, n = 9, 4, 3
    zx = rng.standard_normal((F, n_z, n)) + 1j * rng.standard_normal((F, n_z, n))
    theta = rng.standard_normal((F, n)) + 1j * rng.standard_normal((F, n))
    zy = np.einsum("fzk,fk->fz", zx, theta)
    a = rng.standard_normal((F, n_z, n_z)) + 1j * rng.standard_normal((F, n_z, n_z))
    rr = a @ np.conj(np.transpose(a, (0, 2, 1))) + np.eye(n_z)
    factor = instrument_factor(rr)
    np.testing.assert_allclose(factor @ np.conj(np.transpose(factor, (0, 2, 1))), rr, rtol=1e-9)
    row = RowSpectra(zy, zx, np.full(F, 1e3), np.zeros((F, n)), np.zeros((F, n, n)), False)
    estimate = implicit_row(row, rr, factor, np.arange(n))
    np.testing.assert_allclose(estimate.ratio, theta, rtol=1e-9, atol=1e-9)
    assert np.all(estimate.condition >= 1.0) and np.all(np.isfinite(estimate.condition))
    assert estimate.power.shape == (F, n) and np.all(estimate.power > 0)


def _random_row(F: int, n_z: int, n: int, seed: int) -> tuple[RowSpectra, np.ndarray]:
    rng = np.random.default_rng(seed)
    zx = rng.standard_normal((F, n_z, n)) + 1j * rng.standard_normal((F, n_z, n))
    zy = rng.standard_normal((F, n_z)) + 1j * rng.standard_normal((F, n_z))
    a = rng.standard_normal((F, n_z, n_z)) + 1j * rng.standard_normal((F, n_z, n_z))
    rr = a @ np.conj(np.transpose(a, (0, 2, 1))) + np.eye(n_z)
    return RowSpectra(zy, zx, np.full(F, 1e3), np.zeros((F, n)), np.zeros((F, n, n)), False), rr


def test_whitened_row_solves_output_and_regressors_with_the_factor():
    row, rr = _random_row(7, 5, 3, seed=4)
    factor = instrument_factor(rr)
    whitened = whitened_row(row, factor)
    assert whitened.shape == (7, 5, 4)
    np.testing.assert_allclose(factor @ whitened[:, :, :1], row.zy[:, :, None], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(factor @ whitened[:, :, 1:], row.zx, rtol=1e-10, atol=1e-12)
    # given or not, the same estimate (a layout's columns read their part of it)
    columns = np.array([0, 2])
    given = implicit_row(row, rr, factor, columns, whitened=whitened)
    np.testing.assert_allclose(given.ratio, implicit_row(row, rr, factor, columns).ratio, rtol=1e-12)


def test_conditioning_at_some_bins_is_the_condition_number_of_those_bins():
    row, rr = _random_row(11, 4, 3, seed=5)
    columns = np.array([0, 2])
    lazy = Conditioning(row.zx[:, :, columns], rr)
    bins = np.array([3, 7, 3])
    some = lazy.at(bins)
    assert np.count_nonzero(lazy._known) == 2  # only the bins asked were computed
    # independently: the singular values of the design scaled to unit instrument and regressor power
    scale = np.sqrt(np.einsum("fll->fl", rr).real)
    for value, f in zip(some, bins, strict=True):
        design = row.zx[f][:, columns] / scale[f][:, None]
        design = design / np.linalg.norm(design, axis=0)
        sv = np.linalg.svd(design, compute_uv=False)
        np.testing.assert_allclose(value, sv[0] / sv[-1], rtol=1e-8)
    np.testing.assert_array_equal(lazy.at()[bins], some)
    estimate = implicit_row(row, rr, instrument_factor(rr), columns)
    np.testing.assert_array_equal(estimate.condition_at(bins), estimate.condition[bins])
    empty = implicit_row(row, rr, instrument_factor(rr), np.array([], dtype=int))
    assert np.all(np.isinf(empty.condition)) and np.all(np.isinf(empty.condition_at(bins)))


def test_gain_bin_and_search_limit():
    assert gain_bin(False) == 0 and gain_bin(True) == 1
    assert search_limit_reason(3, low=-10, high=10) is None
    assert "search limit (+10 samples of -10 .. +10)" in search_limit_reason(10, low=-10, high=10)
    assert search_limit_reason(-10, low=-10, high=10) is not None
    assert search_limit_reason(-2, low=-2, high=10, low_is_limit=False) is None  # a plant delay cannot be negative
    omega = np.linspace(0, np.pi, 129)
    delay, cost = hamon_hannan_delay(omega, np.exp(-3j * omega), np.full(129, 0.9), 8, lowest=0)
    assert delay == 3 and cost.size == 9


# -- the parametric row problem ------------------------------------------------------------------


def _ratio_column() -> ColumnModel:
    return ColumnModel("ratio", math.exp(-1 / 10.0), 10.0, (-3.0, 3.0), (-2, 6), True)


def _lag_column() -> ColumnModel:
    return ColumnModel("lag", 0.0, 10.0, (math.log(0.05 / 10.0), 3.0), (0, 12), False)


def test_shapes_are_the_ratio_of_sampled_elements_and_their_derivative_is_right():
    omega = np.linspace(0, np.pi, 64)
    z_inv = np.exp(-1j * omega)
    ratio, lag = _ratio_column(), _lag_column()
    s = np.array([0.3])
    shape, derivative = ratio.shapes(z_inv, s)
    np.testing.assert_allclose(shape[0], ratio_shape(z_inv, ratio.pole_model, ratio.pole(0.3), 0), rtol=1e-12)
    # a lag is the ratio with no model pole: the unit-gain first-order element behind the ZOH's sample
    a = lag.pole(0.3)
    np.testing.assert_allclose(lag.shapes(z_inv, s)[0][0], (1 - a) / (1 - a * z_inv), rtol=1e-12)
    step = 1e-6
    numeric = (ratio.shapes(z_inv, s + step)[0] - ratio.shapes(z_inv, s - step)[0]) / (2 * step)
    np.testing.assert_allclose(derivative, numeric, rtol=1e-6, atol=1e-9)
    flat, zero = ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-1, 1), True).shapes(z_inv, s)
    assert np.all(flat == 1.0) and np.all(zero == 0.0)


def test_shape_and_a_given_numerator_give_the_shapes_own_numbers():
    # the column search refines s with shape(numerator=...): it must find what shapes() would, to the bit
    z_inv = np.exp(-1j * np.linspace(0, np.pi, 64))
    s = np.array([-0.4, 0.3])
    delay = ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-1, 1), True)
    for column in (_ratio_column(), _lag_column(), delay):
        shape, derivative = column.shapes(z_inv, s)
        given = column.shapes(z_inv, s, numerator=column.numerator(z_inv))
        assert np.array_equal(column.shape(z_inv, s), shape)
        assert np.array_equal(column.shape(z_inv, s, numerator=column.numerator(z_inv)), shape)
        assert np.array_equal(given[0], shape) and np.array_equal(given[1], derivative)
    ratio = _ratio_column()
    ah = ratio.pole_model
    np.testing.assert_allclose(ratio.numerator(z_inv), (1 - ah * z_inv) / (1 - ah), rtol=1e-15)


def _system(columns, params, *, seed=3, F=80, n_z=4, noise=0.0):
    """A row's equations in information form from a random design and known parameters."""
    rng = np.random.default_rng(seed)
    omega = np.linspace(0.0, 0.9, F)
    n = len(columns)
    A = rng.standard_normal((F, n_z, n)) + 1j * rng.standard_normal((F, n_z, n))
    A[0] = A[0].real  # the zero bin is real
    z_inv = np.exp(-1j * omega)
    system = RowSystem(np.zeros((F, n, n), complex), np.zeros((F, n), complex), np.zeros(F), z_inv, 2 * F * n_z)
    theta = RowProblem(system, columns).coefficients(params).theta
    b = np.einsum("fzk,fk->fz", A, theta) + noise * (rng.standard_normal((F, n_z)) + 1j * rng.standard_normal((F, n_z)))
    AH = np.conj(np.transpose(A, (0, 2, 1)))
    return RowSystem(AH @ A, (AH @ b[:, :, None])[:, :, 0], np.sum(np.abs(b) ** 2, axis=1), z_inv, 2 * b.size), A, b


def test_row_system_cost_is_the_squared_residual_and_the_free_estimate_its_least_squares():
    columns = [_ratio_column(), _lag_column()]
    truth = RowParameters(np.array([1.1, 0.4]), np.array([0.2, -0.5]), np.array([1, 3]))
    system, A, b = _system(columns, truth, noise=0.1)
    theta = np.random.default_rng(4).standard_normal((A.shape[0], 2)) + 0j
    direct = np.sum(np.abs(b - np.einsum("fzk,fk->fz", A, theta)) ** 2)
    assert system.cost(theta) == pytest.approx(direct, rel=1e-10)
    cost, product = system.cost_and_product(theta)
    assert cost == pytest.approx(direct, rel=1e-10)
    np.testing.assert_allclose(product, (system.M @ theta[:, :, None])[:, :, 0], rtol=1e-12, atol=1e-12)
    free, variance = system.free_estimate()
    for f in (0, 40):
        np.testing.assert_allclose(free[f], np.linalg.lstsq(A[f], b[f], rcond=None)[0], rtol=1e-8)
    assert np.all(variance > 0)


def test_the_search_and_the_joint_fit_recover_the_parameters_exactly_without_noise():
    columns = [_ratio_column(), ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-3, 3), True), _ratio_column()]
    truth = RowParameters(np.array([1.15, 0.9, 0.8]), np.array([0.25, 0.0, -0.4]), np.array([2, -1, 0]))
    system, _, _ = _system(columns, truth)
    start = sweep_columns(system, column_grids(columns, system.z_inv))
    assert start.delays.tolist() == truth.delays.tolist()
    params, cost = RowProblem(system, columns).fit(start)
    assert cost < 1e-10 * system.beta.sum()
    np.testing.assert_allclose(params.lin, truth.lin, atol=1e-6)
    np.testing.assert_allclose(params.s, truth.s, atol=1e-6)


def test_a_problem_on_another_system_of_its_bins_is_a_new_problems_to_the_bit():
    columns = [_ratio_column(), ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-3, 3), True), _lag_column()]
    truth = RowParameters(np.array([1.15, 0.9, 0.4]), np.array([0.25, 0.0, -0.4]), np.array([2, -1, 3]))
    first, _, _ = _system(columns, truth, noise=0.05)
    second, _, _ = _system(columns, truth, seed=8, noise=0.05)
    shared, new = RowProblem(first, columns).with_system(second), RowProblem(second, columns)
    assert shared.system is second
    start = truth.with_delay(0, 1)
    (got, got_cost), (want, want_cost) = shared.fit(start), new.fit(start)
    assert got_cost == want_cost and np.array_equal(got.lin, want.lin) and np.array_equal(got.s, want.s)
    assert np.array_equal(shared.information(shared.coefficients(truth)), new.information(new.coefficients(truth)))
    other = RowSystem(second.M[:40], second.v[:40], second.beta[:40], second.z_inv[:40], second.components)
    assert np.array_equal(RowProblem(first, columns).with_system(other)._turns, RowProblem(other, columns)._turns)


def test_a_fit_settled_above_a_cost_stops_after_one_step_and_a_neighbour_settled_so_is_kept():
    from pmr_ros.core.pmr.parametric.trials import Trials

    columns = [_ratio_column(), ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-3, 3), True), _ratio_column()]
    truth = RowParameters(np.array([1.15, 0.9, 0.8]), np.array([0.25, 0.0, -0.4]), np.array([2, -1, 0]))
    system, _, _ = _system(columns, truth, noise=0.05)
    problem = RowProblem(system, columns)
    far = truth.with_delay(0, 0)  # two samples off: far worse than the truth
    one, three = problem.fit(far, iterations=1), problem.fit(far, iterations=3)
    assert one[1] > three[1]  # the further steps would lower it
    settled = problem.fit(far, iterations=3, settled_above=0.5 * one[1])
    assert settled[1] == one[1]
    np.testing.assert_array_equal(settled[0].lin, one[0].lin)
    unsettled = problem.fit(far, iterations=3, settled_above=2.0 * one[1])  # below the bound after one step
    assert unsettled[1] == three[1]
    trials = Trials(problem, column_grids(columns, system.z_inv))
    best = trials.full(truth)
    kept = trials.moved(best, [(0, 0)], settled_above=best[1] + 1.0)
    assert kept[1] > best[1] + 1.0 and trials.tried[(0, -1, 0)] is kept
    assert trials.moved(best, [(0, 0)]) is kept  # tried once: the same fit, whatever the bound


def test_an_interaction_template_is_placed_by_the_search():
    """The lag's time constant stays where the search put it (grid, interpolated): its gain within 1 %."""
    columns = [_ratio_column(), _lag_column()]
    truth = RowParameters(np.array([1.1, 0.6]), np.array([0.1, -0.7]), np.array([1, 4]))
    system, _, _ = _system(columns, truth)
    params, _ = RowProblem(system, columns).fit(sweep_columns(system, column_grids(columns, system.z_inv)))
    assert params.delays.tolist() == [1, 4]
    assert params.lin[1] == pytest.approx(0.6, rel=0.01) and params.lin[0] == pytest.approx(1.1, rel=0.01)


def test_an_interaction_within_its_chance_level_is_absent_and_one_beyond_it_is_not():
    from pmr_ros.core.pmr.parametric.profile import absent, uncertainty

    columns = [_ratio_column(), _lag_column()]
    z = [math.inf, 3.0]
    for gain, expected in ((0.0, True), (0.6, False)):
        truth = RowParameters(np.array([1.1, gain]), np.array([0.1, -0.7]), np.array([1, 4]))
        system, _, _ = _system(columns, truth, noise=0.02)
        problem = RowProblem(system, columns)
        params, _ = problem.fit(truth)
        sd_lin, _ = uncertainty(problem, params, 1.0)
        assert 0 < sd_lin[1] < 0.1  # well determined: the absence is the gain's, not the noise's
        assert absent(problem, params, z=z, inflation=1.0).tolist() == [False, expected]
    # an inflation that widens the deviations past the gain makes even a present interaction absent
    assert absent(problem, params, z=z, inflation=(params.lin[1] / (3.0 * sd_lin[1])) ** 2 * 1.01).tolist() == [
        False,
        True,
    ]
    # noise-free, the modelled column's deviation is 0 beside its infinite z: no 0 x inf (a NaN and a warning)
    system, _, _ = _system(columns, truth, noise=0.0)
    problem = RowProblem(system, columns)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert absent(problem, truth, z=z, inflation=0.0).tolist() == [False, False]


def test_column_search_and_move_delay():
    columns = [_ratio_column(), _lag_column()]
    truth = RowParameters(np.array([0.9, 0.5]), np.array([-0.3, 0.0]), np.array([0, 5]))
    system, _, _ = _system(columns, truth)
    grids = column_grids(columns, system.z_inv)
    problem = RowProblem(system, columns)
    theta = problem.coefficients(truth).theta
    free, variance = system.free_estimate()
    lin, s, delay = column_search(grids[0], free[:, 0], 1.0 / variance[:, 0])
    assert delay == 0 and lin == pytest.approx(0.9, abs=0.02) and s == pytest.approx(-0.3, abs=0.1)
    moved = move_delay(system, grids[1], truth, theta=theta, k=1, delay=6)
    assert moved.delays.tolist() == [0, 6] and truth.delays.tolist() == [0, 5]
    # the column's target given once (every delay of the column shares it): the same move
    target = conditional_target(system, theta, 1)
    again = move_delay(system, grids[1], truth, theta=theta, k=1, delay=6, target=target)
    np.testing.assert_allclose(again.lin, moved.lin, rtol=1e-14)
    np.testing.assert_allclose(again.s, moved.s, rtol=1e-14)


def test_column_models_follow_the_element_kinds():
    layout = row_layout(MIXED, 1, n_instruments=3, dithered=np.zeros(3, dtype=bool))
    kinds = [c.kind for c in column_models(MIXED, layout, max_delay_samples=4)]
    assert kinds == ["delay", "pulse", "ratio"]
    first = column_models(MIXED, row_layout(MIXED, 0, n_instruments=3, dithered=np.zeros(3, bool)), max_delay_samples=4)
    assert [c.kind for c in first] == ["ratio", "lag", "ratio"]
    assert first[0].delay_bounds == (-2, 4) and not first[0].low_is_limit  # the model delay 2 bounds dD below
    assert first[1].delay_bounds == interaction_delay_range(MIXED, 4) == (0, 7)
    assert (
        search_candidates(first[1]) == 8 * 2
        and search_candidates(kinds and column_models(MIXED, layout, max_delay_samples=4)[1]) == 8
    )


def test_noise_spectrum_of_a_differenced_row_is_smoothed_with_the_difference_divided_out():
    omega = np.linspace(0, np.pi, 65)
    white = 0.01 * (2 - 2 * np.cos(omega))  # differenced white noise, no regressor
    row = RowSpectra(np.zeros((65, 1)), np.zeros((65, 1, 1)), white, np.zeros((65, 1)), np.zeros((65, 1, 1)), True)
    phi = noise_spectrum(row, np.array([0]), np.zeros((65, 1)), omega)
    np.testing.assert_allclose(phi[1:], white[1:], rtol=1e-9)


def test_noise_spectrum_of_gathered_moments_is_the_same_numbers():
    rng = np.random.default_rng(2)
    omega = np.linspace(0, np.pi, 65)
    X = rng.standard_normal((65, 3, 3)) + 1j * rng.standard_normal((65, 3, 3))
    xx = np.einsum("fkz,fmz->fkm", X, X.conj())
    xy = rng.standard_normal((65, 3)) + 1j * rng.standard_normal((65, 3))
    row = RowSpectra(np.zeros((65, 2)), np.zeros((65, 2, 3)), 50.0 + omega, xy, xx, False)
    columns, theta = np.array([0, 2]), 0.1 * (rng.standard_normal((65, 2)) + 1j)
    gathered = (xy[:, columns], xx[:, columns][:, :, columns])
    alone = noise_spectrum(row, columns, theta, omega)
    assert np.array_equal(noise_spectrum(row, columns, theta, omega, moments=gathered), alone)
    xy_kept, xx_kept = column_moments(row, columns)  # the row's own gather: the same moments
    assert np.array_equal(xy_kept, gathered[0]) and np.array_equal(xx_kept, gathered[1])


def test_fitted_bins_skip_leading_bins_without_coherence_and_the_zero_bin_of_a_differenced_row():
    omega = np.linspace(0, np.pi, 10)
    coherence = np.array([0.9, 0.2, 0.8, 0.9, 0.9, 0.1, 0.9, 0.9, 0.9, 0.9])
    assert fitted_bins(omega, coherence, differenced=False, coherence_min=0.5).tolist() == [0, 2, 3, 4]
    assert fitted_bins(omega, coherence, differenced=True, coherence_min=0.5).tolist() == [2, 3, 4]
    assert fitted_bins(omega, np.zeros(10), differenced=True, coherence_min=0.5).size == 0


# -- verdicts --------------------------------------------------------------------------------------


LABELS = [("G11", "u1")]


def _fit(columns, *, lin, s, delays, sd_lin, lack=1.0) -> RowFit:
    n = len(columns)
    profiles = tuple({int(d): 0.0, int(d) + 1: 50.0} for d in delays)
    return RowFit(
        lin=np.array(lin, float),
        s=np.array(s, float),
        delays=np.array(delays),
        sd_lin=np.array(sd_lin, float),
        sd_s=np.full(n, 0.01),
        chi_square=100.0,
        dof=100,
        delay_profile=profiles,
        lack_of_fit=np.full(n, lack),
        columns=tuple(columns),
    )


def test_an_element_at_its_search_limit_or_misfitted_is_inconclusive_with_its_numbers():

    settings = _settings()
    column = _ratio_column()
    good = element_result(
        _fit([column], lin=[1.12], s=[0.0], delays=[1], sd_lin=[0.005]),
        0,
        settings=settings,
        quality={},
        warnings=(),
        labels=LABELS,
    )
    assert good.verdict == "mismatch" and good.gain_verdict == "mismatch" and good.tau_verdict == "ok"
    edge = _fit([column], lin=[1.12], s=[0.3], delays=[6], sd_lin=[0.005])
    assert trust_reasons(edge, 0, settings)[0].startswith("delay at the search limit")
    result = element_result(edge, 0, settings=settings, quality={}, warnings=(), labels=LABELS)
    assert result.verdicts[:3] == ("inconclusive",) * 3 and result.gain_mismatch_pct == pytest.approx(12.0)
    misfit = _fit([column], lin=[1.12], s=[0.0], delays=[1], sd_lin=[0.005], lack=40.0)
    assert "fit does not follow the data (40.0x" in trust_reasons(misfit, 0, settings)[0]
    integrating = ColumnModel("delay", 0.0, 1.0, (0.0, 0.0), (-3, 3), True)
    level = element_result(
        _fit([integrating], lin=[0.9], s=[0.0], delays=[0], sd_lin=[0.005]),
        0,
        settings=settings,
        quality={},
        warnings=(),
        labels=LABELS,
    )
    assert level.tau_mismatch_pct is None and level.tau_verdict is None and level.verdict == "mismatch"


def test_an_interaction_is_judged_by_its_share_of_the_row_with_the_search_counted():

    settings = _settings()
    # 3.5 sd from zero: beyond a single 95 % interval, not beyond the Bonferroni level of 30 candidates
    assert interaction_verdict(3.5 * 2.0, 2.0, candidates=1, settings=settings) == "mismatch"
    # not a mismatch at the Bonferroni level, and its plain interval [2.1, 9.9] holds shares beyond 2 x 3 %
    assert interaction_verdict(3.0 * 2.0, 2.0, candidates=30, settings=settings) == "inconclusive"
    assert interaction_verdict(1.0, 2.0, candidates=30, settings=settings) == "ok"  # [-2.9, 4.9]: within 2 x 3 %
    assert interaction_verdict(2.0, 0.2, candidates=30, settings=settings) == "ok"  # certain but below 3 %
    assert interaction_verdict(1.0, 20.0, candidates=30, settings=settings) == "inconclusive"
    lag = _lag_column()
    found = interaction_result(
        _fit([lag], lin=[0.8], s=[0.0], delays=[3], sd_lin=[0.01]),
        0,
        share_per_gain=0.5,
        settings=settings,
        quality={},
        warnings=(),
    )
    assert found.verdict == "mismatch" and found.mismatches == ("interaction",) and found.unmodeled_delay_samples == 3
    assert found.unmodeled_gain_interval == pytest.approx((0.8 - 1.96 * 0.01, 0.8 + 1.96 * 0.01), abs=1e-4)
    assert found.quality["unmodeled_share_pct"] == pytest.approx(40.0)
    assert found.gain_verdict is None and found.summary().startswith("unmodeled interaction: gain +0.8")
    nothing = interaction_result(
        _fit([lag], lin=[0.001], s=[0.0], delays=[12], sd_lin=[0.002]),
        0,
        share_per_gain=0.5,
        settings=settings,
        quality={},
        warnings=(),
    )
    assert nothing.verdict == "ok" and not nothing.reasons  # an absent interaction's delay at the limit means nothing
    unprofiled = replace(_fit([lag], lin=[0.8], s=[0.0], delays=[3], sd_lin=[0.01]), delay_profile=({},))
    found = interaction_result(unprofiled, 0, share_per_gain=0.5, settings=settings, quality={}, warnings=())
    # no profile, no confidence to claim; a verdict on a gain that grew past its chance level after the search
    # says its delay was not profiled
    assert found.verdict == "mismatch" and found.delay_confidence is None and found.unmodeled_delay_samples == 3
    assert "interaction delay not profiled" in found.warnings


def test_an_interaction_is_absent_within_the_bonferroni_level_of_its_search():
    from scipy.stats import norm

    from pmr_ros.core.pmr.parametric.parameterization import absence_z

    layout = row_layout(MIXED, 0, n_instruments=3, dithered=np.zeros(3, bool))
    columns = column_models(MIXED, layout, max_delay_samples=4)
    z = absence_z(columns, confidence_level=0.95)
    lag = columns[1]
    assert lag.interaction and not columns[0].interaction
    assert z[0] == math.inf and z[2] == math.inf  # an element is never absent
    np.testing.assert_allclose(z[1], norm.ppf(1.0 - 0.05 / (2.0 * search_candidates(lag))), rtol=1e-12)
    settings = _settings()
    share = z[1] * 2.0  # at the level: inconclusive at most, never a mismatch
    assert interaction_verdict(0.99 * share, 2.0, candidates=search_candidates(lag), settings=settings) != "mismatch"
    assert interaction_verdict(1.01 * share + 6.0, 2.0, candidates=search_candidates(lag), settings=settings) == (
        "mismatch"
    )


# -- results and tables ------------------------------------------------------------------------------


def test_results_of_every_kind_round_trip_and_read():
    interaction = ParametricResult(
        delay_confidence=0.99,
        gain_verdict=None,
        tau_verdict=None,
        delay_verdict=None,
        unmodeled_gain=0.42,
        unmodeled_gain_interval=(0.40, 0.44),
        unmodeled_delay_samples=3,
        unmodeled_verdict="mismatch",
    )
    level = ParametricResult(
        gain_mismatch_pct=15.0,
        gain_mismatch_pct_interval=(14.0, 16.0),
        delay_mismatch_samples=0,
        delay_confidence=1.0,
        gain_verdict="mismatch",
        tau_verdict=None,
        delay_verdict="ok",
    )
    edge = ClassicResult(1.1, 12.0, 10, True, True, True, reasons=("delay at the search limit",))
    elements = {
        "G13": ElementDiagnosis("G13", 0, 2, ElementModel("none", 0.0, None, 0), "parametric", parametric=interaction),
        "G21": ElementDiagnosis(
            "G21", 1, 0, ElementModel("integrating", 0.05, None, 1), "parametric", classic=edge, parametric=level
        ),
    }
    diagnosis = Diagnosis("parametric", "ok", "", 100, elements)
    assert diagnosis_from_json(diagnosis_to_json(diagnosis)) == diagnosis
    assert interaction.verdict == "mismatch" and level.verdict == "mismatch" and level.mismatches == ("gain",)
    assert edge.verdict == "inconclusive" and "inconclusive: delay at the search limit" in edge.summary()
    assert "τ" not in level.summary()
    table = format_parametric_table(diagnosis, confidence_level=0.95)
    assert "G13      no model: K +0.42 [+0.4,+0.44]!" in table and "+3 (99 %)" in table
    level_line = next(line for line in table.splitlines() if line.startswith("G21"))
    assert level_line.split()[1:7] == ["+15.0", "[", "+14.0,", "+16.0]!", "-", "+0"]  # no time constant: "-"
    classic = format_classic_table(diagnosis)
    assert classic.splitlines()[1].split() == ["G13", "-", "-", "-", "-", "-", "mismatch"]  # no classic result
    assert "G21           1.100" in classic and "G21: delay at the search limit" in classic


def test_complex_products_from_real_ones_equal_numpy():
    from pmr_ros.core.pmr.products import hermitian_product, product, real_product

    rng = np.random.default_rng(5)
    a = rng.standard_normal((7, 5, 3)) + 1j * rng.standard_normal((7, 5, 3))
    b = rng.standard_normal((7, 5, 4)) + 1j * rng.standard_normal((7, 5, 4))
    np.testing.assert_allclose(hermitian_product(a, b), np.conj(np.swapaxes(a, 1, 2)) @ b, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(product(np.swapaxes(a, 1, 2), b), np.swapaxes(a, 1, 2) @ b, rtol=1e-12, atol=1e-12)
    expected = np.real(np.swapaxes(a, 1, 2) @ b)
    np.testing.assert_allclose(real_product(np.swapaxes(a, 1, 2), b), expected, rtol=1e-12, atol=1e-12)
    # the real part product() computes, to the bit
    np.testing.assert_array_equal(real_product(np.swapaxes(a, 1, 2), b), np.real(product(np.swapaxes(a, 1, 2), b)))


# -- the Welch segments' leakage --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "pole_model", "reference", "delay"),
    [
        ("ratio", math.exp(-1 / 15), 15.0, 2),
        ("ratio", math.exp(-1 / 8), 8.0, -1),
        ("lag", 0.0, 6.0, 3),
        ("delay", 0.0, 1.0, 1),
    ],
)
def test_a_columns_time_domain_response_is_its_coefficient(kind, pole_model, reference, delay):
    """``ColumnModel.response`` has the frequency response ``lin shape(w) z^-d`` (scipy.signal.freqz)."""
    column = ColumnModel(kind, pole_model, reference, (-3.0, 3.0), (-3, 5), False)
    impulse = np.zeros(2048)
    impulse[64] = 1.0
    response = column.response(impulse, lin=1.3, s=0.2, delay=delay)
    omega = np.linspace(0.01, 3.0, 40)
    _, measured = freqz(response, worN=omega)
    _, reference_impulse = freqz(impulse, worN=omega)
    shape, _ = column.shapes(np.exp(-1j * omega), np.array([0.2]))
    expected = 1.3 * shape[0] * np.exp(-1j * omega) ** delay
    np.testing.assert_allclose(measured / reference_impulse, expected, rtol=1e-9, atol=1e-9)
    # started at steady state: a constant input gives the coefficient's gain at once
    step = column.response(np.ones((50, 2)), lin=1.3, s=0.2, delay=delay)
    np.testing.assert_allclose(step, 1.3, rtol=1e-12)


def test_instrument_cross_of_the_regressors_themselves_is_the_rows_spectra(wood_berry):
    record = simulate(wood_berry, samples=4096, seed=2)
    spectra = record_spectra([Record(record.r, record.u, record.y)], wood_berry.model, WelchSettings("hann", 256, 0.5))
    for i in range(2):
        regressors = spectra.instrument_cross(i, lambda x, u: x)
        np.testing.assert_allclose(regressors, spectra.row(i).zx, rtol=1e-12, atol=1e-14)
        bins = np.array([1, 4, 9, 30])  # only some bins: those of the whole
        at_bins = spectra.instrument_cross(i, lambda x, u: x, bins)
        np.testing.assert_allclose(at_bins, spectra.row(i).zx[bins], rtol=1e-12, atol=1e-14)


def test_the_leakage_offset_makes_the_equations_exact_at_the_true_parameters_without_noise():
    """Noise-free, ``S_zy - offset = sum_k theta_k S_zx_k`` at the truth.

    Without the offset the segments' edges leave a residual (the leakage) that biased an ill-conditioned
    column's ratios by one to two deviations.
    """
    config = SKOGESTAD_LV.config()
    config = replace(config, noise_std=np.zeros_like(config.noise_std))
    record = simulate(config, samples=8192, seed=1, scenario="full")
    welch = config.parametric.welch(config.model, 8192, config.pmr)
    spectra = record_spectra([Record(record.r, record.u, record.y)], config.model, welch)
    factor = instrument_factor(spectra.rr)
    layout = row_layout(config.model, 0, n_instruments=spectra.n_instruments, dithered=spectra.dithered)
    row = spectra.row(0)
    bins = np.arange(1, 60)
    data = RowData(row, factor, layout.columns, bins, spectra.omega, spectra.equivalent_segments, 1.0, spectra, 0)
    columns = column_models(config.model, layout, max_delay_samples=config.pmr.max_delay_samples)
    truth = config.mismatch.for_scenario("full")
    params = RowParameters(
        1.0 + truth.gain_pct[0] / 100.0, np.log1p(truth.time_constant_pct[0] / 100.0), truth.delay_samples[0].copy()
    )
    problem = RowProblem(data.system(np.zeros((spectra.omega.size, 2), dtype=complex)), columns)
    theta = problem.coefficients(params, np.exp(-1j * spectra.omega)).theta
    product = np.einsum("fzk,fk->fz", row.zx[:, :, layout.columns], theta)
    scale = np.abs(row.zy[bins]).max()
    leakage = np.abs(row.zy[bins] - product[bins]).max() / scale
    offset = leakage_offset(data, problem, params)
    left = np.abs(row.zy[bins] - offset[bins] - product[bins]).max() / scale
    assert leakage > 1e-3  # what the fit saw before
    assert left < 1e-3 * leakage
    assert offset.shape == row.zy.shape and not np.any(np.delete(offset, bins, axis=0))  # 0 where no fit reads


def test_the_excitation_guard_holds_a_row_of_many_elements_to_a_fair_share():
    from pmr_ros.core.pmr.identifiable import RowLayout
    from pmr_ros.core.pmr.parametric.guard import FAIR_SHARE_ELEMENTS, RowQuality

    settings = replace(load_config(None).parametric, excitation_min=0.02)

    def quality(gains, shares):
        n = len(gains)
        layout = RowLayout(0, np.arange(n))
        return RowQuality(
            layout, np.arange(3), 0.9, 1.0, 1.0, np.array(shares), (), (), np.zeros(n, bool), np.array(gains)
        )

    small = quality([1.0, 0.5, 0.0, 2.0], [0.6, 0.015, 0.0, 0.385])  # 3 modeled elements: 2 % itself
    assert small.excitation_least(settings) == (0.02, 3)
    reasons = small.element_reasons(1, settings, modeled=True, input_name="u2", element_name="G12")
    assert (
        len(reasons) == 1
        and "(1.5 % of the row's instrument-driven output < parametric.excitation_min 2 %)" in reasons[0]
    )
    gains = np.ones(16)
    big = quality(gains, np.full(16, 1 / 16))  # 16 modeled elements: 2 % x 4/16 = 0.5 %
    least, elements = big.excitation_least(settings)
    np.testing.assert_allclose(least, 0.02 * FAIR_SHARE_ELEMENTS / 16, rtol=1e-12)
    assert elements == 16
    shares = np.full(16, 0.006)
    shares[3] = 0.004
    big = quality(gains, shares)
    assert big.element_reasons(0, settings, modeled=True, input_name="u1", element_name="G11") == ()  # 0.6 % > 0.5 %
    (reason,) = big.element_reasons(3, settings, modeled=True, input_name="u4", element_name="G14")
    assert "0.4 %" in reason and "x 4/16 elements" in reason and "move u4 more" in reason
