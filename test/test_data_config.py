"""The ``data`` block of a params file: declared defaults, strict values, and no node sees it."""

from __future__ import annotations

import pytest

from pmr_ros.config import ConfigError, DataSettings, flatten_parameters, load_config
from pmr_ros.config.data import data_settings
from pmr_ros.config.schema import Shape, parameter

SYSTEM = """/**:
  ros__parameters:
    system:
      sample_time: 1.0
      output_names: [a, b]
      input_names: [p, q, s]
      gain: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
      time_constant: [5.0, 5.0, 5.0, 5.0, 5.0, 5.0]
      delay: [0.0, 1.0, 0.0, 1.0, 0.0, 1.0]
"""


def _config(tmp_path, data: str = ""):
    path = tmp_path / "c.yaml"
    path.write_text(SYSTEM + (f"    data:\n{data}" if data else ""))
    return load_config(path)


def test_a_model_alone_is_a_configuration_for_data(tmp_path):
    config = _config(tmp_path)
    assert config.data == DataSettings(
        time_column="time",
        time_format="detected",
        time_unit_s=1.0,
        grid_tolerance=0.25,
        setpoint_columns=(),
        input_columns=(),
        output_columns=(),
        dither_columns=(),
        bad_values=(-9999.0, -10000.0, "Bad", "bad", ""),
        outlier_mad=100.0,
        frozen_samples=20,
        mode_column="",
        mode_on_values=(1.0, "ON", "On", "on", "AUTO", "Auto", "auto"),
    )


def test_column_lists_per_channel(tmp_path):
    config = _config(
        tmp_path,
        "      output_columns: [TI101.PV, TI102.PV]\n      input_columns: [FC1.OP, FC2.OP, FC3.OP]\n"
        "      bad_values: [-1, 'I/O Timeout']\n      mode_column: MODE\n",
    )
    assert config.data.output_columns == ("TI101.PV", "TI102.PV")
    assert config.data.input_columns == ("FC1.OP", "FC2.OP", "FC3.OP")
    assert config.data.setpoint_columns == ()
    assert config.data.bad_values == (-1.0, "I/O Timeout")
    assert config.data.mode_column == "MODE"


@pytest.mark.parametrize(
    ("data", "field", "words"),
    [
        ("      output_columns: [TI101.PV]\n", "data.output_columns", "needs 2 column names (one per output), got 1"),
        ("      input_columns: [A, A, B]\n", "data.input_columns", "unique"),
        ("      input_columns: A\n", "data.input_columns", "must be a list of 3 column names"),
        ("      bad_values: -9999\n", "data.bad_values", "must be a list of numbers and strings"),
        ("      bad_values: [.nan]\n", "data.bad_values[0]", "finite"),
        ("      time_format: excel\n", "data.time_format", "one of detected, iso, seconds"),
        ("      grid_tolerance: 0.5\n", "data.grid_tolerance", "< 0.5"),
        ("      frozen_sample: 5\n", "data.frozen_sample", "did you mean data.frozen_samples"),
    ],
)
def test_bad_data_values_name_the_field(tmp_path, data, field, words):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, data)
    assert err.value.field == field and words in str(err.value)
    assert str(tmp_path / "c.yaml") in str(err.value) and "\n" not in str(err.value)


def test_the_new_kinds_check_their_values():
    columns = parameter("data.input_columns")
    assert columns.check([], source="s", shape=Shape(2, 3)) == ()
    assert columns.check(["x", "y", "z"], source="s", shape=Shape(2, 3)) == ("x", "y", "z")
    with pytest.raises(ConfigError, match="column names"):
        columns.check(["x", "", "z"], source="s", shape=Shape(2, 3))
    values = parameter("data.mode_on_values")
    assert values.check([], source="s") == ()
    assert values.check([2, "AUTO"], source="s") == (2.0, "AUTO")
    with pytest.raises(ConfigError, match="must be a number"):
        values.check([True], source="s")


def test_data_settings_reads_every_declared_key():
    keys = [name.split(".", 1)[1] for name in flatten_parameters({"data": load_config().parameters["data"]})]
    got = data_settings(lambda name: f"value of {name}", keys)
    assert got.time_column == "value of data.time_column" and got.mode_on_values == "value of data.mode_on_values"


def test_no_node_declares_the_data_block(wood_berry):
    from pmr_ros.config.schema import parameters

    assert all(not p.nodes for name, p in parameters().items() if name.startswith("data."))
    # read by pmr-ros alone: the data block, --adapt's rollback tolerance, the simulated manual stretches
    alone = ("data.", "adapt.", "run.manual_")
    assert all(p.nodes for name, p in parameters().items() if not name.startswith(alone))
    # the controller of the control impact: the live diagnostician takes it as the batch path does
    assert all(p.nodes == ("pmr_diagnostician",) for name, p in parameters().items() if name.startswith("controller."))
    assert not parameters()["adapt.ise_rise_tolerance_pct"].nodes
    assert "bad_values" in wood_berry.parameters["data"]  # in the effective tree, with its mixed-type list
