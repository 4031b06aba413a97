"""Closing the loop in the node set: the corrected model re-run, and the live update with its rollback."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from shipped import without_impact

from pmr_ros.bag.reader import open_bag
from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.config.write import system_tree
from pmr_ros.contract.layout import read_signal
from pmr_ros.contract.model_topics import read_active_model
from pmr_ros.contract.topics import topic
from pmr_ros.service.bag_diagnosis import diagnose_bag

WINDOW = 4096
"""One window of the adapted runs (was 8,192).  Measured with the batch core (the node set's data equal it):
the corrected model from 4,096 samples of the full-mismatch run is within dK 1.1 % and dtau 1.3 % of the true
plant on Wood-Berry, 1.4 % and 1.2 % on the 3x3 (8,192: 0.8/0.8 %, 1.7/1.8 %), against the 3 % and 5 % checked.
Adapted runs (node set, twice each): the switch at sample 4129..4162, the after window 5120..9215, no mismatch in it;
tracking error per sample 2.41 -> 1.95 on Wood-Berry, 4.113 -> 4.050 on the 3x3 (8,192: 4.16 -> 3.99): the 3x3's
margin is thin (1.5 %) but the figures came out the same to every digit in both runs."""

WRONG_WINDOW = 1024
"""One window of the run whose update is deliberately wrong (was WINDOW, 4,096: 28 s of a worker, now ~8 s).  Measured
(node set, seeds 1, 2 and 3): after the wrong update the largest mismatch is 68.2 / 68.1 / 71.5 % against 17.8 / 15.4 /
14.9 % before, the update judged worse and rolled back at sample 2321 / 2330 / 2324, after the window 1280..2303 (at
2,048 and seed 1: 68.2 against 16.7 %)."""


def _run(tmp_path: Path, name: str, *args: str) -> dict:
    out = tmp_path / f"{name}.json"
    assert main(["run", "--samples", str(WINDOW), "--json", str(out), *args]) == 0
    return json.loads(out.read_text())


def _on_plant(path: Path, truth, seed: int) -> Path:
    """The written model's file with the true plant as its plant block: new data from the same plant."""
    doc = yaml.safe_load(path.read_text())
    params = doc["/**"]["ros__parameters"]
    plant = system_tree(truth)
    params["plant"] = {k: plant[k] for k in ("gain", "time_constant", "delay", "element_type")}
    params["run"] = {**params.get("run", {}), "seed": seed}
    params["run"].pop("scenario", None)
    out = path.with_name(f"{path.stem}_on_plant.yaml")
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


@pytest.mark.parametrize("system", [None, "config/three_by_three.yaml"], ids=["wood_berry", "three_by_three"])
def test_the_written_model_of_a_node_set_run_rediagnoses_without_mismatch(tmp_path, ros_domain, system):
    config = load_config(system)
    truth = config.plant("full")
    written = tmp_path / "corrected.yaml"
    first = _run(tmp_path, "first", "--write-model", str(written), "--config", str(without_impact(tmp_path, system)))
    assert first["path"] == "nodes" and any(e["verdict"] == "mismatch" for e in first["elements"].values())
    corrected = load_config(written).model
    # within the diagnosis specification of the true plant: dK 3 pp, dtau 5 pp, dD exact
    np.testing.assert_allclose(corrected.gain / truth.gain, 1.0, atol=0.03)
    np.testing.assert_allclose(corrected.time_constant / truth.time_constant, 1.0, atol=0.05)
    np.testing.assert_array_equal(corrected.delay_samples, truth.delay_samples)
    # new data from the true plant: the batch core gives the node set's data (test_nodes), at a fraction of the time
    again = _run(tmp_path, "again", "--batch", "--config", str(_on_plant(written, truth, seed=7)))
    assert [n for n, e in again["elements"].items() if e["verdict"] == "mismatch"] == [], again["elements"]


@pytest.mark.parametrize("system", [None, "config/three_by_three.yaml"], ids=["wood_berry", "three_by_three"])
def test_adapt_finds_the_mismatch_updates_the_controller_and_tracks_better(tmp_path, ros_domain, capsys, system):
    # Wood-Berry runs in a namespace and is recorded (one adapted run serves both tests: they cost a minute each)
    where = [] if system else ["--namespace", "column_a", "--bag", str(tmp_path / "adapted")]
    report = _run(tmp_path, "adapt", "--adapt", "--config", str(without_impact(tmp_path, system)), *where)
    adaptation = report["adaptation"]
    before = adaptation["before"]["elements"]
    assert all(e["verdict"] == "mismatch" for e in before.values() if e["model"]["kind"] != "none")
    assert {c["element"] for c in adaptation["changes"]} == set(before)
    assert adaptation["before_window"] == [0, WINDOW - 1]
    assert adaptation["after_window"][0] >= adaptation["switch_sample"] > WINDOW - 1
    assert [n for n, e in report["elements"].items() if e["verdict"] == "mismatch"] == [], report["elements"]
    tracking = adaptation["tracking"]
    assert tracking["after"]["ise_per_sample"] < tracking["before"]["ise_per_sample"]
    assert not adaptation["worse"] and not adaptation["rolled_back"]
    truth = load_config(system).plant("full")
    updated = {c["element"]: c["after"] for c in adaptation["changes"]}
    for j, name in enumerate(truth.element_names()):
        i, k = divmod(j, truth.n_inputs)
        np.testing.assert_allclose(updated[name]["gain"] / truth.gain[i, k], 1.0, atol=0.03)
        assert updated[name]["delay_samples"] == truth.delay_samples[i, k]
    printed = capsys.readouterr().out
    assert "live model update (--adapt)" in printed and "the update stays" in printed
    if system is None:
        _check_the_namespaced_recording(tmp_path / "adapted", report)


def test_a_wrong_update_is_caught_and_rolled_back(ros_domain):
    from pmr_ros.node_set import NodeSetOptions, run_node_set
    from pmr_ros.nodes.adapter import ModelAdapter
    from pmr_ros.service.adapted_run import adapted_report, run_adapted

    config = load_config(
        overrides={"run": {"samples": WRONG_WINDOW}, "impact": {"samples": 0}}
    )  # shipped.without_impact

    def wrong(block: dict) -> dict:
        """The proposal with every gain 40 % low: a deliberately wrong model."""
        return {**block, "gain": [0.6 * g for g in block["gain"]]}

    def options(**kwargs):
        return NodeSetOptions(private=True, **kwargs)

    _, adapter = run_adapted(config, options, run_node_set, adapter_type=ModelAdapter, proposal_filter=wrong)
    final, adaptation = adapted_report(adapter)
    assert adaptation["worse"] and adaptation["rolled_back"]
    assert "a larger mismatch" in " ".join(adaptation["reasons"])
    assert adaptation["rollback_sample"] > adaptation["after_window"][1]
    assert any(e.verdict == "mismatch" for e in final)  # the wrong model's verdicts, reported
    # the controller is back on the model it started with
    assert adapter.models[-1][1] == system_tree(config.model) and len(adapter.models) == 3


def _check_the_namespaced_recording(bag: Path, report: dict) -> None:
    """An adapted run in /column_a updated that set's controller, and its bag holds the model topics."""
    adaptation = report["adaptation"]
    recorded = open_bag(bag)
    assert recorded.topics and all(name.startswith("/column_a/") for name in recorded.topics), recorded.topics
    on_wire = recorded.messages({topic("active_model").resolved("/column_a")})
    models = [read_active_model(recorded.decode(m).data, "bag") for m in on_wire]
    assert [m.revision for m in models] == [0, 1] and models[1].first_sample == adaptation["switch_sample"]
    proposals = [recorded.decode(m).data for m in recorded.messages({topic("proposed_model").resolved("/column_a")})]
    assert proposals and f"(samples 0..{WINDOW - 1})" in proposals[0]
    # the recording covers the whole adapted run (3 windows), every sample of y
    y = [
        read_signal(recorded.decode(m))[0] for m in recorded.messages({topic("measured_output").resolved("/column_a")})
    ]
    assert [round(stamp) for stamp in y] == list(range(3 * WINDOW))
    # offline, the bag is diagnosed as the live diagnostician did: against the model the controller switched to,
    # on the samples from the switch on
    offline = diagnose_bag(recorded)
    assert offline.comparisons and offline.all_equal, offline.comparisons
    final = offline.final_diagnosis
    assert {e.name: e.verdict for e in final} == {n: e["verdict"] for n, e in report["elements"].items()}
    assert not any(e.verdict == "mismatch" for e in final)
