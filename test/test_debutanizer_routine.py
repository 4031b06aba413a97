"""The shipped routine-operation debutanizer (config/debutanizer_routine.yaml): what it declares, and that it runs."""

from __future__ import annotations

import numpy as np
import pytest

from pmr_ros.config import config_dir, load_config
from pmr_ros.core.sim.closed_loop import routine_features, simulate_with_statistics


@pytest.fixture(scope="module")
def routine():
    return load_config(config_dir() / "debutanizer_routine.yaml")


def test_it_is_the_industrial_column_with_two_dvs_zones_steps_and_manual_stretches(routine):
    column = load_config(config_dir() / "industrial_column.yaml")
    np.testing.assert_array_equal(routine.model.gain, column.model.gain)
    np.testing.assert_array_equal(routine.model.delay, column.model.delay)
    d = routine.disturbance_model
    assert d is not None and d.input_names == ("wild_feed", "feed_c4") and d.output_names == column.model.output_names
    # the wild feed acts like the MV feed on the compositions (same signs, weaker, later)
    feed = column.model.input_names.index("feed")
    assert np.all(np.sign(d.gain[:2, 0]) == np.sign(column.model.gain[:2, feed]))
    assert np.all(d.delay[:2, 0] > column.model.delay[:2, feed])
    # a lighter feed: less C5 over the top, more C4 in the bottoms, pressure up
    assert d.gain[0, 1] < 0 < d.gain[1, 1] and d.gain[3, 1] > 0 and d.element_type[2, 1] == "none"
    assert routine.mpc.output_mode == ("setpoint", "setpoint", "zone", "zone")
    assert sorted(j for _, _, j in routine.manual.stretches) == list(range(8))
    assert routine.run.samples == 28 * 24 * 60  # four weeks at Ts = 1 min
    assert routine.prbs.mode == "steps" and routine.prbs.step_interval_samples >= 120  # several hours
    assert routine_features(routine) == [
        "measured disturbances",
        "CV zones or limits",
        "setpoint steps",
        "manual stretches",
    ]


def test_its_injected_changes_are_three_g_elements_and_one_d_element(routine):
    mismatch, dv = routine.mismatch, routine.disturbance_mismatch
    assert dv is not None
    changed = (mismatch.gain_pct != 0) | (mismatch.time_constant_pct != 0) | (mismatch.delay_samples != 0)
    assert [routine.model.element_names()[j] for j in np.flatnonzero(changed.ravel())] == ["G12", "G21", "G33"]
    assert np.count_nonzero(dv.gain_pct) == 1 and dv.gain_pct[0, 0] == 25.0
    truth = routine.disturbance_plant()
    assert truth is not None and routine.disturbance_model is not None
    np.testing.assert_allclose(truth.gain[0, 0], 1.25 * routine.disturbance_model.gain[0, 0], rtol=1e-12)


def test_its_first_days_simulate_with_every_feature(routine):
    record, statistics = simulate_with_statistics(routine, samples=3200)  # to the end of the first manual stretch
    assert statistics.failures == 0 and np.all(np.isfinite(record.y))
    assert record.dv is not None and record.manual is not None
    assert np.count_nonzero(np.diff(record.dv[:, 0])) >= 5  # the wild feed steps every few hours
    np.testing.assert_array_equal(record.r[:, 2:], 0.0)  # zone CVs: no setpoint moves
    assert np.count_nonzero(np.diff(record.r[:, 0])) >= 3
    np.testing.assert_array_equal(np.flatnonzero(record.manual[:, 0]), np.arange(2880, 3120))
    # compositions near their setpoints; the level mostly within its zone
    assert np.sqrt(np.mean((record.r[:, :2] - record.y[:, :2]) ** 2)) < 0.15
    assert np.mean(np.abs(record.y[:, 2]) <= 10.0 + 3 * 0.3) > 0.9
