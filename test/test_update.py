"""Closing the loop: the corrected model, its params file, and which mismatch matters for control."""

from __future__ import annotations

import math
import signal
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.config.write import model_params_text, system_tree
from pmr_ros.core.loop.impact import control_impact, loop_figures
from pmr_ros.core.loop.update import NotCorrectable, corrected_model
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.results import ClassicResult, Diagnosis, ElementDiagnosis, ParametricResult
from pmr_ros.core.results.codec import diagnosis_from_json, diagnosis_to_json
from pmr_ros.core.sim.batch import simulate_many
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.service.closing import close_diagnosis
from pmr_ros.service.refusal import ServiceError


def _diagnose(config, record):
    return diagnose(record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric)


@pytest.fixture(scope="module")
def wood_berry_diagnosis():
    config = load_config()
    return config, _diagnose(config, simulate(config))


def _with_plant(path: Path, truth) -> Path:
    """The corrected model's file with the true plant as its plant block (a simulation of the same plant)."""
    doc = yaml.safe_load(path.read_text())
    params = doc["/**"]["ros__parameters"]
    plant = system_tree(truth)
    params["plant"] = {k: plant[k] for k in ("gain", "time_constant", "delay", "element_type")}
    params["run"].pop("scenario", None)
    out = path.with_name("corrected_on_plant.yaml")
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def test_only_mismatched_elements_change(wood_berry_diagnosis):
    config, diagnosis = wood_berry_diagnosis
    g12 = diagnosis.elements["G12"]
    ok = replace(g12.parametric, gain_verdict="ok", tau_verdict="ok", delay_verdict="ok")
    cannot_tell = replace(
        diagnosis.elements["G21"].parametric, gain_verdict="ok", tau_verdict="inconclusive", delay_verdict="ok"
    )
    elements = {
        **diagnosis.elements,
        "G12": replace(g12, parametric=ok),
        "G21": replace(diagnosis.elements["G21"], parametric=cannot_tell),
    }
    update = corrected_model(config.model, replace(diagnosis, elements=elements))
    assert [c.name for c in update.changes] == ["G11", "G22"]
    for i, k in ((0, 1), (1, 0)):  # G12 ok, G21 inconclusive: the model's own
        assert update.model.gain[i, k] == config.model.gain[i, k]
        assert update.model.time_constant[i, k] == config.model.time_constant[i, k]
        assert update.model.delay[i, k] == config.model.delay[i, k]
    p = diagnosis.elements["G11"].parametric
    np.testing.assert_allclose(update.model.gain[0, 0], 12.8 * (1 + p.gain_mismatch_pct / 100), rtol=1e-12)
    np.testing.assert_allclose(update.model.time_constant[0, 0], 16.7 * (1 + p.tau_mismatch_pct / 100), rtol=1e-12)


def test_a_corrected_model_needs_parametric_verdicts():
    config = load_config()
    models = config.model.element_models()
    with pytest.raises(NotCorrectable, match="no verdicts"):
        corrected_model(
            config.model, Diagnosis.insufficient(method="parametric", models=models, reason="short", samples=9)
        )
    classic = {
        n: ElementDiagnosis(n, i, k, m, "classic", classic=ClassicResult(1.2, 30.0, 1, True, True, True))
        for n, (i, k, m) in models.items()
    }
    with pytest.raises(NotCorrectable, match="parametric method"):
        corrected_model(config.model, Diagnosis("classic", "ok", "", 100, classic))
    unchanged = {
        n: ElementDiagnosis(n, i, k, m, "parametric", parametric=ParametricResult(reasons=("x",)))
        for n, (i, k, m) in models.items()
    }
    assert corrected_model(config.model, Diagnosis("parametric", "ok", "", 100, unchanged)).changes == ()


def test_the_model_file_reads_back_to_the_corrected_model_and_keeps_the_settings(tmp_path, wood_berry_diagnosis):
    config, diagnosis = wood_berry_diagnosis
    update = corrected_model(config.model, diagnosis)
    path = tmp_path / "corrected.yaml"
    path.write_text(
        model_params_text(update.model, settings=config.parameters, notes={c.name: c.note() for c in update.changes})
    )
    back = load_config(path)
    assert back.model.element_models() == update.model.element_models()  # lossless floats
    assert back.parameters["mpc"] == config.parameters["mpc"] and back.pmr == config.pmr
    assert back.diagnostician == config.diagnostician
    np.testing.assert_array_equal(back.mismatch.gain_pct, 0.0)  # the simulation's truth is not part of a model
    assert "# G21: K 6.6 -> " in path.read_text()


def test_the_corrected_model_matches_the_plant_and_rediagnoses_without_mismatch(tmp_path, wood_berry_diagnosis):
    config, diagnosis = wood_berry_diagnosis
    truth = config.plant()
    update = corrected_model(config.model, diagnosis)
    # within the diagnosis specification of the true plant: dK 3 pp, dtau 5 pp, dD exact
    np.testing.assert_allclose(update.model.gain / truth.gain, 1.0, atol=0.03)
    np.testing.assert_allclose(update.model.time_constant / truth.time_constant, 1.0, atol=0.05)
    np.testing.assert_array_equal(update.model.delay_samples, truth.delay_samples)
    path = tmp_path / "corrected.yaml"
    path.write_text(model_params_text(update.model, settings=config.parameters))
    again = load_config(_with_plant(path, truth), {"run": {"seed": 5}})
    assert again.plant().element_models() == truth.element_models()
    for seed, record in zip((5, 6), simulate_many(again, [("full", 5), ("full", 6)]), strict=True):
        second = _diagnose(again, record)
        assert second.status == "ok"
        assert all(e.verdict != "mismatch" for e in second), (seed, {e.name: e.summary() for e in second})


def test_impact_ranks_the_mismatches_by_what_they_do_to_control(wood_berry_diagnosis):
    config, diagnosis = wood_berry_diagnosis
    update = corrected_model(config.model, diagnosis)
    with_impact = control_impact(diagnosis, loop=config, update=update, samples=2048)
    assert diagnosis.impact is None and all(e.impact is None for e in diagnosis)  # the input is left as it was
    ranks = sorted(e.impact.rank for e in with_impact)
    assert ranks == [1, 2, 3, 4]
    first = next(e for e in with_impact if e.impact.rank == 1)
    assert first.impact.ise_ratio == max(e.impact.ise_ratio for e in with_impact)
    base = loop_figures(config, config.model, samples=2048)
    alone = loop_figures(config, update.model, samples=2048)
    np.testing.assert_allclose(with_impact.impact.ise_ratio, alone.ise / base.ise, rtol=1e-12)
    assert diagnosis_to_json(with_impact)["elements"][first.name]["impact"]["rank"] == 1
    assert diagnosis_from_json(diagnosis_to_json(with_impact)) == with_impact


def test_the_impacts_simulations_run_through_the_mapper_in_order_and_on_workers_give_the_same_figures(
    wood_berry_diagnosis,
):
    config, diagnosis = wood_berry_diagnosis
    update = corrected_model(config.model, diagnosis)
    config = replace(config, impact=replace(config.impact, samples=512))
    seen = []

    def mapper(work, tasks):
        seen.append(len(tasks))
        return [work(task) for task in reversed(tasks)][::-1]  # run out of order, returned in order

    here = control_impact(diagnosis, loop=config, update=update, samples=512)
    mapped = control_impact(diagnosis, loop=config, update=update, samples=512, mapper=mapper)
    assert seen == [len(update.changes) + 2]  # one call: the loop as modelled, each element, all together
    assert mapped == here
    on_workers = close_diagnosis(diagnosis, config, jobs=2).diagnosis  # two worker processes
    assert on_workers == close_diagnosis(diagnosis, config).diagnosis == here


def test_a_killed_impact_worker_ends_in_one_line():
    from pmr_ros.service.closing import _on_workers

    with pytest.raises(ServiceError, match=r"^control impact: a worker process ended .*\(killed\? out of memory\?\)$"):
        _on_workers(2)(signal.raise_signal, [signal.SIGKILL, signal.SIGKILL])


def test_a_plant_that_breaks_the_loop_has_an_impact_far_beyond_any_estimated_mismatch():
    config = load_config()
    wild = replace(config.model, gain=config.model.gain * np.array([[1.0, 1.0], [1.0, -3.0]]))  # G22 changes sign
    # 512 samples: the ratio is 6,500-7,900 on seeds 1-4 (7,700 at 4,096 samples, which cost 60 s of CPU)
    ise, _ = loop_figures(config, wild, samples=512).ratio_to(loop_figures(config, config.model, samples=512))
    assert ise > 100  # the input limits keep it bounded; the tracking is lost


def test_a_loop_that_blows_up_has_infinite_impact():
    config = load_config()
    unbounded = replace(
        config, mpc=replace(config.mpc, u_min=np.full(2, -1e300), u_max=np.full(2, 1e300), du_max=np.full(2, 1e300))
    )
    wild = replace(config.model, gain=config.model.gain * np.array([[1.0, 1.0], [1.0, -3.0]]))
    # infinite from 256 samples on (seeds 1-5); past the overflow each sample costs the QP many rounds
    figures = loop_figures(unbounded, wild, samples=1024)
    assert math.isinf(figures.ise) and math.isinf(
        figures.ratio_to(loop_figures(unbounded, config.model, samples=1024))[0]
    )


def test_run_writes_the_corrected_model_and_prints_the_impact(tmp_path, capsys):
    path = tmp_path / "corrected.yaml"
    assert main(["run", "--batch", "--samples", "8192", "--write-model", str(path)]) == 0
    out = capsys.readouterr().out
    assert "impact ISE" in out and "all together ISE x" in out
    model = load_config(path).model
    assert model.delay_samples[1, 0] == 9  # G21's delay 7 + the diagnosed 2


def test_write_model_refusals_are_one_line_and_come_first(tmp_path, capsys):
    code = main(
        ["run", "--batch", "--samples", "8192", "--method", "classic", "--write-model", str(tmp_path / "m.yaml")]
    )
    err = capsys.readouterr().err.strip()
    assert code == 3 and "needs the parametric method" in err and "\n" not in err
    code = main(["run", "--batch", "--samples", "100000000", "--write-model", str(tmp_path / "no" / "m.yaml")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "cannot write there" in err  # refused before the (long) run
