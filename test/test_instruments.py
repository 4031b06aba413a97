"""The instruments of the data, the D elements' names and the augmented model/record, the attribution's arithmetic."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.pmr.checks import InsufficientData, check_stretches
from pmr_ros.core.pmr.implicit import input_label, row_layout
from pmr_ros.core.pmr.parametric.attribution import (
    instrument_shares,
    more_data_factor,
    more_data_reason,
    needed_halfwidth,
    with_attribution,
)
from pmr_ros.core.records import InstrumentSet, Record, instruments, moving_columns, moving_instruments
from pmr_ros.core.results import ParametricResult, compare_diagnoses
from pmr_ros.core.sim.augment import (
    augmented_model,
    augmented_record,
    disturbance_part,
    missing_disturbances,
    process_part,
    with_disturbances,
)
from pmr_ros.core.sim.model import TransferMatrix, element_name

G = TransferMatrix([[1.0, 2.0], [3.0, 4.0]], [[5.0, 6.0], [7.0, 8.0]], [[0.0, 1.0], [2.0, 0.0]], 1.0)
GD = TransferMatrix(
    [[0.5], [0.0]], [[4.0], [1.0]], [[2.0], [0.0]], 1.0, input_names=("feed",), element_type=[["foptd"], ["none"]]
)


def _record(n=4000, *, seed=0, r_moves=(True, False), dither=(True, False), manual=None, dv=None):
    rng = np.random.default_rng(seed)
    r = rng.standard_normal((n, 2)) * np.array(r_moves, dtype=float) + 3.0
    d = rng.standard_normal((n, 2)) * np.array(dither, dtype=float)
    return Record(r, rng.standard_normal((n, 2)), rng.standard_normal((n, 2)), d, dv=dv, manual=manual)


def test_only_signals_that_move_are_instruments_and_a_manual_column_is_u_where_manual():
    manual = np.zeros((4000, 2), dtype=bool)
    manual[1000:2000, 1] = True
    record = _record(manual=manual)
    moving = moving_instruments([record])
    assert moving.setpoints.tolist() == [True, False] and moving.dither.tolist() == [True, False]
    assert moving.manual.tolist() == [False, True] and moving.count == 3 and moving.direct.tolist() == [True, True]
    z = instruments(record, moving)
    np.testing.assert_allclose(z[:, 0], record.r[:, 0], rtol=1e-15)
    np.testing.assert_allclose(z[:, 1], record.dither[:, 0], rtol=1e-15)
    u2 = record.u[1000:2000, 1]
    np.testing.assert_allclose(z[1000:2000, 2], u2 - u2.mean(), atol=1e-12)
    assert not z[:1000, 2].any() and not z[2000:, 2].any()
    assert moving.labels(("a.b", "y2"), ("u1", "feed"), n_disturbances=1) == ("setpoint_a_b", "dither_u1", "dv_feed")
    assert moving_columns(np.array([[1.0, 2.0], [1.0, 3.0]])).tolist() == [False, True]


def test_an_input_held_in_manual_is_no_instrument():
    manual = np.zeros((4000, 2), dtype=bool)
    manual[:, 1] = True
    record = _record(manual=manual)
    record = Record(record.r, np.column_stack([record.u[:, 0], np.full(4000, 2.0)]), record.y, manual=manual)
    moving = moving_instruments([record])
    assert not moving.manual.any() and moving.count == 1


def test_a_constant_setpoint_is_no_refusal_but_nothing_moving_is():
    welch = load_config().pmr.welch
    check_stretches([_record(r_moves=(False, False), dither=(True, True))], model=G, welch=welch)  # passes
    still = _record(r_moves=(False, False), dither=(False, False))
    with pytest.raises(InsufficientData, match="no excitation: nothing external moves in this record.*add MV dither"):
        check_stretches([still], model=G, welch=welch)


def test_d_element_names_and_the_augmented_model():
    assert element_name(9, 2, 10, prefix="D") == "D10_3" and element_name(0, 0, 2, prefix="D") == "D11"
    both = augmented_model(G, GD)
    assert both.n_disturbances == 1 and both.element_names() == ["G11", "G12", "D11", "G21", "G22", "D21"]
    assert both.input_names == ("u1", "u2", "feed") and both.element_type[1, 2] == "none"
    assert process_part(both).element_names() == G.element_names() and process_part(G) is G
    np.testing.assert_allclose(process_part(both).gain, G.gain, rtol=0)
    assert disturbance_part(G) is None
    np.testing.assert_allclose(disturbance_part(both).gain, GD.gain, rtol=0)
    big = TransferMatrix(np.ones((10, 3)), np.ones((10, 3)), np.zeros((10, 3)), 1.0, n_disturbances=1)
    assert big.element_names()[:3] == ["G1_1", "G1_2", "D1_1"] and big.element_names()[-1] == "D10_1"
    assert augmented_model(G, None) is G
    with pytest.raises(ValueError, match="does not match the model"):
        augmented_model(G, TransferMatrix([[1.0]], [[1.0]], [[0.0]], 1.0))
    assert input_label(both, 2) == "the measured disturbance feed" and input_label(both, 0) == "u1"


def test_the_augmented_record_has_the_dvs_as_inputs_always_in_manual():
    dv = np.arange(8.0).reshape(8, 1)
    record = Record(np.zeros((8, 2)), np.ones((8, 2)), np.zeros((8, 2)), np.full((8, 2), 0.5), dv=dv)
    both = augmented_record(record, 1)
    np.testing.assert_array_equal(both.u[:, 2], dv[:, 0])
    assert both.manual[:, :2].sum() == 0 and both.manual[:, 2].all() and both.dv is None
    np.testing.assert_array_equal(both.dither[:, 2], 0.0)
    assert missing_disturbances([record], GD) is None
    line = missing_disturbances([Record(record.r, record.u, record.y)], GD)
    assert line.startswith("the configuration has 1 measured disturbance (feed) but the data carry none")
    stretches, model = with_disturbances([record], G, GD)
    assert model.n_disturbances == 1 and stretches[0].u.shape == (8, 3)
    with pytest.raises(ValueError, match="the data carry dv of shape"):
        with_disturbances([Record(record.r, record.u, record.y, dv=np.zeros((8, 2)))], G, GD)


def test_row_layout_names_what_nothing_moves_and_leaves_out_a_still_input():
    moving = InstrumentSet(np.array([False, False]), np.array([True, False]), np.array([False, False]))
    layout = row_layout(G, 0, n_instruments=1, dithered=moving.dither, moving=moving)
    assert layout.columns.size == 0
    assert (
        "nothing external moves u2 in this record: add MV dither (excitation.mv_dither_amplitude) on u2"
        in (layout.reasons[0])
    )
    assert layout.reasons[0].endswith("or a setpoint change on y1")
    held = row_layout(G, 1, n_instruments=1, dithered=moving.dither, moving=moving, still=np.array([False, True]))
    assert held.columns.tolist() == [0] and not held.reasons
    assert held.missing(1).startswith("u2 does not move at all in this record") and held.missing(0) is None


def test_instrument_shares_are_each_instruments_part_of_the_explained_power():
    rng = np.random.default_rng(3)
    F = 6
    zx = rng.standard_normal((F, 3, 2)) + 1j * rng.standard_normal((F, 3, 2))
    power = np.array([1.0, 4.0, 0.25])
    rr = np.tile(np.diag(power), (F, 1, 1)).astype(complex)
    bins = np.array([1, 2, 4])
    shares = instrument_shares(zx, rr, bins)
    expected = (np.abs(zx[bins]) ** 2 / power[None, :, None]).sum(axis=0)
    np.testing.assert_allclose(shares, expected / expected.sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(shares.sum(axis=0), 1.0, rtol=1e-12)
    assert not instrument_shares(np.zeros((F, 3, 1), dtype=complex), rr, bins).any()


def test_the_more_data_factor_is_the_squared_ratio_of_half_widths():
    settings = load_config().parametric  # gain tolerance 3 %, ok band 2x, max half-width 15 pp
    assert needed_halfwidth(1.0, tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0) == 5.0
    assert needed_halfwidth(3.0, tolerance=3.0, ok_band_factor=2.0, max_halfwidth=15.0) == 3.0
    # centre 1 %, half-width 8 pp: ok needs 5 pp -> (8/5)^2 = 2.56x the data
    np.testing.assert_allclose(more_data_factor((-7.0, 9.0), tolerance=3.0, settings=settings), 2.56, rtol=1e-12)
    assert more_data_factor((-3.0, 9.0), tolerance=3.0, settings=settings) == pytest.approx((6.0 / 3.0) ** 2)
    # an estimate sitting on the tolerance with an ok band of one tolerance: no amount of data decides
    on_the_edge = replace(settings, ok_band_factor=1.0)
    assert math.isinf(more_data_factor((0.0, 6.0), tolerance=3.0, settings=on_the_edge))
    assert "would not decide" in more_data_reason(math.inf, samples=1, sample_time=1.0)
    text = more_data_reason(3.2, samples=1000, sample_time=2.0)
    assert text.startswith("~3.2x the data (2200 more samples, 4400 time units)") and "1/sqrt(N)" in text
    result = ParametricResult(
        gain_mismatch_pct=1.0, gain_mismatch_pct_interval=(-7.0, 9.0), gain_verdict="inconclusive", tau_verdict=None
    )
    attributed = with_attribution(result, {"dither_u1": 1.0}, samples=1000, sample_time=1.0, settings=settings)
    assert attributed.instrument_shares == {"dither_u1": 1.0}
    np.testing.assert_allclose(attributed.more_data_factor, 2.56, rtol=1e-12)
    assert attributed.reasons[-1].startswith("~2.6x the data (1560 more samples")
    apart = ParametricResult(
        gain_mismatch_pct_interval=(-7.0, 9.0), gain_verdict="inconclusive", reasons=("cannot be told apart",)
    )
    assert with_attribution(apart, {}, samples=1, sample_time=1.0, settings=settings).more_data_factor is None


def test_a_recording_without_instrument_shares_still_agrees():
    def element(shares):
        return {"G11": {"parametric": {"gain_mismatch_pct": 1.0, "instrument_shares": shares}}}

    assert compare_diagnoses(element({}), element({"setpoint_y1": 1.0})) == []
    assert compare_diagnoses(element(None), element({"setpoint_y1": 1.0})) == []
    assert compare_diagnoses(element({"setpoint_y1": 0.4}), element({"setpoint_y1": 1.0})) == [
        "G11.parametric.instrument_shares.setpoint_y1: 0.4 != 1.0"
    ]
