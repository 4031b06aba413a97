"""Params files a harsh probe sent (issue 21, item 12): the plant block as documented, one-line names."""

from __future__ import annotations

import pytest

from pmr_ros import cli
from pmr_ros.config import ConfigError, config_dir, load_config

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
        if path.name != "parameters.yaml":
            load_config(path)
