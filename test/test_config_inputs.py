"""Params files and options a harsh probe sent (issue 21, item 12).

The plant block as documented, one-line names, one number grammar.
"""

from __future__ import annotations

import pytest

from pmr_ros import cli
from pmr_ros.commands import number, whole_number
from pmr_ros.config import ConfigError, config_dir, load_config
from pmr_ros.config.fast_yaml import load as load_yaml
from pmr_ros.config.numbers import parse_number

SYSTEM = """\
/**:
  ros__parameters:
    system:
      name: {name}
      sample_time: 1.0
      output_names: [x_D, x_B]
      input_names: [reflux, steam]
      gain: [12.8, -18.9, 6.6, -19.4]
      time_constant: [16.7, 21.0, 10.9, 14.4]
      delay: [1.0, 3.0, 7.0, 3.0]
"""

PLANT = """\
    plant:
      name: column_as_built
      sample_time: {ts}
      output_names: [x_D, x_B]
      input_names: [reflux, steam]
      gain: [14.0, -18.9, 6.6, -19.4]
      time_constant: [16.7, 21.0, 10.9, 14.4]
      delay: [1.0, 3.0, 7.0, 3.0]
"""


def _write(tmp_path, text: str):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    return path


def test_a_copy_of_the_system_block_is_a_plant_block_with_foptd_elements_by_default(tmp_path):
    config = load_config(_write(tmp_path, SYSTEM.format(name="wb") + PLANT.format(ts="1.0")))
    plant = config.plant()
    assert plant.name == "column_as_built"
    assert plant.element_type.tolist() == [["foptd", "foptd"], ["foptd", "foptd"]]
    assert plant.gain[0, 0] == 14.0 and config.model.gain[0, 0] == 12.8


def test_a_plant_block_with_another_sample_time_or_channels_is_refused_naming_the_field(tmp_path):
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, SYSTEM.format(name="wb") + PLANT.format(ts="2.0")))
    assert "plant.sample_time" in str(err.value) and "must be system.sample_time (1.0)" in str(err.value)
    text = SYSTEM.format(name="wb") + PLANT.format(ts="1.0").replace("[reflux, steam]", "[steam, reflux]")
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, text))
    assert "plant.input_names" in str(err.value) and "must be system.input_names" in str(err.value)


@pytest.mark.parametrize("name", ['"two\\nlines"', '"carriage\\rreturn"', '"tab\\there"'])
def test_a_system_name_with_a_newline_or_cr_is_refused_in_one_line(tmp_path, capsys, name):
    path = _write(tmp_path, SYSTEM.format(name=name))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert "system.name" in str(err.value) and "one line of printable text" in str(err.value)
    out = tmp_path / "model.yaml"
    assert cli.main(["run", "--batch", "--config", str(path), "--write-model", str(out)]) == 2
    message = capsys.readouterr().err.strip()
    assert message.count("\n") == 0 and "system.name" in message and not out.exists()


def test_output_names_with_a_newline_are_refused(tmp_path):
    text = SYSTEM.format(name="wb").replace("[x_D, x_B]", '["x_D", "x\\nB"]')
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, text))
    assert "system.output_names" in str(err.value) and "one line" in str(err.value)


def test_the_shipped_configurations_still_load():
    for path in sorted(config_dir().glob("*.yaml")):
        if path.name not in ("parameters.yaml", "diagnostic_analyzers.yaml"):  # the schema; the aggregator's file
            load_config(path)


# -- one number grammar: YAML/ROS decimal and exponent forms, no hex, no digit separators


@pytest.mark.parametrize(
    ("text", "value"),
    [("1e9", 1e9), ("010", 10), ("-.5", -0.5), ("7.", 7.0), ("+2", 2), ("1.0e-3", 1e-3), ("1E+2", 100.0)],
)
def test_the_grammar_reads_decimal_and_exponent_forms(text, value):
    assert parse_number(text) == value and type(parse_number(text)) is type(value)
    assert load_yaml(f"x: {text}\n")["x"] == value


@pytest.mark.parametrize("text", ["0x10", "1_9.4", "0o17", "1:30", "nan", "inf", "1e", "--1", ""])
def test_the_grammar_refuses_hex_separators_and_the_rest(text):
    assert parse_number(text) is None
    if text:
        assert isinstance(load_yaml(f"x: {text}\n")["x"], str)


def test_the_command_line_and_the_params_file_read_numbers_alike(tmp_path, capsys):
    for text, ok in (("1e4", True), ("0x10", False), ("1_000", False)):
        path = _write(tmp_path, SYSTEM.format(name="wb") + f"    run:\n      samples: {text}\n")
        if ok:
            assert load_config(path).run.samples == 10000
        else:
            with pytest.raises(ConfigError) as err:
                load_config(path)
            assert "run.samples" in str(err.value) and "must be a number" in str(err.value)
        if ok:  # read as 10000 samples: enough to run (it stops short of the diagnosis in a test: too few)
            assert whole_number(text) == 10000 and number(text) == 1e4
        else:
            with pytest.raises(SystemExit):
                cli.main(["run", "--batch", "--samples", text])
            assert f"argument --samples: '{text}' is not a whole number" in capsys.readouterr().err
    assert cli.main(["run", "--batch", "--samples", "1e2"]) == 3  # 100 samples: too few, said before simulating
    assert "window too short, known before simulating: 100 samples" in capsys.readouterr().out
