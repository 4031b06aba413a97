"""The control impact in routine operation: DVs fed forward through Gd, a zone CV counted outside its zone.

Wood-Berry with one measured disturbance (feed rate) and x_B a zone CV (|x_B| <= 1); setpoints of x_D
step rarely; no dither, so every difference between two loops is the plant's.
"""

from __future__ import annotations

import numpy as np
import pytest
from routine_cases import FEED_RATE_ZONE, gain_only_fit

from pmr_ros.config import load_config
from pmr_ros.core.loop.impact import control_impact, loop_figures, weighted_errors
from pmr_ros.core.loop.update import corrected_model
from pmr_ros.core.results import Diagnosis, ElementDiagnosis, ParametricResult
from pmr_ros.core.sim.augment import augmented_model
from pmr_ros.core.sim.closed_loop import simulate

SAMPLES = 1024
RATIO_TOLERANCE = 1e-12
"""An estimate equal to the model gives the very loop of the model: only rounding could differ."""


@pytest.fixture(scope="module")
def config():
    return load_config(
        overrides={
            "run": {"samples": SAMPLES},
            "noise": {"std": 0.0},
            "mismatch": {"gain_pct": 0.0, "time_constant_pct": 0.0, "delay_samples": 0},
            **FEED_RATE_ZONE,
        }
    )


def _fit(gain_pct: float | None) -> ParametricResult:
    return gain_only_fit(gain_pct or 0.0, mismatch=gain_pct is not None, half_width_pct=1.0)


def _impact(config, **gain_pct: float) -> Diagnosis:
    """The impact of verdicts with these elements' gains mismatched (by that many %), the others ok."""
    models = augmented_model(config.model, config.disturbance_model).element_models()
    elements = {
        name: ElementDiagnosis(name, i, k, model, "parametric", parametric=_fit(gain_pct.get(name)))
        for name, (i, k, model) in models.items()
    }
    diagnosis = Diagnosis("parametric", "ok", "", 8192, elements)
    update = corrected_model(config.model, diagnosis, disturbance_model=config.disturbance_model)
    return control_impact(diagnosis, loop=config, update=update, samples=SAMPLES)


def test_weighted_errors_count_a_zone_cv_only_outside_its_zone(config):
    r = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    y = np.array([[0.5, 0.4], [1.0, 1.5], [2.0, -1.2]])  # x_B inside, 0.5 above, 0.2 below its zone
    expected = np.array([[0.25, 0.0], [0.0, 10.0 * 0.25], [1.0, 10.0 * 0.04]])  # Q = 1, zone_weight = 10
    np.testing.assert_allclose(weighted_errors(config.mpc, r, y), expected, rtol=1e-12)


def test_the_impact_loop_moves_the_dvs_and_counts_the_zone_as_the_run_does(config):
    # the configured run on a plant equal to the model, noise-free, is the impact's base loop
    run = simulate(config, samples=SAMPLES)
    assert np.ptp(run.dv) > 0.4  # the DVs move
    outside = np.maximum(-1.0 - run.y[:, 1], 0.0) + np.maximum(run.y[:, 1] - 1.0, 0.0)
    ise = np.sum((run.r[:, 0] - run.y[:, 0]) ** 2) + 10.0 * np.sum(outside**2)
    figures = loop_figures(config, config.model, samples=SAMPLES)
    np.testing.assert_allclose(figures.ise, ise, rtol=1e-9)


def test_estimates_equal_to_the_model_have_no_impact(config):
    found = _impact(config, D11=0.0, G21=0.0)
    for name in ("D11", "G21"):  # a D element's impact is simulated too (the feedforward's)
        impact = found.elements[name].impact
        assert impact is not None, name
        np.testing.assert_allclose([impact.ise_ratio, impact.input_movement_ratio], 1.0, rtol=0, atol=RATIO_TOLERANCE)
    assert found.elements["G11"].impact is None  # ok elements are not simulated


def test_a_feedforward_gain_error_raises_the_error_more_the_larger_it_is(config):
    ratios = {pct: _impact(config, D11=pct).elements["D11"].impact.ise_ratio for pct in (-30.0, 15.0, 30.0)}
    assert ratios[-30.0] > 1.0 and 1.0 < ratios[15.0] < ratios[30.0], ratios
    # a G element's with the DVs moving and fed forward: a weaker plant, a slower loop; a stronger, a faster one
    weaker, stronger = (_impact(config, G11=pct).elements["G11"].impact for pct in (-30.0, 30.0))
    assert weaker.ise_ratio > 1.0 > stronger.ise_ratio and stronger.input_movement_ratio > 1.0, (weaker, stronger)
