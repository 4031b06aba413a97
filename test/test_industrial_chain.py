"""The whole chain on an industrial shape: node set, bag, ``pmr-ros diagnose`` and the reports.

The system (test/configs/level_temperature.yaml) has more MVs than CVs, an
integrating CV (a level), two empty cells and MV dither.  What the diagnosis
finds in it is checked elsewhere; here: every stage runs on this shape, the
node set gives the batch core's data sample for sample, and every element is
reported everywhere, with its model kind.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from ros_fixtures import claimed_domain, ros_environment
from shipped import with_impact_samples

from pmr_ros.bag.reader import open_bag
from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.contract.topics import topic
from pmr_ros.core.sim.closed_loop import simulate

pytestmark = pytest.mark.ros

CONFIG = Path(__file__).parent / "configs" / "level_temperature.yaml"
SAMPLES = 3000
ELEMENTS = {"G11": "integrating", "G12": "integrating", "G13": "none", "G21": "foptd", "G22": "none", "G23": "foptd"}
VERDICTS = {"ok", "mismatch", "inconclusive"}


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """``pmr-ros run`` (the four nodes) recording a bag, then ``pmr-ros diagnose`` of that bag (its table printed)."""
    folder = tmp_path_factory.mktemp("chain")
    with claimed_domain() as domain, pytest.MonkeyPatch.context() as mp:
        for key, value in ros_environment(domain).items():
            mp.setenv(key, value)
        # the control impact's simulations of 1,024 samples, not 4,096: the run's and the diagnosis's are compared,
        # equal at any length
        config = with_impact_samples(folder, 1024, CONFIG)
        argv = ["run", "--config", str(config), "--samples", str(SAMPLES), "--bag", str(folder / "bag")]
        assert main([*argv, "--json", str(folder / "run.json")]) == 0
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):  # the table it prints, read by a test (one diagnosis, not two)
        assert main(["diagnose", str(folder / "bag"), "--json", str(folder / "diagnose.json")]) == 0
    (folder / "diagnose.txt").write_text(printed.getvalue())
    return folder


def _signal(bag, key: str) -> np.ndarray:
    """The values of a recorded signal topic, in stamp order, one row per sample."""
    rows = []
    for message in bag.messages({topic(key).resolved()}):
        msg = bag.decode(message)
        rows.append((msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec, np.asarray(msg.position)))
    return np.array([values for _, values in sorted(rows, key=lambda row: row[0])])


def test_the_node_set_runs_a_non_square_system_with_a_level_like_the_batch(chain):
    config = load_config(CONFIG)
    bag = open_bag(chain / "bag")
    assert bag.complete
    batch = simulate(config, samples=SAMPLES)
    for key, expected in (("setpoint", batch.r), ("manipulated_input", batch.u), ("measured_output", batch.y)):
        recorded = _signal(bag, key)
        assert recorded.shape == expected.shape, key
        assert np.array_equal(recorded, expected), key  # same core, same arithmetic: sample for sample
    assert batch.dither is not None  # the controller node added the same dither as the batch core


def test_the_run_report_lists_every_element_with_its_model_kind(chain):
    report = json.loads((chain / "run.json").read_text())
    assert report["status"] == "ok" and report["samples"] == SAMPLES
    assert {name: e["model"]["kind"] for name, e in report["elements"].items()} == ELEMENTS
    assert all(e["verdict"] in VERDICTS for e in report["elements"].values())
    assert set(report["injected"]) == set(ELEMENTS)


def test_pmr_ros_diagnose_of_the_bag_reports_every_element_as_the_node_set_did(chain):
    offline = json.loads((chain / "diagnose.json").read_text())
    live = json.loads((chain / "run.json").read_text())
    assert set(offline["elements"]) == set(ELEMENTS)
    assert offline["elements"] == live["elements"]  # one machine, one bag: the live diagnostician's verdicts exactly
    table = (chain / "diagnose.txt").read_text().splitlines()
    for name in ELEMENTS:
        assert any(line.startswith(f"{name} ") for line in table), name
