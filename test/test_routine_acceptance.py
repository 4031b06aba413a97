"""Routine operation on the shipped debutanizer (config/debutanizer_routine.yaml): four weeks of it, diagnosed.

Compositions at setpoints moved by operator-like steps (every few hours),
pressure and level in zones, two measured disturbances (wild feed, feed C4)
stepping at random, small MV dither, one manual stretch per MV.  The plant has
G12's gain -15 %, G21's time constant +20 %, G33's delay +1 and D11's gain
+25 % (the file's ``mismatch`` block).  Every one must be found within
specification (dK 3 pp, dtau 5 pp, dD exact), nothing else may be called a
mismatch, and no constant setpoint may refuse the diagnosis -- from the record
and from its historian export (DV columns, zone CVs without setpoint columns,
a mode tag per MV, the logged dither).  With only the rare setpoint steps (no dither, no manual
moves; the DVs still move) whatever the data cannot decide must be
``inconclusive``, never confidently wrong.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from plant_export import export_frame, export_tags

from pmr_ros.config import config_dir, load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.service.historian import diagnose_table

pytestmark = pytest.mark.slow

GAIN_PP, TAU_PP = 3.0, 5.0
"""The specification: |dK error| <= 3 percentage points, |dtau error| <= 5; dD exact."""
INJECTED = {"G12": ("gain", -15.0), "G21": ("tau", 20.0), "G33": ("delay", 1), "D11": ("gain", 25.0)}
ROUTINE = config_dir() / "debutanizer_routine.yaml"


def _diagnose(config, record):
    return diagnose_stretches(
        [record],
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        disturbance_model=config.disturbance_model,
    )


@pytest.fixture(scope="module")
def routine(shared):
    """The shipped routine month, simulated and diagnosed once per session (the ``shared`` fixture)."""
    config = load_config(ROUTINE)

    def run():
        record = simulate(config)
        return record, _diagnose(config, record)

    return config, *shared("test_routine_acceptance_debutanizer_routine_as_shipped", run)


def _within_specification(name, element):
    kind, size = INJECTED[name]
    p = element.parametric
    if kind == "gain":
        return abs(p.gain_mismatch_pct - size) <= GAIN_PP
    if kind == "tau":
        return abs(p.tau_mismatch_pct - size) <= TAU_PP
    return p.delay_mismatch_samples == size


def test_the_configuration_injects_what_this_test_checks():
    config = load_config(ROUTINE)  # the routine fixture's: its configuration, not its month of simulation
    names = config.model.element_names()
    changed = (config.mismatch.gain_pct != 0) | (config.mismatch.time_constant_pct != 0)
    changed |= config.mismatch.delay_samples != 0
    assert [names[j] for j in np.flatnonzero(changed.ravel())] == ["G12", "G21", "G33"]
    assert config.disturbance_mismatch is not None
    assert config.disturbance_mismatch.gain_pct[0, 0] == INJECTED["D11"][1]
    assert config.mismatch.gain_pct[0, 1] == INJECTED["G12"][1]
    assert config.mismatch.time_constant_pct[1, 0] == INJECTED["G21"][1]
    assert config.mismatch.delay_samples[2, 2] == INJECTED["G33"][1]


def test_four_weeks_of_routine_data_find_every_injected_change_and_nothing_else(routine):
    config, record, diagnosis = routine
    assert diagnosis.status == "ok", diagnosis.reason
    assert np.ptp(record.r[:, 2:]) == 0.0  # the zone CVs' setpoints never move: no refusal for that
    for name, element in diagnosis.elements.items():
        if name in INJECTED:
            assert element.verdict == "mismatch", (name, element.summary())
            assert _within_specification(name, element), (name, element.summary())
        else:
            assert element.verdict != "mismatch", (name, element.summary())
    decided = [n for n, e in diagnosis.elements.items() if e.verdict == "ok"]
    assert len(decided) >= 0.8 * len(diagnosis.elements)  # routine data decide most elements, not a few


def test_the_historian_export_of_the_run_gives_the_same_verdicts(routine, tmp_path):
    config, record, direct = routine
    tags = export_tags(config, dither=True)  # the dither a step tester adds is logged (else it is no instrument)
    assert "" in tags.r and len(tags.modes) == config.model.n_inputs and len(tags.dv) == 2
    path = tmp_path / "debutanizer.csv"
    export_frame(record, tags).to_csv(path, index=False)
    block = tags.data_block()
    data = replace(
        config.data,
        time_column=block["time_column"],
        time_unit_s=block["time_unit_s"],
        setpoint_columns=tags.r,
        input_columns=tags.u,
        output_columns=tags.y,
        disturbance_columns=tags.dv,
        dither_columns=tags.dither,
        mode_columns=tags.modes,
        mode_on_values=("AUTO",),
    )
    found = diagnose_table(path, replace(config, data=data)).diagnosis
    assert found.status == "ok", found.reason
    assert list(found.elements) == list(direct.elements)
    for name, element in found.elements.items():
        if name in INJECTED:
            assert element.verdict == "mismatch" and _within_specification(name, element), (name, element.summary())
        else:
            assert element.verdict != "mismatch", (name, element.summary())
    agree = sum(found.elements[n].verdict == e.verdict for n, e in direct.elements.items())
    assert agree >= 0.9 * len(direct.elements)  # the export's cleaning may cut a few stretches, no more


def test_rare_setpoint_steps_alone_are_never_confidently_wrong():
    overrides = {"excitation": {"mv_dither_amplitude": 0.0}, "run": {"samples": 14 * 24 * 60, "manual_stretches": []}}
    config = load_config(ROUTINE, overrides=overrides)
    record = simulate(config)
    assert record.manual is None or not record.manual.any()
    diagnosis = _diagnose(config, record)
    assert diagnosis.status in ("ok", "insufficient_data"), diagnosis.reason
    inconclusive = 0
    for name, element in diagnosis.elements.items():
        if element.verdict == "inconclusive":
            inconclusive += 1
            assert element.all_reasons, name  # says why (and what to add)
        elif element.verdict == "mismatch":
            assert name in INJECTED and _within_specification(name, element), (name, element.summary())
    assert inconclusive > 0  # two weeks of rare steps cannot decide everything a dithered month does
