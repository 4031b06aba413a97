"""Model files: DMCplus .mdl and CSV curves, ``pmr-ros model import|export``, the new system fields.

The .mdl text below follows the layout of the public examples of
github.com/jamestjsp/dmcplus (docs/models.md) with our own numbers: units with
a blank, three-digit exponents as a Windows C library prints them, a ramp
dependent and an empty pair.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from pmr_ros.cli import main
from pmr_ros.config import ConfigError, load_config
from pmr_ros.config.schema import Shape, parameter
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.models.csv_curves import csv_text, read_csv_curves, write_csv_curves
from pmr_ros.models.curve_set import ModelFileError
from pmr_ros.models.mdl import mdl_text, read_mdl, write_mdl
from pmr_ros.models.system_file import load_model, to_curve_set

EXAMPLE_MDL = """\
Last Run: 11/25/26, 16:00:00    Model Order = 2
           0
           3
           2
           6
          18
       12.000000
     9896.000000
     -999.000000                    FIC-101      M3/H        |
     -999.000000                    TIC-102      DEG F       |
     -999.000000                    FF-103                   |
        0.000000                    AI-201       %                0     2
        0.000000                    LI-202       %                1     3
AI-201       %               0      0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
FIC-101      M3/H                               1.500000000000000e+00
   0.000000e+00   5.000000e-01   1.000000e+00   1.300000e+00   1.450000e+00
   1.500000e+00
TIC-102      DEG F                            -2.000000000000000e-001
 -1.000000e-001 -1.600000e-001 -1.900000e-001 -2.000000e-001 -2.000000e-001
 -2.000000e-001
FF-103                                          0.000000000000000e+00
   0.000000e+00   0.000000e+00   0.000000e+00   0.000000e+00   0.000000e+00
   0.000000e+00
LI-202       %               1      0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
        0.000000
FIC-101      M3/H                               5.000000000000000e-02
   0.000000e+00   0.000000e+00   1.000000e-01   2.000000e-01   3.000000e-01
   4.000000e-01
TIC-102      DEG F                              2.500000000000000e-02
   2.000000e-02   6.000000e-02   1.100000e-01   1.600000e-01   2.100000e-01
   2.600000e-01
FF-103                                         -1.000000000000000e-02
   0.000000e+00  -1.000000e-02  -3.000000e-02  -5.000000e-02  -7.000000e-02
  -9.000000e-02
""".replace("|\n", "\n")  # "|" marks the end of a line with trailing blanks


@pytest.fixture
def example(tmp_path: Path) -> Path:
    path = tmp_path / "unit.mdl"
    path.write_text(EXAMPLE_MDL, encoding="utf-8")
    return path


def _split(line: str) -> tuple[list[str], list[float]]:
    """The words and the numbers of a line."""
    words, numbers = [], []
    for token in line.split():
        try:
            numbers.append(float(token))
        except ValueError:
            words.append(token)
    return words, numbers


def _cli(capsys, *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    return code, capsys.readouterr().err


def test_read_mdl_gives_the_layout_fields(example):
    c = read_mdl(example)
    assert c.output_names == ("AI-201", "LI-202") and c.input_names == ("FIC-101", "TIC-102", "FF-103")
    assert c.input_units == ("M3/H", "DEG F", "") and c.output_units == ("%", "%")
    assert c.sample_time == 2.0 and c.n_coefficients == 6  # time to steady state 12 / 6 coefficients
    assert c.ramp.tolist() == [[False] * 3, [True] * 3]
    assert_allclose(c.curves[0, 1], [-0.1, -0.16, -0.19, -0.2, -0.2, -0.2], rtol=1e-15)
    assert_allclose(c.gains, [[1.5, -0.2, 0.0], [0.05, 0.025, -0.01]], rtol=1e-15)
    assert c.extras.header_count == 18 and c.extras.dependent_counts.tolist() == [2, 3]
    assert c.comment == "Last Run: 11/25/26, 16:00:00    Model Order = 2"


def test_mdl_write_read_is_lossless_and_writes_the_same_text_again(example, tmp_path):
    first = read_mdl(example)
    write_mdl(first, tmp_path / "again.mdl")
    second = read_mdl(tmp_path / "again.mdl")
    assert first.same_as(second)
    assert mdl_text(second) == (tmp_path / "again.mdl").read_text()
    # the layout's columns as DMCplus writes them; lines with three-digit exponents hold the same numbers
    written, given = (tmp_path / "again.mdl").read_text().splitlines(), EXAMPLE_MDL.splitlines()
    assert len(written) == len(given)
    for mine, theirs in zip(written, given, strict=True):
        if "e-001" in theirs:
            assert _split(mine) == _split(theirs)
        else:
            assert mine == theirs


def test_import_export_import_is_identical(example, tmp_path, capsys):
    code, err = _cli(capsys, "model", "import", str(example), "-o", str(tmp_path / "m.yaml"))
    assert code == 0 and "2x3 step-response model of 6 coefficients" in err
    code, _ = _cli(capsys, "model", "export", str(tmp_path / "m.yaml"), "-o", str(tmp_path / "back.mdl"))
    assert code == 0
    code, _ = _cli(capsys, "model", "import", str(tmp_path / "back.mdl"), "-o", str(tmp_path / "m2.yaml"))
    assert code == 0
    assert read_mdl(example).same_as(read_mdl(tmp_path / "back.mdl"))
    first, second = (
        yaml.safe_load((tmp_path / f).read_text())["/**"]["ros__parameters"]["system"] for f in ("m.yaml", "m2.yaml")
    )
    assert first.pop("model_file") == "unit.mdl" and second.pop("model_file") == "back.mdl"
    first.pop("name"), second.pop("name")
    assert first == second
    assert first["element_type"] == ["step_response", "step_response", "none"] + ["step_response"] * 3
    assert first["delay"] == [2.0, 0.0, 0.0, 4.0, 0.0, 2.0]  # leading zeros x Ts


def test_imported_model_loads_as_step_response_elements(example, tmp_path, capsys):
    _cli(capsys, "model", "import", str(example), "-o", str(tmp_path / "m.yaml"))
    model = load_model(tmp_path / "m.yaml")
    g21 = model.elements[1][0]
    assert g21.kind == "step_response" and g21.integrating and g21.delay_samples == 2
    assert_allclose(g21.step_response(8), [0, 0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6], atol=1e-15)
    assert g21.steady_state_gain == 0.05  # the file's ramp rate, per time unit
    assert model.elements[0][2].kind == "none"


TF_MODEL = """\
/**:
  ros__parameters:
    system:
      name: mixed
      sample_time: 1.0
      output_names: [level, temp]
      input_names: [flow, heat]
      gain: [0.05, 1.0, 0.0, 2.0]
      time_constant: [0.0, 0.0, 0.0, 8.0]
      delay: [1.0, 2.0, 0.0, 3.0]
      element_type: [integrating, tf, none, foptd]
      numerator: ["", "-0.5, 1", "", ""]
      denominator: ["", "20, 12, 1", "", ""]
"""


def test_a_tf_model_exported_as_mdl_reads_back_as_its_sampled_curves(tmp_path, capsys):
    (tmp_path / "tf.yaml").write_text(TF_MODEL)
    code, err = _cli(
        capsys, "model", "export", str(tmp_path / "tf.yaml"), "-o", str(tmp_path / "tf.mdl"), "--coefficients", "90"
    )
    assert code == 0, err
    curves = read_mdl(tmp_path / "tf.mdl")
    tf = transfer_function("-0.5, 1", "20, 12, 1", delay_samples=2, sample_time=1.0)
    assert_allclose(curves.curves[0, 1], tf.step_response(90), rtol=5e-7, atol=1e-12)  # 7 digits in the file
    assert_allclose(curves.curves[0, 0], 0.05 * np.maximum(np.arange(1, 91) - 1, 0), rtol=5e-7)
    assert_allclose(curves.curves[1, 1], 2.0 * (1 - np.exp(-np.maximum(np.arange(1, 91) - 3, 0) / 8.0)), rtol=5e-7)
    assert curves.ramp[0].all() and not curves.ramp[1].any()  # one flag per dependent
    assert_allclose(curves.gains, [[0.05, 1.0], [0.0, 2.0]], rtol=1e-12)


def test_export_default_length_lets_every_element_settle(tmp_path, capsys):
    (tmp_path / "tf.yaml").write_text(TF_MODEL)
    model = load_model(tmp_path / "tf.yaml")
    curves = to_curve_set(model)
    assert abs(curves.curves[1, 1, -1] - 2.0) < 2e-3
    assert abs(curves.curves[0, 1, -1] - 1.0) < 2e-3


def test_csv_layout_round_trip_and_import(example, tmp_path, capsys):
    c = read_mdl(example)
    write_csv_curves(c, tmp_path / "c.csv")
    back = read_csv_curves(tmp_path / "c.csv")
    assert_allclose(back.curves, c.curves, rtol=0) and back.sample_time == 2.0
    assert back.ramp.tolist() == c.ramp.tolist()
    assert csv_text(back) == (tmp_path / "c.csv").read_text()
    assert (tmp_path / "c.csv").read_text().splitlines()[:2] == [
        "time,AI-201|FIC-101,AI-201|TIC-102,AI-201|FF-103,LI-202|FIC-101,LI-202|TIC-102,LI-202|FF-103",
        "ramp,0,0,0,1,1,1",
    ]
    code, _ = _cli(capsys, "model", "import", str(tmp_path / "c.csv"), "-o", str(tmp_path / "c.yaml"))
    assert code == 0
    g11 = load_model(tmp_path / "c.yaml").elements[0][0]
    assert g11.steady_state_gain == 1.5 and g11.delay_samples == 1


# -- bad input: one clear line each ---------------------------------------------------------


def _broken(example: Path, old: str, new: str) -> Path:
    text = example.read_text()
    assert old in text
    example.write_text(text.replace(old, new, 1))
    return example


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        (
            "\n           6\n",
            "\n           7\n",
            ["line 28", "curve AI-201/FIC-101 has 6 coefficients, not 7", "'TIC-102' comes next"],
        ),
        (
            "\n           6\n",
            "\n           5\n",
            [
                "line 27: the curve AI-201/TIC-102: expected a tag, found the number '1.500000e+00'",
                "says 3 independents, 2 dependents, 5 coefficients",
            ],
        ),
        (
            "\n           3\n",
            "\n           4\n",
            [
                "line 15: the block of dependent LI-202: expected a tag",
                "the header says 4 independents, 2 dependents, 6 coefficients",
            ],
        ),
        (
            "TIC-102      DEG F                            -2.0",
            "TIC-109      DEG F                            -2.0",
            ["expected the curve of independent 'TIC-102'", "got 'TIC-109'"],
        ),
        ("     9896.000000", "     1234.000000", ["layout flag 1234", "only the new-style layout"]),
        ("       12.000000", "       twelve", ["the time to steady state: 'twelve' is not a number"]),
    ],
)
def test_bad_mdl_files_are_refused_in_one_line(example, tmp_path, capsys, old, new, words):
    _broken(example, old, new)
    with pytest.raises(ModelFileError) as info:
        read_mdl(example)
    for word in words:
        assert word in str(info.value)
    code, err = _cli(capsys, "model", "import", str(example), "-o", str(tmp_path / "m.yaml"))
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"pmr-ros: error: {example} line ")


def test_a_truncated_mdl_names_where_it_ends(example):
    example.write_text("\n".join(EXAMPLE_MDL.splitlines()[:40]) + "\n")
    with pytest.raises(
        ModelFileError,
        match=r"unit.mdl line 40: ends after line 40, before number 7 of the block of LI-202 \(the header says",
    ):
        read_mdl(example)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (('"-0.5, 1"', '"-0.5 x, 1"'), ["G12", "numerator '-0.5 x, 1' does not parse", "'x' is not a number"]),
        (('"20, 12, 1"', '"1, -12, 1"'), ["G12", "unstable", "right half-plane"]),
        (('"-0.5, 1"', '"1, 0, -0.5, 1"'), ["G12", "improper: numerator degree 3 > denominator degree 2"]),
        (("delay: [1.0, 2.0, 0.0, 3.0]", "delay: [1.0, 2.5, 0.0, 3.0]"), ["system.delay[1] (G12)", "whole samples"]),
        (
            ("[integrating, tf, none, foptd]", "[integrating, step_response, none, foptd]"),
            ["system.model_file", "missing"],
        ),
        (
            ('numerator: ["", "-0.5, 1", "", ""]', 'numerator: ["", -0.5, "", ""]'),
            ["system.numerator[1] (G12)", "must be a string"],
        ),
    ],
)
def test_bad_model_params_files_are_refused_in_one_line(tmp_path, capsys, change, words):
    (tmp_path / "tf.yaml").write_text(TF_MODEL.replace(*change))
    code, err = _cli(capsys, "model", "export", str(tmp_path / "tf.yaml"), "-o", str(tmp_path / "x.mdl"))
    assert code == 2 and err.count("\n") == 1, err
    for word in words:
        assert word in err


def test_step_response_curve_shorter_than_its_delay_in_a_model_file(example, tmp_path, capsys):
    _cli(capsys, "model", "import", str(example), "-o", str(tmp_path / "m.yaml"))
    text = (
        (tmp_path / "m.yaml")
        .read_text()
        .replace("- 2.0                      # G11", "- 14.0                     # G11")
    )
    (tmp_path / "m.yaml").write_text(text)
    code, err = _cli(capsys, "model", "export", str(tmp_path / "m.yaml"), "-o", str(tmp_path / "x.mdl"))
    assert code == 2 and err.count("\n") == 1
    assert "G11: the step-response curve of 6 coefficients is shorter than its delay of 7 samples" in err


def test_export_refuses_curves_not_longer_than_a_delay(tmp_path, capsys):
    (tmp_path / "tf.yaml").write_text(TF_MODEL)
    code, err = _cli(
        capsys, "model", "export", str(tmp_path / "tf.yaml"), "-o", str(tmp_path / "x.mdl"), "--coefficients", "3"
    )
    assert (
        code == 2
        and err == "pmr-ros: error: G22: curves of 3 coefficients are not longer than its delay of 3 samples\n"
    )


def test_unknown_model_file_type_is_refused(tmp_path, capsys):
    code, err = _cli(capsys, "model", "import", str(tmp_path / "model.txt"), "-o", str(tmp_path / "m.yaml"))
    assert code == 2 and "unknown model file type '.txt'" in err


# -- the new system fields ------------------------------------------------------------------


def test_strings_parameter_takes_one_string_per_element_or_one_for_all():
    numerator = parameter("system.numerator")
    shape = Shape(1, 2)
    assert numerator.check("1", source="f", shape=shape).tolist() == [["1", "1"]]
    assert numerator.check(["1", "2, 1"], source="f", shape=shape).tolist() == [["1", "2, 1"]]
    with pytest.raises(ConfigError, match=r"needs 2 strings \(1x2, row by row\), got 3"):
        numerator.check(["1", "2", "3"], source="f", shape=shape)
    assert parameter("system.model_file").default == ""


def test_a_run_config_with_a_tf_element_holds_that_element(tmp_path):
    (tmp_path / "tf.yaml").write_text(TF_MODEL)
    model = load_config(str(tmp_path / "tf.yaml")).model
    expected = transfer_function("-0.5, 1", "20, 12, 1", delay_samples=2, sample_time=1.0, name="G12")
    assert model.element(0, 1) == expected
    assert list(model.element_type.ravel()) == ["integrating", "tf", "none", "foptd"]


def test_mdl_example_text_is_what_the_docs_describe():
    # the documented header lines, in order (docs/models.md)
    head = textwrap.dedent(EXAMPLE_MDL).splitlines()[:8]
    assert [line.strip() for line in head[1:]] == ["0", "3", "2", "6", "18", "12.000000", "9896.000000"]
