"""Measured-disturbance (DV) elements of any type: tf and step_response D elements read, simulated, diagnosed.

Known truths: scipy.signal's zero-order-hold sampling (cont2discrete) and
simulation (dlsim) of the DV's second-order transfer function, the curves the
test writes itself into the .mdl, the injected DV gain change of the mismatch
block, and the one-line refusals of a bad DV tf.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import cont2discrete, dlsim

from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.sim.augment import augmented_model
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.step_curve import as_step_response
from pmr_ros.core.sim.true_plant import FoptdPlant
from pmr_ros.models import CurveSet, write_mdl

D11 = ("0.9", "30, 11, 1", 2)
"""(numerator, denominator, delay [samples]) of the second-order DV element D11 (poles at -1/5 and -1/6)."""

CONFIG = """\
/**:
  ros__parameters:
    system:
      name: dv unit
      sample_time: 1.0
      output_names: [x_D, x_B]
      input_names: [reflux, steam]
      gain: [12.8, -18.9, 6.6, -19.4]
      time_constant: [16.7, 21.0, 10.9, 14.4]
      delay: [1.0, 3.0, 7.0, 3.0]
      disturbance_names: [feed]
      disturbance_element_type: [tf, foptd]
      disturbance_numerator: ["0.9", ""]
      disturbance_denominator: ["30, 11, 1", ""]
      disturbance_gain: [0.0, -0.6]
      disturbance_time_constant: [0.0, 8.0]
      disturbance_delay: [2.0, 1.0]
    disturbance_signal:
      kind: prbs
      amplitude: 1.0
      mean_interval_samples: 12.0
    mpc:
      prediction_horizon: 40
      control_horizon: 6
"""


def _write(tmp_path: Path, text: str = CONFIG) -> Path:
    path = tmp_path / "dv.yaml"
    path.write_text(text)
    return path


def _d11():
    num, den, delay = D11
    return transfer_function(num, den, delay_samples=delay, sample_time=1.0, name="D11")


def test_a_dv_tf_element_is_read_as_its_transfer_function(tmp_path):
    config = load_config(_write(tmp_path))
    dv = config.disturbance_model
    assert dv is not None and dv.has_general and dv.input_names == ("feed",)
    assert dv.element(0, 0) == _d11()
    assert list(dv.element_type.ravel()) == ["tf", "foptd"]
    assert_allclose(dv.gain, [[0.9], [-0.6]], rtol=1e-12)  # the tf's steady-state gain


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # the sampled numerator's leading ~0
def test_a_second_order_dv_element_in_the_plant_is_scipys_zoh_simulation(tmp_path):
    config = load_config(_write(tmp_path))
    truth = augmented_model(config.plant(), config.disturbance_plant())
    plant = FoptdPlant(truth, 0.0, seed=0)
    rng = np.random.default_rng(5)
    v = np.repeat(rng.standard_normal(40), 6)  # the DV held for 6 samples each; the MVs at rest
    y = np.empty(v.size)
    for k in range(v.size):
        y[k] = plant.output()[0]
        plant.advance(np.array([0.0, 0.0, v[k]]))
    num_d, den_d, _ = cont2discrete(([0.9], [30.0, 11.0, 1.0]), 1.0, method="zoh")
    shifted = np.concatenate((np.zeros(D11[2]), v))[: v.size]  # the DV's dead time
    _, expected = dlsim((np.atleast_2d(num_d)[0], den_d, 1.0), shifted)
    assert np.ptp(y) > 0.5  # the DV acts
    assert_allclose(y, expected[:, 0], atol=1e-10)


def test_a_closed_loop_with_a_tf_dv_model_feeds_it_forward(tmp_path):
    text = CONFIG + "    noise:\n      std: 0.0\n    prbs:\n      amplitude: 0.0\n"
    config = load_config(_write(tmp_path, text))
    record = simulate(config, samples=600, seed=3, scenario="none")
    assert record.dv is not None and np.ptp(record.dv) > 1.5  # the DV moves
    assert np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.u))
    # with its exact feedforward model the MPC keeps both CVs far closer to 0 than the DV alone would move them
    truth = augmented_model(config.plant(), config.disturbance_plant())
    open_loop = truth.element_outputs(np.hstack([np.zeros_like(record.u), record.dv]))
    assert np.std(record.y[100:, 0]) < 0.5 * np.std(open_loop[100:, 0])


def test_step_response_dv_elements_read_their_curves_from_the_model_file(tmp_path):
    n = 120
    rows = [[None, None, _d11()], [None, None, None]]
    curves = np.zeros((2, 3, n))
    curves[0, 2] = as_step_response(rows[0][2], n).curve
    curves[1, 2] = 0.5 * (1 - np.exp(-np.arange(1, n + 1) / 6.0))
    gains = curves[:, :, -1]
    names = (("x_D", "x_B"), ("reflux", "steam", "feed"))
    write_mdl(CurveSet(1.0, *names, curves, np.zeros((2, 3), bool), gains), tmp_path / "unit.mdl")
    text = CONFIG.replace("disturbance_element_type: [tf, foptd]", "disturbance_element_type: step_response")
    text = text.replace("disturbance_delay: [2.0, 1.0]", "disturbance_delay: [2.0, 0.0]\n      model_file: unit.mdl")
    config = load_config(_write(tmp_path, text))
    dv = config.disturbance_model
    assert dv is not None and list(dv.element_type.ravel()) == ["step_response"] * 2
    for k in range(2):
        assert_allclose(dv.element(k, 0).step_response(n), curves[k, 2], rtol=5e-7, atol=1e-12)  # 7 digits in .mdl


BAD = [
    (
        ('disturbance_numerator: ["0.9", ""]', 'disturbance_numerator: ["0.9 x", ""]'),
        "system.disturbance_numerator[0] (D11) = '0.9 x': numerator '0.9 x' does not parse",
    ),
    (
        ('disturbance_denominator: ["30, 11, 1", ""]', 'disturbance_denominator: ["30, -11, 1", ""]'),
        "system.disturbance_denominator[0] (D11) = '30, -11, 1': unstable: pole at s = ",
    ),
    (
        ('disturbance_numerator: ["0.9", ""]', 'disturbance_numerator: ["1, 2, 0.9, 1", ""]'),
        "system.disturbance_numerator[0] (D11) = '1, 2, 0.9, 1': improper",
    ),
    (
        ('disturbance_numerator: ["0.9", ""]', 'disturbance_numerator: ["0.9"]'),
        "system.disturbance_numerator = ['0.9']: needs 2 strings (2x1, row by row), got 1",
    ),
    (
        ("disturbance_element_type: [tf, foptd]", "disturbance_element_type: [step_response, foptd]"),
        "system.model_file: missing: step_response elements read their curves there",
    ),
]


@pytest.mark.parametrize(("change", "line"), BAD)
def test_a_bad_dv_element_is_refused_in_one_line_with_exit_2(tmp_path, capsys, change, line):
    assert change[0] in CONFIG
    path = _write(tmp_path, CONFIG.replace(*change))
    code = main(["run", "--batch", "--config", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert f"{path}: {line}" in err, err


def test_the_plant_block_may_give_tf_dv_elements_of_its_own(tmp_path):
    plant = (
        "    plant:\n      gain: [12.8, -18.9, 6.6, -19.4]\n      time_constant: [16.7, 21.0, 10.9, 14.4]\n"
        "      delay: [1.0, 3.0, 7.0, 3.0]\n      disturbance_element_type: tf\n"
        '      disturbance_numerator: ["1.2", "-0.6"]\n      disturbance_denominator: ["20, 9, 1", "8, 1"]\n'
        "      disturbance_delay: [2.0, 1.0]\n"
    )
    config = load_config(_write(tmp_path, CONFIG + plant))
    truth = config.disturbance_plant()
    assert truth is not None and list(truth.element_type.ravel()) == ["tf", "tf"]
    assert_allclose(truth.gain, [[1.2], [-0.6]], rtol=1e-12)
    assert config.disturbance_model is not None and config.disturbance_model.element(0, 0) == _d11()


def test_a_gain_change_of_a_tf_dv_element_is_found_by_the_diagnosis(tmp_path):
    text = CONFIG + "    mismatch:\n      disturbance_gain_pct: [20.0, 0.0]\n"
    config = load_config(_write(tmp_path, text))
    record = simulate(config, samples=4096, seed=4, scenario="full")
    diagnosis = diagnose_stretches(
        [record], model=config.model, pmr=config.pmr, parametric=config.parametric, method="parametric",
        disturbance_model=config.disturbance_model,
    )  # fmt: skip
    d11, d21 = diagnosis.elements["D11"], diagnosis.elements["D21"]
    assert d11.model.kind == "tf"
    assert d11.verdict == "mismatch", d11.summary()
    assert abs(d11.parametric.gain_mismatch_pct - 20.0) < 3.0  # the injected +20 %, within the 3 pp specification
    assert d21.verdict != "mismatch", d21.summary()
    assert all(diagnosis.elements[g].verdict != "mismatch" for g in ("G11", "G12", "G21", "G22"))


def test_a_corrected_model_written_keeps_the_dv_curves_in_its_curve_file(tmp_path):
    from pmr_ros.core.loop.update import ModelUpdate
    from pmr_ros.core.results import Diagnosis
    from pmr_ros.service.closing import curve_file, model_file_text

    n = 90
    curves = np.zeros((2, 3, n))
    curves[:, :, :] = np.array([1.0, -2.0, 0.7])[None, :, None] * (1 - np.exp(-np.arange(1, n + 1) / 9.0))
    names = (("x_D", "x_B"), ("reflux", "steam", "feed"))
    write_mdl(CurveSet(1.0, *names, curves, np.zeros((2, 3), bool), curves[:, :, -1]), tmp_path / "unit.mdl")
    system = (
        "    system:\n      sample_time: 1.0\n      output_names: [x_D, x_B]\n      input_names: [reflux, steam]\n"
        "      delay: [0.0, 0.0, 0.0, 0.0]\n      element_type: step_response\n      model_file: unit.mdl\n"
        "      disturbance_names: [feed]\n      disturbance_element_type: step_response\n"
    )
    config = load_config(_write(tmp_path, "/**:\n  ros__parameters:\n" + system))
    scaled = config.model.with_elements(
        [[e.scaled(gain_ratio=1.1) for e in row] for row in config.model.element_rows()]
    )
    out = tmp_path / "out" / "corrected.yaml"
    out.parent.mkdir()
    update = ModelUpdate(scaled, ())
    written = curve_file(config, update, str(out))
    diagnosis = Diagnosis(method="parametric", status="ok", reason="", samples=0, elements={})
    out.write_text(model_file_text(config, update, diagnosis, model_file=written))
    again = load_config(out)
    assert again.disturbance_model is not None
    for i in range(2):
        assert_allclose(again.disturbance_model.element(i, 0).step_response(n), curves[i, 2], rtol=5e-7)
        assert_allclose(again.model.element(i, 1).step_response(n), 1.1 * curves[i, 1], rtol=5e-7)


def test_a_mdl_with_a_feedforward_imports_it_as_a_dv_and_exports_it_back_identically(tmp_path, capsys):
    from test_mdl import EXAMPLE_MDL

    from pmr_ros.models import read_mdl

    (tmp_path / "unit.mdl").write_text(EXAMPLE_MDL)
    model, back = tmp_path / "m.yaml", tmp_path / "back.mdl"
    assert main(["model", "import", str(tmp_path / "unit.mdl"), "-o", str(model), "--disturbances", "FF-103"]) == 0
    assert "2x2 step-response model and 1 measured disturbance(s)" in capsys.readouterr().err
    config = load_config(model)
    assert config.model.input_names == ("FIC-101", "TIC-102")
    dv = config.disturbance_model
    assert dv is not None and dv.input_names == ("FF-103",)
    assert list(dv.element_type.ravel()) == ["none", "step_response"]  # FF-103 -> AI-201 is an empty pair
    d21 = dv.element(1, 0)
    assert d21.integrating and d21.delay_samples == 1  # LI-202 is a ramp CV; one leading zero of Ts 2
    assert_allclose(d21.step_response(6), [0.0, -0.01, -0.03, -0.05, -0.07, -0.09], rtol=1e-15)
    assert main(["model", "export", str(model), "-o", str(back)]) == 0
    assert read_mdl(tmp_path / "unit.mdl").same_as(read_mdl(back))  # the DV back as the third independent
    assert main(["model", "import", str(back), "-o", str(tmp_path / "m2.yaml"), "--disturbances", "FF-103"]) == 0
    first, second = (p.read_text().split("    system:\n")[1] for p in (model, tmp_path / "m2.yaml"))
    assert first.replace('"unit.mdl"', '"back.mdl"').replace('"unit"', '"back"') == second


def test_a_feedforward_tag_that_is_no_independent_is_one_line(tmp_path, capsys):
    from test_mdl import EXAMPLE_MDL

    (tmp_path / "unit.mdl").write_text(EXAMPLE_MDL)
    argv = ["model", "import", str(tmp_path / "unit.mdl"), "-o", str(tmp_path / "m.yaml")]
    assert main([*argv, "--disturbances", "FF-104"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'FF-104' is no independent of the file (it has FIC-101, TIC-102, FF-103)" in err
    assert main([*argv, "--disturbances", "FIC-101,TIC-102,FF-103"]) == 2
    assert "every independent is a disturbance" in capsys.readouterr().err


def test_a_csv_curve_file_holds_dv_pairs_as_its_other_columns(tmp_path):
    from pmr_ros.models import write_csv_curves

    n = 60
    curve = 0.4 * (1 - np.exp(-np.arange(1, n + 1) / 7.0))
    curves = np.zeros((2, 3, n))
    curves[:, :2] = np.array([[1.0, -2.0], [0.5, 1.5]])[:, :, None] * curve
    curves[1, 2] = curve  # x_B|feed; x_D|feed has no column (an empty pair)
    names = (("x_D", "x_B"), ("reflux", "steam", "feed"))
    write_csv_curves(CurveSet(1.0, *names, curves, np.zeros((2, 3), bool), curves[:, :, -1]), tmp_path / "c.csv")
    assert "x_B|feed" in (tmp_path / "c.csv").read_text().splitlines()[0]
    system = (
        "    system:\n      sample_time: 1.0\n      output_names: [x_D, x_B]\n      input_names: [reflux, steam]\n"
        "      delay: [0.0, 0.0, 0.0, 0.0]\n      element_type: step_response\n      model_file: c.csv\n"
        "      disturbance_names: [feed]\n      disturbance_element_type: [none, step_response]\n"
    )
    config = load_config(_write(tmp_path, "/**:\n  ros__parameters:\n" + system))
    dv = config.disturbance_model
    assert dv is not None and list(dv.element_type.ravel()) == ["none", "step_response"]
    assert_allclose(dv.element(1, 0).step_response(n), curve, rtol=1e-15)  # repr: lossless
