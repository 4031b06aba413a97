"""CV zones and limits: no tracking inside the zone, a soft penalty outside; setpoint steps move setpoint CVs only."""

from __future__ import annotations

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.mpc.zones import zone_points
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.excitation import PrbsGenerator
from pmr_ros.core.sim.operation import RandomSignal, setpoint_generator

G1 = np.array([12.8, -18.9])  # Wood-Berry's x_D row
G2 = np.array([6.6, -19.4])  # its x_B row


def _loop(zone_low: float, zone_high: float, **mpc):
    """Wood-Berry, plant = model, no noise: x_D at setpoint 1, x_B a zone CV."""
    return load_config(
        overrides={
            "run": {"scenario": "none", "samples": 800},
            "noise": {"std": 0.0},
            "prbs": {"amplitude": 0.0, "nominal": [1.0, 0.0]},
            "mpc": {"output_mode": ["setpoint", "zone"], "output_low": [-np.inf, zone_low], **mpc}
            | {"output_high": [np.inf, zone_high]},
        }
    )


def _free_steady_state() -> float:
    """x_B where the input targets put the inputs among the steady states with x_D = 1 (S = I): closed form."""
    u = G1 / (G1 @ G1)  # the least-norm u with G1 u = 1
    return float(G2 @ u)


def test_a_zone_cv_inside_its_zone_is_not_tracked():
    free = _free_steady_state()  # 0.866: inside [-1, 1], away from its r = 0
    record = simulate(_loop(-1.0, 1.0))
    np.testing.assert_allclose(record.y[-1], [1.0, free], atol=1e-4)
    np.testing.assert_array_equal(record.r[:, 1], 0.0)


def test_a_zone_cv_is_held_at_its_zone_when_it_would_leave_it():
    config = _loop(-0.5, 0.5, zone_weight=[1.0, 1000.0])
    record = simulate(config)
    y1, y2 = record.y[-1]
    # the target calculation puts the steady state at the zone's edge, the setpoint met
    np.testing.assert_allclose([y1, y2], [1.0, 0.5], atol=1e-6)
    free = simulate(_loop(-1.0, 1.0))
    assert free.y[-1, 1] > 0.85  # without the binding zone it rests where the input targets put it


def test_the_zone_qp_equals_the_fast_path_when_nothing_binds_and_solves_it_when_something_does():
    config = _loop(-0.5, 0.5)
    fast = LinearMpc(config.model, config.mpc)
    exact = LinearMpc(config.model, config.mpc, always_solve_qp=True)
    rng = np.random.default_rng(2)
    for _ in range(40):
        y, r = rng.normal(scale=0.3, size=2), np.array([rng.normal(scale=0.3), 0.0])
        np.testing.assert_allclose(fast.step(y, r), exact.step(y, r), rtol=0, atol=1e-8)
    assert fast.statistics.solves < exact.statistics.solves and exact.statistics.solves >= 40


def test_zone_points_reach_the_end_of_the_horizon():
    assert zone_points(40).tolist() == [4, 8, 12, 16, 20, 24, 28, 32, 36, 40]
    assert zone_points(3).tolist() == [1, 2, 3]


def test_without_zones_the_setpoints_are_the_prbs_itself(wood_berry):
    assert isinstance(setpoint_generator(wood_berry.prbs, 3), PrbsGenerator)
    held = setpoint_generator(wood_berry.prbs, 3, moving=np.array([True, False])).sequence(4000)
    np.testing.assert_array_equal(held[:, 0], PrbsGenerator(wood_berry.prbs, 3).sequence(4000)[:, 0])
    np.testing.assert_array_equal(held[:, 1], wood_berry.prbs.nominal[1])


def test_setpoint_steps_are_operator_like_and_move_only_setpoint_cvs():
    config = load_config(
        overrides={
            "prbs": {"mode": "steps", "step_interval_samples": 200.0, "step_amplitude": [0.5, 2.0], "nominal": 1.0},
            "mpc": {"output_mode": ["setpoint", "zone"], "output_low": [-np.inf, -3.0], "output_high": [np.inf, 3.0]},
        }
    )
    moving = ~config.mpc.zone_outputs
    r = setpoint_generator(config.prbs, 7, moving=moving).sequence(200_000)
    changes = np.flatnonzero(np.diff(r[:, 0]))
    intervals = np.diff(changes)
    assert abs(intervals.mean() / 200.0 - 1.0) < 0.1  # mean of exponential intervals (about 1000 of them)
    assert np.all(np.abs(r[:, 0] - 1.0) <= 0.5) and np.ptp(r[:, 0]) > 0.9
    np.testing.assert_array_equal(r[:, 1], 1.0)  # the zone CV's setpoint stays at its nominal
    # stateless in k: any sample asked alone is the sequence's
    again = setpoint_generator(config.prbs, 7, moving=moving)
    np.testing.assert_array_equal(again.value(150_000), r[150_000])


@pytest.mark.parametrize("kind", ["steps", "walk", "prbs"])
def test_random_signals_have_their_amplitude_and_interval(kind):
    signal = RandomSignal([kind], [2.0], [50.0], [0.5], seed=4, stream=11)
    x = signal.sequence(100_000)[:, 0] - 0.5
    if kind == "walk":
        np.testing.assert_allclose(x.std(), 2.0, rtol=0.15)  # stationary std = amplitude
        lag = 50
        rho = np.corrcoef(x[:-lag], x[lag:])[0, 1]
        np.testing.assert_allclose(rho, np.exp(-1.0), atol=0.1)  # correlation time = mean interval
    else:
        switches = np.count_nonzero(np.diff(x))
        np.testing.assert_allclose(100_000 / switches, 50.0, rtol=0.1)
        assert np.max(np.abs(x)) <= 2.0
        if kind == "prbs":
            np.testing.assert_array_equal(np.unique(x), [-2.0, 2.0])
