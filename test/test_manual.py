"""Manual stretches: an MV's controller off, an operator moving it, the MPC taking it as a given input."""

from __future__ import annotations

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.closed_loop import routine_features, simulate
from pmr_ros.core.sim.operation import ManualOperator, ManualSettings, manual_plan

STRETCHES = [[300, 400, "reflux"], [900, 300, 1]]


@pytest.fixture(scope="module")
def manual_run():
    config = load_config(
        overrides={
            "run": {"manual_stretches": STRETCHES, "manual_move_amplitude": [0.8, 0.6], "manual_moves": 4},
            "excitation": {"mv_dither_amplitude": 0.2},
        }
    )
    return config, simulate(config, samples=1500)


def test_the_record_marks_the_manual_samples(manual_run):
    config, record = manual_run
    assert routine_features(config) == ["manual stretches"]
    expected = np.zeros((1500, 2), dtype=bool)
    expected[300:700, 0] = expected[900:1200, 1] = True
    np.testing.assert_array_equal(record.manual, expected)


def test_an_operator_moves_the_mv_in_a_few_steps_from_where_it_was(manual_run):
    config, record = manual_run
    manual, offset = manual_plan(config.manual, 2, 1500, config.run.seed)
    for (start, length, j), amplitude in zip(config.manual.stretches, (0.8, 0.6), strict=True):
        inside = record.u[start : start + length, j]
        expected = np.clip(record.u[start - 1, j] + offset[start : start + length, j], -2.0, 2.0)
        np.testing.assert_allclose(inside, expected, rtol=0, atol=1e-12)
        assert 2 <= np.unique(inside).size <= 5 and np.max(np.abs(inside - record.u[start - 1, j])) <= amplitude
        assert record.dither is not None and np.all(record.dither[start : start + length, j] == 0.0)
        # the controller takes over again without a bump: its first move within the move limit
        assert abs(record.u[start + length, j] - record.u[start + length - 1, j]) <= 0.5 + 0.2 + 1e-9
    other = record.u[300:700, 1]
    assert np.ptp(other) > 0.1  # the other MV stays under control meanwhile


def test_a_manual_mv_is_a_given_input_of_the_controller(wood_berry):
    mpc = LinearMpc(wood_berry.model, wood_berry.mpc)
    plant_x = np.zeros(mpc.matrices.A.shape[0])
    rng = np.random.default_rng(1)
    for k in range(60):
        given = np.array([1.7 if k >= 10 else 0.0, np.nan])  # a 1.7 jump: beyond du_max = 0.5
        u = mpc.step(mpc.model_output, rng.normal(size=2), manual_input=given)
        assert u[0] == given[0]
        plant_x = mpc.matrices.A @ plant_x + mpc.matrices.B @ u
        np.testing.assert_allclose(mpc.model_output, mpc.matrices.C @ plant_x, rtol=0, atol=1e-12)
    assert mpc.disturbance[0].tolist() == [0.0, 0.0]  # no residual: the manual input is no disturbance


def test_stretches_beyond_the_run_are_cut_and_draw_the_same_moves():
    settings = ManualSettings(((10, 20, 0), (95, 50, 1)), np.array([1.0, 1.0]), 3)
    short_manual, short_offset = manual_plan(settings, 2, 100, 5)
    long_manual, long_offset = manual_plan(settings, 2, 200, 5)
    np.testing.assert_array_equal(short_manual, long_manual[:100])
    np.testing.assert_array_equal(short_offset, long_offset[:100])
    assert short_manual[95:, 1].all() and long_manual[95:145, 1].all() and not long_manual[145:, 1].any()


def test_the_operator_asked_sample_by_sample_gives_the_batch_moves(manual_run):
    """The node's operator (:class:`ManualOperator`, asked with the last applied u) is the batch loop's."""
    config, record = manual_run
    tuning = config.mpc
    operator = ManualOperator(config.manual, 2, config.run.seed, u_min=tuning.u_min, u_max=tuning.u_max)
    given = [operator.inputs(k, record.u[k - 1] if k else np.zeros(2)) for k in range(1500)]
    on = [k for k, g in enumerate(given) if g is None]
    assert len(on) == 1500 - 700  # every controller on outside the stretches
    values = np.array([g if g is not None else np.full(2, np.nan) for g in given])
    np.testing.assert_allclose(values[record.manual], record.u[record.manual], rtol=0, atol=1e-12)
    assert np.isnan(values[~record.manual]).all()  # NaN: that MV's controller is on
    np.testing.assert_array_equal(operator.in_manual(5000), [False, False])  # beyond the last stretch
