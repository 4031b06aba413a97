"""The node set on step-response curves controlling a tf plant: the batch's numbers, sample for sample.

The plant node simulates the tf plant, the controller predicts with the
curves of a ``model_file`` named relative to the params file (the nodes read
it wherever they run), and the records equal the pure core's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from ros_fixtures import claimed_domain, ros_environment  # noqa: E402
from test_general_config import STEP_CONFIG, TF_CONFIG, _write_mdl

from pmr_ros.config import load_config
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.node_set import NodeSetOptions, run_node_set  # noqa: E402

pytestmark = pytest.mark.ros


def test_the_node_set_runs_curves_on_a_tf_plant_as_the_batch_does(tmp_path, monkeypatch):
    _write_mdl(tmp_path / "curves" / "unit.mdl")
    plant = TF_CONFIG.split("    system:\n")[1].split("    mpc:")[0]
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG.replace("    mpc:", "    plant:\n" + plant + "    mpc:"))
    monkeypatch.chdir(tmp_path / "curves")  # the nodes must not read model_file relative to where they run
    config = load_config(tmp_path / "unit.yaml")
    with claimed_domain() as domain, pytest.MonkeyPatch.context() as mp:
        for key, value in ros_environment(domain).items():
            mp.setenv(key, value)
        short = replace(config, run=replace(config.run, samples=1200))
        run = run_node_set(short, NodeSetOptions(domain_id=domain, record=True))
    batch = simulate(short)
    assert run.record is not None
    assert np.array_equal(run.record.u, batch.u)
    assert np.array_equal(run.record.y, batch.y)
    assert list(config.plant().element_type.ravel()) == ["tf"] * 4


def test_the_node_set_runs_a_tf_dv_model_as_the_batch_does(tmp_path):
    from test_general_disturbances import CONFIG

    (tmp_path / "dv.yaml").write_text(CONFIG + "    mismatch:\n      disturbance_gain_pct: [20.0, 0.0]\n")
    config = load_config(tmp_path / "dv.yaml")
    assert config.disturbance_model is not None and config.disturbance_model.element_type[0, 0] == "tf"
    with claimed_domain() as domain, pytest.MonkeyPatch.context() as mp:
        for key, value in ros_environment(domain).items():
            mp.setenv(key, value)
        short = replace(config, run=replace(config.run, samples=600, scenario="full"))
        run = run_node_set(short, NodeSetOptions(domain_id=domain, record=True))
    batch = simulate(short)
    assert run.record is not None and batch.dv is not None and np.ptp(batch.dv) > 1.5  # the DV moves the plant
    assert np.array_equal(run.record.u, batch.u)  # the MPC's feedforward from the tf DV model, sample for sample
    assert np.array_equal(run.record.y, batch.y)
