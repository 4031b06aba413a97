"""Configurations of tf and step_response elements: loaded, refused in one line, run, written and read back.

Known truths: the curves the test writes itself (with the DMCplus writer),
the transfer functions' own step responses, and the one-line refusals the
brief names (an improper or unstable tf, a numerator that does not parse, a
.mdl with inconsistent counts, a curve shorter than its delay).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.config.write import model_params_text, write_curve_file
from pmr_ros.core.sim.model import Mismatch
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.step_curve import as_step_response
from pmr_ros.models import CurveSet, read_curves, write_mdl

TFS = (("12.8", "40, 14, 1", 1), ("-0.5, 1", "20, 12, 1", 3), ("5, 1", "10, 1", 2), ("-19.4", "14.4, 1", 3))
"""Row-major (numerator, denominator, delay): second order, inverse response, lead-lag, first order."""
N = 160

TF_CONFIG = """\
/**:
  ros__parameters:
    system:
      name: tf unit
      sample_time: 1.0
      output_names: [top, bottom]
      input_names: [reflux, steam]
      delay: [1.0, 3.0, 2.0, 3.0]
      element_type: [tf, tf, tf, tf]
      numerator: ["12.8", "-0.5, 1", "5, 1", "-19.4"]
      denominator: ["40, 14, 1", "20, 12, 1", "10, 1", "14.4, 1"]
    mpc:
      prediction_horizon: 60
      control_horizon: 8
    run:
      samples: 3000
"""

STEP_CONFIG = """\
/**:
  ros__parameters:
    system:
      name: step unit
      sample_time: 1.0
      output_names: [top, bottom]
      input_names: [reflux, steam]
      model_file: curves/unit.mdl
      delay: [1.0, 3.0, 2.0, 3.0]
      element_type: step_response
    mpc:
      prediction_horizon: 60
      control_horizon: 8
    run:
      samples: 3000
"""


def _tf(j: int):
    num, den, delay = TFS[j]
    return transfer_function(num, den, delay_samples=delay, sample_time=1.0, name=f"G{j // 2 + 1}{j % 2 + 1}")


def _write_mdl(path: Path, n: int = N) -> np.ndarray:
    """The four tf elements' curves of ``n`` coefficients as a DMCplus .mdl (written by the project's writer)."""
    curves = np.array([[as_step_response(_tf(2 * i + k), n).curve for k in range(2)] for i in range(2)])
    path.parent.mkdir(parents=True, exist_ok=True)
    gains = curves[:, :, -1]
    write_mdl(CurveSet(1.0, ("top", "bottom"), ("reflux", "steam"), curves, np.zeros((2, 2), bool), gains), path)
    return curves


def _cli(capsys, *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    return code, capsys.readouterr().err


def test_a_tf_configuration_holds_its_transfer_functions(tmp_path):
    (tmp_path / "tf.yaml").write_text(TF_CONFIG)
    model = load_config(tmp_path / "tf.yaml").model
    for j in range(4):
        assert model.element(j // 2, j % 2) == _tf(j)
    assert_allclose(model.gain, [[12.8, 1.0], [1.0, -19.4]], rtol=1e-12)  # each element's steady-state gain


def test_a_model_file_configuration_reads_its_curves_relative_to_the_params_file(tmp_path):
    curves = _write_mdl(tmp_path / "curves" / "unit.mdl")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG)
    config = load_config(tmp_path / "unit.yaml")
    for i in range(2):
        for k in range(2):
            element = config.model.element(i, k)
            assert element.kind == "step_response" and element.delay_samples == TFS[2 * i + k][2]
            assert_allclose(element.step_response(N), curves[i, k], rtol=5e-7, atol=1e-12)  # 7 digits in a .mdl
    assert config.parameters["system"]["model_file"] == str((tmp_path / "curves" / "unit.mdl").resolve())


def test_a_plant_block_may_have_another_structure_than_the_model(tmp_path):
    _write_mdl(tmp_path / "curves" / "unit.mdl")
    plant = TF_CONFIG.split("    system:\n")[1].split("    mpc:")[0].replace("name: tf unit", "name: true unit")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG.replace("    mpc:", "    plant:\n" + plant + "    mpc:"))
    config = load_config(tmp_path / "unit.yaml")
    assert list(config.plant().element_type.ravel()) == ["tf"] * 4
    assert list(config.model.element_type.ravel()) == ["step_response"] * 4
    assert config.plant().element(0, 1) == _tf(1)


def test_the_mismatch_block_scales_a_tf_elements_gain_dynamics_and_delay(tmp_path):
    text = TF_CONFIG + "    mismatch:\n      gain_pct: 10.0\n      time_constant_pct: -20.0\n      delay_samples: 1\n"
    (tmp_path / "tf.yaml").write_text(text)
    config = load_config(tmp_path / "tf.yaml")
    plant = config.plant("full")
    expected = _tf(1).scaled(gain_ratio=1.1, time_scale=0.8, delay_change=1)
    assert_allclose(plant.element(0, 1).step_response(120), expected.step_response(120), atol=1e-12)
    # alpha = 0.8: the denominator 20 s^2 + 12 s + 1 becomes 12.8 s^2 + 9.6 s + 1
    assert_allclose(plant.element(0, 1).denominator, (20 * 0.64, 12 * 0.8, 1.0), rtol=1e-12)


BAD_TF = [
    (('"-0.5, 1"', '"-0.5 x, 1"'), "system.numerator[1] (G12) = '-0.5 x, 1': numerator '-0.5 x, 1' does not parse"),
    (('"20, 12, 1"', '"1, -12, 1"'), "system.denominator[1] (G12) = '1, -12, 1': unstable: pole at s = "),
    (('"-0.5, 1"', '"1, 0, -0.5, 1"'), "system.numerator[1] (G12) = '1, 0, -0.5, 1': improper: numerator degree 3"),
]


@pytest.mark.parametrize(("change", "line"), BAD_TF)
def test_a_bad_tf_is_refused_by_pmr_ros_run_in_one_line(tmp_path, capsys, change, line):
    (tmp_path / "tf.yaml").write_text(TF_CONFIG.replace(*change))
    code, err = _cli(capsys, "run", "--batch", "--config", str(tmp_path / "tf.yaml"))
    assert code == 2 and err.count("\n") == 1, err
    assert f"{tmp_path / 'tf.yaml'}: {line}" in err


def test_a_curve_shorter_than_its_delay_is_refused_in_one_line(tmp_path, capsys):
    _write_mdl(tmp_path / "curves" / "unit.mdl", n=4)
    (tmp_path / "unit.yaml").write_text(
        STEP_CONFIG.replace("delay: [1.0, 3.0, 2.0, 3.0]", "delay: [1.0, 5.0, 2.0, 3.0]")
    )
    code, err = _cli(capsys, "run", "--batch", "--config", str(tmp_path / "unit.yaml"))
    assert code == 2 and err.count("\n") == 1, err
    assert (
        "system.delay[1] (G12) = 5.0: the step-response curve of 4 coefficients is shorter than its delay of 5" in err
    )


def test_a_mdl_with_inconsistent_counts_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "curves" / "unit.mdl"
    _write_mdl(path, n=20)
    lines = path.read_text().splitlines()
    assert lines[4].strip() == "20"  # the number of coefficients (after the comment, file names, counts)
    lines[4] = f"{21:12d}"
    path.write_text("\n".join(lines) + "\n")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG)
    code, err = _cli(capsys, "run", "--batch", "--config", str(tmp_path / "unit.yaml"))
    assert code == 2 and err.count("\n") == 1, err
    assert "system.model_file = 'curves/unit.mdl'" in err and "coefficients, not 21" in err


def test_a_tf_model_written_reads_back_to_the_same_elements(tmp_path):
    (tmp_path / "tf.yaml").write_text(TF_CONFIG)
    config = load_config(tmp_path / "tf.yaml")
    change = Mismatch(np.full((2, 2), 7.3), np.full((2, 2), -13.7), np.ones((2, 2), dtype=int))
    scaled = config.model.with_mismatch(change)  # coefficients that are not round numbers
    assert scaled.element(0, 0) != config.model.element(0, 0)
    text = model_params_text(scaled, settings=config.parameters, header=["corrected"])
    (tmp_path / "written.yaml").write_text(text)
    again = load_config(tmp_path / "written.yaml").model
    assert again.element_rows() == scaled.element_rows()  # lossless (repr)
    assert list(again.element_type.ravel()) == ["tf"] * 4


def test_a_step_response_model_written_reads_back_to_its_curves(tmp_path):
    _write_mdl(tmp_path / "curves" / "unit.mdl")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG)
    config = load_config(tmp_path / "unit.yaml")
    slower = config.model.with_mismatch(Mismatch(np.full((2, 2), 5.0), np.full((2, 2), 30.0), np.zeros((2, 2), int)))
    assert len(slower.element(0, 0).curve) > N  # a slower curve is longer than the file's
    out = tmp_path / "out" / "corrected.yaml"
    out.parent.mkdir()
    write_curve_file(slower, out.with_suffix(".mdl"), original=config.parameters["system"]["model_file"])
    out.write_text(model_params_text(slower, settings=config.parameters, model_file="corrected.mdl"))
    again = load_config(out).model
    n = read_curves(out.with_suffix(".mdl")).n_coefficients
    for i in range(2):
        for k in range(2):
            assert_allclose(
                again.element(i, k).step_response(n), slower.element(i, k).step_response(n), rtol=5e-7, atol=1e-9
            )


@pytest.mark.slow
def test_pmr_ros_run_takes_a_model_file_end_to_end_and_writes_the_corrected_curves(tmp_path, capsys):
    _write_mdl(tmp_path / "curves" / "unit.mdl")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG + "    mismatch:\n      gain_pct: [15.0, 0.0, 0.0, 0.0]\n")
    report, written = tmp_path / "report.json", tmp_path / "out" / "corrected.yaml"
    written.parent.mkdir()
    argv = ["run", "--batch", "--config", str(tmp_path / "unit.yaml"), "--samples", "3000", "--json", str(report)]
    code = main([*argv, "--write-model", str(written)])
    assert code == 0, capsys.readouterr().err
    g11 = json.loads(report.read_text())["elements"]["G11"]
    assert g11["verdict"] == "mismatch" and g11["model"]["kind"] == "step_response"
    dk, alpha = g11["parametric"]["gain_mismatch_pct"], g11["parametric"]["tau_mismatch_pct"]
    assert abs(dk - 15.0) < 3.0  # the injected +15 %
    model = load_config(tmp_path / "unit.yaml").model
    corrected = load_config(written).model  # corrected.yaml names corrected.mdl beside it
    assert (written.with_suffix(".mdl")).is_file()
    expected = model.element(0, 0).scaled(gain_ratio=1 + dk / 100, time_scale=1 + alpha / 100)
    assert_allclose(corrected.element(0, 0).step_response(N), expected.step_response(N), rtol=1e-6, atol=1e-6)
    assert_allclose(corrected.element(1, 1).step_response(N), model.element(1, 1).step_response(N), rtol=1e-6)


def test_measured_disturbances_beside_tf_elements_feed_forward_as_with_their_curves(tmp_path):
    from dataclasses import replace

    from pmr_ros.core.sim.closed_loop import simulate
    from pmr_ros.core.sim.model import TransferMatrix

    dv = "      disturbance_names: [feed]\n      disturbance_gain: [0.8, -0.4]\n      disturbance_time_constant: 6.0\n"
    text = TF_CONFIG.replace("      delay: [1.0", dv + "      delay: [1.0").replace(
        "    run:\n", "    noise:\n      std: 0.0\n    run:\n"
    )
    (tmp_path / "tf.yaml").write_text(text)
    config = load_config(tmp_path / "tf.yaml")
    assert config.model.has_general and config.disturbance_model is not None
    rows = [[as_step_response(e, 400) for e in row] for row in config.model.element_rows()]
    curves = TransferMatrix.of_elements(
        rows, sample_time=1.0, output_names=config.model.output_names, input_names=config.model.input_names
    )
    by_tf = simulate(config, samples=800, seed=2)
    by_curves = simulate(replace(config, model=curves, explicit_plant=config.model), samples=800, seed=2)
    assert np.ptp(by_tf.dv) > 0.5  # the DV moves
    assert_allclose(by_curves.u, by_tf.u, atol=1e-5)
    assert_allclose(by_curves.y, by_tf.y, atol=1e-5)


def test_a_proposal_names_the_curves_it_needs(tmp_path):
    from pmr_ros.core.loop.update import ElementChange, ModelUpdate, with_changes
    from pmr_ros.core.results import ElementModel
    from pmr_ros.service.closing import curve_file

    _write_mdl(tmp_path / "curves" / "unit.mdl")
    (tmp_path / "unit.yaml").write_text(STEP_CONFIG)
    config = load_config(tmp_path / "unit.yaml")
    original = config.parameters["system"]["model_file"]
    assert curve_file(config, ModelUpdate(config.model, ())) == original  # no curve changed: the file as it is
    faster = config.model.element(1, 0).scaled(gain_ratio=0.9, time_scale=0.8)
    before = ElementModel("step_response", 1.0, None, 2)
    change = ElementChange("G21", before, before, None, faster)  # the estimate is not read here
    update = ModelUpdate(with_changes(config.model, [(1, 0, change)]), (change,))
    proposed = curve_file(config, update)
    assert proposed != original and proposed.endswith(".mdl") and curve_file(config, update) == proposed
    curves = read_curves(proposed)
    assert_allclose(curves.curves[1, 0][: len(faster.curve)], faster.curve, rtol=5e-7, atol=1e-9)
    written = curve_file(config, update, str(tmp_path / "out.yaml"))  # --write-model: beside the params file
    assert written == "out.mdl" and (tmp_path / "out.mdl").is_file()
