"""Manual stretches in the node set: the controller plays the operator, marks MVs on u; the diagnostician reads them.

The same configuration run by the batch core and by the four nodes over DDS gives the same r, u, y, the same
modes and the same verdicts: the stretches travel to the nodes as the flat integer list a ROS parameter holds.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.node_set import NodeSetOptions, node_parameter_values, run_node_set

pytestmark = pytest.mark.ros

SAMPLES = 2560
"""Past the last stretch's end (2200) (was 4,096): the node set equals the batch at any length, and at 2,560 the batch
diagnosis is "ok", every element decided (mismatch) with parametric gains, and knowing the modes moves them by
0.1-1.7 pp (measured), far beyond ESTIMATE_TOLERANCE_PP."""
STRETCHES = [[600, 500, "reflux"], [1800, 400, 1]]
"""As a params file read by pmr-ros may nest them, with an MV's name."""

SIGNAL_TOLERANCE = 1e-12
"""r, u, y [their units]: float64 travels losslessly and both runs compute in the same order, so
nothing but an ordering difference of the arithmetic could show; none is expected."""

ESTIMATE_TOLERANCE_PP = 1e-6
"""A gain estimate [pp]: the same data give the same fit to its convergence."""


@pytest.fixture(scope="module")
def config():
    return load_config(
        overrides={
            "run": {"samples": SAMPLES, "manual_stretches": STRETCHES, "manual_move_amplitude": [0.8, 0.6]},
            "excitation": {"mv_dither_amplitude": 0.2},
            "diagnostician": {"window_samples": SAMPLES, "min_samples": 2048},
            "impact": {"samples": 0},  # not compared here (test_nodes does): 9 closed loops per verdict saved
        }
    )


def _diagnose(record, config):
    return diagnose_stretches(
        [record], model=config.model, pmr=config.pmr, parametric=config.parametric, quality=config.quality
    )


def test_the_nodes_get_the_stretches_as_a_flat_integer_list(config):
    assert node_parameter_values(config)["run.manual_stretches"] == [600, 500, 0, 1800, 400, 1]
    assert config.manual.stretches == ((600, 500, 0), (1800, 400, 1))


def test_node_set_with_manual_stretches_equals_the_batch(config, ros_domain):
    result = run_node_set(config, NodeSetOptions(domain_id=ros_domain, record=True))
    batch = simulate(config)
    for name in ("r", "u", "y"):
        got, expected = getattr(result.record, name), getattr(batch, name)
        np.testing.assert_allclose(got, expected, rtol=0, atol=SIGNAL_TOLERANCE, err_msg=name)
    np.testing.assert_array_equal(result.record.manual, batch.manual)  # the modes marked on u
    assert batch.manual[600:1100, 0].all() and batch.manual[1800:2200, 1].all() and batch.manual.sum() == 900

    expected = _diagnose(batch, config)
    blind = _diagnose(replace(batch, manual=None), config)  # the same data, the modes not known
    verdicts = {name: e.verdict for name, e in result.diagnosis.elements.items()}
    assert verdicts == {name: e.verdict for name, e in expected.elements.items()}
    for name, element in result.diagnosis.elements.items():
        got = element.parametric.gain_mismatch_pct
        want = expected.elements[name].parametric.gain_mismatch_pct
        assert got == pytest.approx(want, abs=ESTIMATE_TOLERANCE_PP), name
    # the diagnostician used the modes: without them the same data give other numbers
    moved = [
        abs(expected.elements[n].parametric.gain_mismatch_pct - blind.elements[n].parametric.gain_mismatch_pct)
        for n in expected.elements
    ]
    assert max(moved) > 100 * ESTIMATE_TOLERANCE_PP
