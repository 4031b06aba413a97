"""A routine run with DVs, dither and manual stretches, diagnosed from its historian export as from the record.

The run (the configured Wood-Berry MPC on a plant with G11's gain +10 %, D11's
+20 % and an effect of feed_comp on x_B the model lacks; :mod:`routine_loop`)
is exported with DV columns, dither columns and a mode tag per MV
(:func:`plant_export.export_frame`), read back and diagnosed by the historian
service: the same verdicts as the record itself, every number within a tenth
of its interval.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import routine_loop
from plant_export import export_frame, export_tags

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.model import Mismatch, TransferMatrix
from pmr_ros.service.historian import diagnose_table

SAMPLES = 16384
MANUAL = ((3000, 1500, 0), (9000, 1500, 1))
"""(start, length, MV): one manual stretch per MV."""
DV_MODEL = TransferMatrix(
    [[3.0, 2.0], [1.5, 0.0]],
    [[12.0, 8.0], [9.0, 1.0]],
    [[2.0, 1.0], [3.0, 0.0]],
    1.0,
    input_names=("feed", "feed_comp"),
    element_type=[["foptd", "foptd"], ["foptd", "none"]],
)
DV_PLANT = TransferMatrix(
    [[3.6, 2.0], [1.5, 1.0]],
    [[12.0, 8.0], [9.0, 6.0]],
    [[2.0, 1.0], [3.0, 2.0]],
    1.0,
    input_names=("feed", "feed_comp"),
)


@pytest.fixture(scope="module")
def run():
    config = replace(load_config(), disturbance_model=DV_MODEL)
    gain = np.array([[10.0, 0.0], [0.0, 0.0]])
    plant = config.model.with_mismatch(Mismatch(gain, np.zeros((2, 2)), np.zeros((2, 2), dtype=int)))
    routine = routine_loop.Routine(dither=np.array([0.2, 0.2]), dv_amplitude=0.1, manual=MANUAL, manual_amplitude=0.1)
    record = routine_loop.routine_run(config, plant, routine, samples=SAMPLES, seed=6, disturbances=DV_PLANT)
    return config, record


def test_the_export_of_a_routine_run_gives_the_records_verdicts(tmp_path, run):
    config, record = run
    tags = export_tags(config, dither=True)
    path = tmp_path / "routine.csv"
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
    found = diagnose_table(path, replace(config, data=data))
    (stretch,) = found.stretches
    assert np.array_equal(stretch.manual, record.manual) and stretch.dv.shape == (SAMPLES, 2)
    direct = diagnose_stretches(
        [record], model=config.model, pmr=config.pmr, parametric=config.parametric, disturbance_model=DV_MODEL
    )
    mine = found.diagnosis
    assert mine.status == direct.status == "ok"
    assert list(mine.elements) == list(direct.elements) == ["G11", "G12", "D11", "D12", "G21", "G22", "D21", "D22"]
    for name, theirs in direct.elements.items():
        ours = mine.elements[name]
        assert ours.verdict == theirs.verdict, (name, ours.summary(), theirs.summary())
        p, q = ours.parametric, theirs.parametric
        if q.gain_mismatch_pct_interval is not None:
            width = q.gain_mismatch_pct_interval[1] - q.gain_mismatch_pct_interval[0]
            np.testing.assert_allclose(p.gain_mismatch_pct, q.gain_mismatch_pct, atol=0.1 * width, err_msg=name)
    d11 = mine.elements["D11"].parametric
    assert d11.verdict == "mismatch" and abs(d11.gain_mismatch_pct - 20.0) <= 3.0
    assert abs(mine.elements["G11"].parametric.gain_mismatch_pct - 10.0) <= 3.0
    for name in ("G12", "G21", "G22", "D12", "D21"):
        assert mine.elements[name].verdict == "ok", (name, mine.elements[name].summary())
