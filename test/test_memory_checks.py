"""Memory before work where ``pmr-ros run`` does not check first: the nodes on their own and the control impact.

A plant delay of 10^6 samples (a 7 TB state matrix) or a model too large is
refused in one line before anything is allocated (issue 21, item 7); the
available memory is set by the test where the machine would have enough.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from plant_export import DATA_BLOCK, clean_frame

from pmr_ros import cli
from pmr_ros.config import ConfigError, config_dir, load_config
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.footprint import controller_bytes, impact_bytes, realization_bytes, states
from pmr_ros.service.memory_checks import (
    check_controller_memory,
    check_impact_memory,
    check_plant_memory,
    impact_shortfall,
)

FAR = "delay_samples: [1000000, 1, 2, 0]"
AVAILABLE = "pmr_ros.core.sim.memory.available_bytes"


def _far_delay_file(tmp_path: Path) -> Path:
    """Wood-Berry whose delay scenario adds 10^6 samples to G11's delay, run.scenario delay."""
    text = (config_dir() / "wood_berry.yaml").read_text().replace("delay_samples: [0, 1, 2, 0]", FAR)
    text += "    run:\n      scenario: delay\n"
    path = tmp_path / "far_delay.yaml"
    path.write_text(text)
    return path


def test_a_plant_of_a_million_delay_samples_is_refused_naming_its_states(tmp_path):
    config = load_config(_far_delay_file(tmp_path))
    assert states(config.plant()) == 4 + (1 + 1000000) + (3 + 1)  # elements, then each input's longest delay
    with pytest.raises(ConfigError) as err:
        check_plant_memory(config, "parameters of node /plant")
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("parameters of node /plant: plant: the simulated 2x2 plant (the model with run.scenario")
    assert "has 1000009 states" in message and "TB of memory" in message
    check_plant_memory(load_config(), "x")  # Wood-Berry: 14 states


def test_the_controller_and_impact_checks_refuse_what_does_not_fit(monkeypatch, wood_berry):
    tuning = wood_berry.mpc
    horizons = {"prediction_horizon": tuning.prediction_horizon, "control_horizon": tuning.control_horizon}
    controller = controller_bytes(wood_berry.model, **horizons)
    impact = impact_bytes(wood_berry.model, wood_berry.model, samples=wood_berry.impact.samples, **horizons)
    assert impact > controller + realization_bytes(wood_berry.model)
    monkeypatch.setattr(AVAILABLE, lambda: controller - 1)
    with pytest.raises(ConfigError, match=r"system: the 2x2 model has 14 states .*: needs about .* available"):
        check_controller_memory(wood_berry, "parameters of node /mpc_controller")
    monkeypatch.setattr(AVAILABLE, lambda: impact - 1)
    check_controller_memory(wood_berry, "x")
    with pytest.raises(ConfigError, match="impact.samples = 4096: the control impact .* set impact.samples to 0"):
        check_impact_memory(wood_berry, "parameters of node /pmr_diagnostician")
    assert impact_shortfall(wood_berry, wood_berry.plant("full")).startswith(
        "control impact not computed: the MPC on the 2x2 model (14 states) steering the estimated plant (17 states)"
    )
    check_impact_memory(load_config(overrides={"impact": {"samples": 0}}), "x")  # no impact, nothing to check
    monkeypatch.setattr(AVAILABLE, lambda: impact)
    check_impact_memory(wood_berry, "x")
    assert impact_shortfall(wood_berry, wood_berry.model) is None


@pytest.mark.ros
def test_the_plant_node_with_a_million_delay_samples_exits_with_one_line(tmp_path, ros_domain):
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from pmr_ros.nodes.plant import main; sys.exit(main())"]
        + ["--ros-args", "--params-file", str(_far_delay_file(tmp_path))],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr + proc.stdout, proc.stderr
    assert lines[0].startswith("wood_berry_plant: error: parameters of node /plant: plant:")
    assert "1000009 states" in lines[0] and "TB of memory" in lines[0]


@pytest.mark.ros
@pytest.mark.parametrize(
    ("executable", "words"),
    [
        ("pmr_diagnostician", "impact.samples = 4096: the control impact simulates the MPC on the 2x2 model (100006"),
        ("mpc_controller", "system: the 2x2 model has 100006 states"),
    ],
)
def test_a_node_on_a_model_of_a_hundred_thousand_states_exits_with_one_line(tmp_path, ros_domain, executable, words):
    """G11's delay 99999 samples (the horizon 100000, the most allowed): 100006 states, hundreds of GB to simulate."""
    text = (config_dir() / "wood_berry.yaml").read_text().replace("delay: [1.0,", "delay: [99999.0,")
    path = tmp_path / "huge.yaml"
    path.write_text(text + "    mpc:\n      prediction_horizon: 100000\n")
    code = f"import sys; from pmr_ros.nodes.{executable} import main"  # the module is named as its executable
    proc = subprocess.run(
        [sys.executable, "-c", f"{code}; sys.exit(main())", "--ros-args", "--params-file", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr + proc.stdout, proc.stderr
    assert lines[0].startswith(f"{executable}: error: parameters of node /{executable}: {words}"), lines[0]
    assert "GB of memory" in lines[0]


@pytest.mark.ros
def test_the_diagnostician_and_controller_refuse_a_model_whose_work_does_not_fit(ros_context, monkeypatch):
    from pmr_ros.config import flatten_parameters
    from pmr_ros.nodes.mpc_controller import MpcControllerNode
    from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode
    from pmr_ros.ros.parameters import parameter_overrides

    config = load_config()
    overrides = parameter_overrides(flatten_parameters(config.parameters))
    horizons = {"prediction_horizon": config.mpc.prediction_horizon, "control_horizon": config.mpc.control_horizon}
    impact = impact_bytes(config.model, config.model, samples=config.impact.samples, **horizons)
    monkeypatch.setattr(AVAILABLE, lambda: impact - 1)
    with pytest.raises(ConfigError, match="parameters of node /pmr_diagnostician: impact.samples = 4096"):
        PmrDiagnosticianNode(context=ros_context, parameter_overrides=overrides)
    monkeypatch.setattr(AVAILABLE, lambda: controller_bytes(config.model, **horizons) - 1)
    with pytest.raises(ConfigError, match="parameters of node /mpc_controller: system: the 2x2 model has 14 states"):
        MpcControllerNode(context=ros_context, parameter_overrides=overrides)


@pytest.fixture(scope="module")
def mismatched_export(tmp_path_factory):
    """A historian export of the paper's mismatch (8192 samples) and a params file whose impact cannot fit."""
    folder = tmp_path_factory.mktemp("impact")
    config = load_config(overrides={"data": DATA_BLOCK})
    csv = folder / "export.csv"
    clean_frame(simulate(config, samples=8192, seed=1, scenario="full")).to_csv(csv, index=False)
    params = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    # the export's controller named (an export is no MPC of ours by default: no impact at all)
    params["/**"]["ros__parameters"].update(
        {"data": DATA_BLOCK, "impact": {"samples": 10_000_000}, "controller": {"kind": "mpc"}}
    )
    path = folder / "params.yaml"
    path.write_text(yaml.safe_dump(params))
    return csv, path, load_config(path)


def test_diagnose_skips_an_impact_that_does_not_fit_with_one_line(mismatched_export, capsys, monkeypatch):
    csv, params, config = mismatched_export
    # ten million samples of the loop: 1.3 GB to simulate; the machine is given 1 GB (the data need 0.4 MB)
    horizons = {"prediction_horizon": config.mpc.prediction_horizon, "control_horizon": config.mpc.control_horizon}
    assert impact_bytes(config.model, config.model, samples=10_000_000, **horizons) > 1.28e9
    monkeypatch.setattr(AVAILABLE, lambda: 10**9)
    assert cli.main(["diagnose", str(csv), "--config", str(params)]) == 0
    out = capsys.readouterr().out
    notes = [line for line in out.splitlines() if line.startswith("note: control impact not computed")]
    assert len(notes) == 1, out
    assert "the MPC on the 2x2 model (14 states) steering the estimated plant (" in notes[0]
    assert "GB of memory (MPC and plant simulation 1.28 GB); 1 GB available" in notes[0]
    assert "mismatch" in out and "control impact (configured MPC" not in out
