"""The shipped industrial-shaped example (config/industrial_column.yaml).

Shape, stability in every scenario, identifiability of every row, offset-free control of every CV.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import csd

from pmr_ros.config import config_dir, load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.mpc.design import steady_state_gain
from pmr_ros.core.mpc.stability import loop_spectral_radius
from pmr_ros.core.sim.batch import run_lockstep
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import SCENARIOS
from pmr_ros.core.sim.true_plant import FoptdPlant


@pytest.fixture(scope="module")
def column():
    return load_config(config_dir() / "industrial_column.yaml")


def test_shape_half_empty_with_a_level_and_a_pressure(column):
    model = column.model
    assert (model.n_outputs, model.n_inputs) == (4, 8) and not column.warnings
    assert int(model.present.sum()) == 16  # half the cells empty
    assert list(np.asarray(model.output_names)[model.integrating_outputs]) == ["drum_level", "pressure"]
    assert model.present.any(axis=0).all() and model.present.any(axis=1).all()  # every MV acts, every CV is moved
    assert column.excitation.active and np.all(column.excitation.mv_dither_amplitude > 0)


def test_the_loop_is_stable_in_every_scenario(column):
    controller = LinearMpc(column.model, column.mpc)
    for scenario in SCENARIOS:
        assert loop_spectral_radius(controller, column.plant(scenario)) < 0.99, scenario


def test_every_row_is_identifiable_from_setpoints_and_dither(column):
    record = simulate(column, samples=8192, scenario="none")
    model = column.model
    instruments = np.hstack([record.r, record.dither])
    freq, _ = csd(record.u[:, 0], record.u[:, 0], nperseg=512)
    band = (freq > 0) & (2 * np.pi * freq <= column.pmr.tau_band)
    cross = np.array([[csd(z, u, nperseg=512)[1][band] for u in record.u.T] for z in instruments.T])
    contributions = model.element_outputs(record.u)[model.settling_samples() :]
    for i in range(model.n_outputs):
        columns = np.flatnonzero(model.present[i])
        # the instruments move the row's MVs independently: a well-conditioned cross-spectrum, columns scaled
        conditions = [np.linalg.cond(c / np.linalg.norm(c, axis=0)) for c in np.moveaxis(cross[:, columns], 2, 0)]
        assert np.median(conditions) < 20, model.output_names[i]
        # and each element carries a share of the row's output above the diagnosis's excitation floor
        part = contributions[:, i, columns]
        part = np.diff(part, axis=0) if model.integrating_outputs[i] else part
        share = part.var(axis=0) / part.var(axis=0).sum()
        assert share.min() > 2 * column.parametric.excitation_min, (model.output_names[i], share)


def test_an_unmeasured_feed_upset_leaves_no_offset_on_any_cv(column):
    model, n = column.model, 6000
    setpoint = np.array([0.2, -0.2, 1.0, 0.5])
    tuning = column.mpc
    controller = LinearMpc(model, tuning)
    plant = FoptdPlant(model, 0.0, seed=0)
    load = np.zeros(model.n_inputs)
    load[model.input_names.index("feed")] = 0.8  # more feed than the controller knows of
    load[model.input_names.index("condenser_duty")] = -5.0  # and a condenser that lost duty
    u = np.zeros(model.n_inputs)
    for k in range(n):
        y = plant.measure()
        u = controller.step(y, setpoint)
        plant.advance(u, disturbance=load if k >= 2000 else None)
    np.testing.assert_allclose(y, setpoint, atol=1e-6)
    # the inputs rest at the input targets' weighted nearest steady state (closed form), within their limits
    G = steady_state_gain(model)
    b = np.where(model.integrating_outputs, 0.0, setpoint)
    s_inv = np.diag(1.0 / tuning.input_target_weight)
    target = tuning.input_target
    expected = target + s_inv @ G.T @ np.linalg.solve(G @ s_inv @ G.T, b - G @ (target + load))
    np.testing.assert_allclose(u, expected, atol=1e-6)
    assert np.all(u > tuning.u_min) and np.all(u < tuning.u_max)


def test_a_run_keeps_the_limits_without_solver_failures(column):
    result = run_lockstep(column, [("full", 1), ("none", 2)], samples=3000)
    for record, stats in zip(result.records, result.statistics, strict=True):
        assert np.all(record.u >= column.mpc.u_min - 1e-9) and np.all(record.u <= column.mpc.u_max + 1e-9)
        assert stats.failures == 0 and np.all(np.isfinite(record.y))
