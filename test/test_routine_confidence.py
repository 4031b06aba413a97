"""Rare setpoint steps and moving DVs, no dither: never confidently wrong, and a real change still found.

Wood-Berry with an exact DV model (:data:`test_data_routine_diagnosis.DV_MODEL`),
8,192 samples (15 Welch segments, four step-like instruments).  Before the
finite-segment bias of the instrumental equations was taken out
(:mod:`pmr_ros.core.pmr.parametric.bias`) and the delay likelihood tempered by
the Welch bins' correlation, every one of these seeds gave ``mismatch`` where
nothing was mismatched (mostly every delay of a row ``+1`` with 98-100 % confidence).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from routine_loop import Routine, routine_run
from test_data_routine_diagnosis import DV_MODEL

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.model import Mismatch

SEEDS = range(1, 7)
SAMPLES = 8192
ROUTINE = Routine(dither=np.zeros(2), dv_amplitude=0.1, setpoint_steps=0.3)
GAIN_PP = 3.0
"""The gain specification: within 3 percentage points of the injected change."""


@pytest.fixture(scope="module")
def config():
    return replace(load_config(), disturbance_model=DV_MODEL)


def _diagnosis(config, plant, seed):
    record = routine_run(config, plant, ROUTINE, samples=SAMPLES, seed=seed, disturbances=DV_MODEL)
    return diagnose_stretches(
        [record], model=config.model, pmr=config.pmr, parametric=config.parametric, disturbance_model=DV_MODEL
    )


@pytest.mark.parametrize("seed", SEEDS)
def test_no_mismatch_is_never_called_a_mismatch(config, seed):
    d = _diagnosis(config, config.model, seed)
    assert d.status == "ok", d.reason
    for e in d:
        assert e.verdict in ("ok", "inconclusive"), (seed, e.name, e.summary())
        p = e.parametric
        if p.delay_verdict is not None:
            assert p.delay_verdict != "mismatch", (seed, e.name, e.summary())


def _g12_plant(config):
    """The plant with G12's gain -20 %."""
    gain = np.zeros((2, 2))
    gain[0, 1] = -20.0
    return config.model.with_mismatch(Mismatch(gain, np.zeros((2, 2)), np.zeros((2, 2), dtype=int)))


def test_an_injected_gain_change_is_still_found(config):
    plant = _g12_plant(config)
    found = 0
    for seed in SEEDS:
        d = _diagnosis(config, plant, seed)
        g12 = d.elements["G12"].parametric
        assert g12.verdict != "ok", (seed, g12.summary())
        np.testing.assert_allclose(g12.gain_mismatch_pct, -20.0, atol=GAIN_PP, err_msg=f"seed {seed}")
        found += g12.gain_verdict == "mismatch"
        for e in d:
            assert e.name == "G12" or e.verdict != "mismatch", (seed, e.name, e.summary())
    # the other seeds: G11 and G12 move together (rare steps only) and G12 is inconclusive, with that reason
    assert found >= 4


def test_a_dv_elements_tau_is_judged_over_the_delays_the_data_leave_open(config):
    """Seed 7: D21 barely excited (2 % of its row's driven output), its delay +1 at 80 %, tau -17 % there.

    At its true delay tau fits -3 %.  The tau interval mixes one component per delay of D21 (the profile
    likelihood, as the delay's confidence): weighing every delay vector tried gave delay +1 five components
    (the empty D22 cell's delay varied over four equivalent values with it) and the truth one, and
    [-29, -7] % called a mismatch.
    """
    d = _diagnosis(config, _g12_plant(config), 7)
    d21 = d.elements["D21"].parametric
    assert d21.delay_verdict == "inconclusive" and d21.tau_verdict == "inconclusive", d21.summary()
    low, high = d21.tau_mismatch_pct_interval
    assert low < -17.0 < high and high > -5.0  # within the tolerance of the truth's 0
    assert d.elements["G12"].parametric.gain_verdict == "mismatch"
    assert [e.name for e in d if e.verdict == "mismatch"] == ["G12"]
