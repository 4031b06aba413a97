"""The lockstep batch simulator reproduces simulate() run by run."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.batch import run_lockstep, simulate_many
from pmr_ros.core.sim.closed_loop import simulate

RUNS = [("none", 1), ("gain", 2), ("time_constant", 3), ("delay", 1), ("full", 2), ("full", 7)]


def test_lockstep_equals_simulate(wood_berry):
    result = run_lockstep(wood_berry, RUNS, samples=3000)
    assert len(result.records) == len(RUNS)
    for (scenario, seed), record, stats in zip(RUNS, result.records, result.statistics, strict=True):
        ref = simulate(wood_berry, samples=3000, seed=seed, scenario=scenario)
        for name in ("r", "u", "y"):
            np.testing.assert_allclose(getattr(record, name), getattr(ref, name), rtol=0, atol=1e-9)
        assert stats.steps == 3000
        assert stats.solves > 0  # the PRBS steps make the move limits bind: the OSQP path is exercised


def test_lockstep_equals_simulate_with_a_longer_horizon(wood_berry):
    model = wood_berry.model.with_time_constant(0, 0, 16.7 * 5)
    config = replace(wood_berry, model=model, mpc=replace(wood_berry.mpc, prediction_horizon=70))
    (record,) = simulate_many(config, [("full", 4)], samples=1500)
    ref = simulate(config, samples=1500, seed=4, scenario="full")
    np.testing.assert_allclose(record.u, ref.u, rtol=0, atol=1e-9)
    np.testing.assert_allclose(record.y, ref.y, rtol=0, atol=1e-9)


def test_simulate_many_empty_and_bad_runs(wood_berry):
    assert simulate_many(wood_berry, []) == []
    with pytest.raises(ValueError, match="unknown scenario"):
        simulate_many(wood_berry, [("bogus", 1)], samples=10)
    with pytest.raises(ValueError, match="seed"):
        simulate_many(wood_berry, [("none", -1)], samples=10)
    with pytest.raises(ValueError, match="samples"):
        simulate_many(wood_berry, [("none", 1)], samples=0)


def test_mpc_matrices_are_read_only_copies(wood_berry):
    mpc = LinearMpc(wood_berry.model, wood_berry.mpc)
    m = mpc.matrices
    Np, Nc, n = wood_berry.mpc.prediction_horizon, wood_berry.mpc.control_horizon, 2
    nz = m.A.shape[0] + 3 * n  # z = [x; u_prev; r; d] (no integrating output: no slope)
    assert Np > Nc and m.gain.shape == (Nc * n, nz) and m.gradient.shape == (Nc * n, nz)
    assert m.gain_offset.shape == (Nc * n,) and not np.any(m.gain_offset)  # square: no input targets
    with pytest.raises(ValueError):
        m.A[0, 0] = 1.0


def test_mv_dither_is_added_to_u_and_the_lockstep_batch_equals_simulate(wood_berry):
    from pmr_ros.core.sim.excitation import ExcitationSettings

    amplitude = np.array([0.2, 0.1])
    config = replace(wood_berry, excitation=ExcitationSettings(amplitude, 5))
    plain = simulate(wood_berry, samples=2000, seed=3)
    dithered = simulate(config, samples=2000, seed=3)
    assert plain.dither is None and dithered.dither.shape == (2000, 2)
    np.testing.assert_allclose(np.abs(dithered.dither), np.broadcast_to(amplitude, (2000, 2)))  # +/- amplitude
    assert np.all(dithered.dither[:5] == dithered.dither[0]) and not np.all(dithered.dither == dithered.dither[0])
    np.testing.assert_array_equal(dithered.r, plain.r)  # the setpoints are not touched
    assert not np.allclose(dithered.u, plain.u)
    # the dither is independent of the setpoints (its own m-sequences) and of the other input's
    corr = np.corrcoef(np.hstack([dithered.r, dithered.dither]).T)
    assert np.max(np.abs(corr - np.eye(4))) < 0.1
    (lockstep,) = simulate_many(config, [("full", 3)], samples=2000)
    np.testing.assert_allclose(lockstep.u, dithered.u, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(lockstep.dither, dithered.dither)


def test_lockstep_equals_simulate_on_a_non_square_system_with_a_level_and_dither():
    from pathlib import Path

    from pmr_ros.config import load_config

    config = load_config(Path(__file__).parent / "configs" / "level_temperature.yaml")
    assert config.model.integrating_outputs.any() and not config.model.present.all() and config.excitation.active
    runs = [("none", 1), ("full", 2), ("gain", 5)]
    result = run_lockstep(config, runs, samples=2500)
    for (scenario, seed), record in zip(runs, result.records, strict=True):
        ref = simulate(config, samples=2500, seed=seed, scenario=scenario)
        for name in ("r", "u", "y", "dither"):
            np.testing.assert_allclose(getattr(record, name), getattr(ref, name), rtol=0, atol=1e-9)
    assert all(stats.solves > 0 for stats in result.statistics)  # the limits bind: the OSQP path is exercised too


def test_an_output_disturbance_enters_simulate_and_the_lockstep_batch_alike_and_only_when_on(wood_berry):
    from pmr_ros.core.sim.true_plant import DisturbanceStream, OutputDisturbance

    disturbance = OutputDisturbance(np.array([0.3, 0.0]), 0.97)
    config = replace(wood_berry, disturbance=disturbance)
    plain = simulate(wood_berry, samples=1500, seed=4)
    disturbed = simulate(config, samples=1500, seed=4)
    np.testing.assert_array_equal(disturbed.r, plain.r)
    assert not np.allclose(disturbed.y[:, 0], plain.y[:, 0])
    (lockstep,) = simulate_many(config, [("full", 4)], samples=1500)
    for name in ("u", "y"):
        np.testing.assert_allclose(getattr(lockstep, name), getattr(disturbed, name), rtol=0, atol=1e-9)
    # off (the default): the measurement noise stream is untouched, so a run is the one without the option
    off = replace(wood_berry, disturbance=OutputDisturbance.off(2))
    np.testing.assert_array_equal(simulate(off, samples=1500, seed=4).y, plain.y)
    np.testing.assert_array_equal(
        simulate_many(off, [("full", 4)], samples=1500)[0].y,
        simulate_many(wood_berry, [("full", 4)], samples=1500)[0].y,
    )
    # y(0): the plant at rest, so the measurement is noise + d(0), d from its own stream
    d0 = DisturbanceStream(disturbance, 2, 4).draw()
    np.testing.assert_allclose(disturbed.y[0] - plain.y[0], d0, rtol=0, atol=1e-15)
