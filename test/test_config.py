"""Configuration: the shipped files load; bad values name the file and field."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmr_ros.config import ConfigError, config_dir, flatten_parameters, load_config, read_parameter_file


def test_shipped_wood_berry_is_the_standard_matrix(wood_berry):
    m = wood_berry.model
    np.testing.assert_allclose(m.gain, [[12.8, -18.9], [6.6, -19.4]])
    np.testing.assert_allclose(m.time_constant, [[16.7, 21.0], [10.9, 14.4]])
    np.testing.assert_array_equal(m.delay_samples, [[1, 3], [7, 3]])
    assert m.sample_time == 1.0 and m.output_names == ("x_D", "x_B")
    np.testing.assert_allclose(wood_berry.mismatch.gain_pct, [[10, 15], [-15, -10]])
    np.testing.assert_allclose(wood_berry.mismatch.time_constant_pct, [[10, 12], [-15, -8]])
    np.testing.assert_array_equal(wood_berry.mismatch.delay_samples, [[0, 1], [2, 0]])
    assert wood_berry.run.scenario == "full" and wood_berry.run.samples == 16384
    np.testing.assert_allclose(wood_berry.noise_std, [0.1, 0.1])  # a scalar default broadcast per channel


def test_three_by_three_loads():
    config = load_config(config_dir() / "three_by_three.yaml")
    assert config.model.gain.shape == (3, 3) and len(config.model.element_names()) == 9


def test_matrix_as_list_of_rows_is_accepted(tmp_path):
    path = _write(tmp_path, {"system": {"gain": [[12.8, -18.9], [6.6, -19.4]]}})
    np.testing.assert_allclose(load_config(path).model.gain, [[12.8, -18.9], [6.6, -19.4]])


def test_overrides_and_flatten():
    config = load_config(overrides={"run": {"seed": 9}})
    assert config.run.seed == 9
    flat = flatten_parameters(config.parameters)
    assert flat["system.gain"] == [12.8, -18.9, 6.6, -19.4] and flat["run.seed"] == 9


def _write(tmp_path: Path, change: dict, base: str = "wood_berry.yaml") -> Path:
    doc = yaml.safe_load((config_dir() / base).read_text())
    params = doc["/**"]["ros__parameters"]
    for block, values in change.items():
        params.setdefault(block, {}).update(values)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize(
    "change,field,words",
    [
        ({"system": {"input_names": ["reflux", "steam", "feed"]}}, "system.gain", "needs 6 entries (2x3, row by row)"),
        ({"system": {"gain": [[12.8, -18.9], [6.6]]}}, "system.gain", "must be 2 rows of 2"),
        ({"system": {"gain": [12.8, -18.9, 6.6]}}, "system.gain", "needs 4 entries"),
        ({"system": {"time_constant": [16.7, 21.0, 0.0, 14.4]}}, "system.time_constant[2] (G21)", "> 0"),
        ({"system": {"time_constant": [16.7, -21.0, 10.9, 14.4]}}, "system.time_constant[1] (G12)", ">= 0"),
        (
            {"system": {"gain": [12.8, 0.0, 6.6, -19.4]}},
            "system.gain[1] (G12)",
            "use element_type none for an empty cell",
        ),
        (
            {"system": {"element_type": ["foptd", "ramp", "foptd", "foptd"]}},
            "system.element_type[1] (G12)",
            "one of foptd",
        ),
        ({"system": {"element_type": ["foptd", "none"]}}, "system.element_type", "needs 4 entries"),
        ({"system": {"delay": [1.0, 3.5, 7.0, 3.0]}}, "system.delay[1]", "whole number of samples"),
        ({"system": {"gain": [12.8, math.nan, 6.6, -19.4]}}, "system.gain[1] (G12)", "finite"),
        ({"system": {"gain": [12.8, "big", 6.6, -19.4]}}, "system.gain[1] (G12)", "number"),
        ({"system": {"sample_time": 0.0}}, "system.sample_time", "> 0"),
        ({"run": {"scenario": "everything"}}, "run.scenario", "none, gain, time_constant, delay, full"),
        ({"noise": {"std": [0.1, -0.1]}}, "noise.std[1]", ">= 0"),
        ({"prbs": {"register_length": 30}}, "prbs.register_length", "<= 24"),
        ({"mpc": {"control_horizon": 80}}, "mpc.control_horizon", "prediction_horizon"),
        ({"mpc": {"u_min": 3.0}}, "mpc.u_min", "below"),
        ({"mpc": {"input_target": [0.0, 2.5]}}, "mpc.input_target", "within mpc.u_min .. mpc.u_max"),
        ({"mpc": {"input_target_weight": [1.0, 0.0]}}, "mpc.input_target_weight[1]", "> 0"),
        ({"mpc": {"ramp_filter_samples": -1.0}}, "mpc.ramp_filter_samples", ">= 0"),
        (
            {"prbs": {"register_length": 3}, "excitation": {"mv_dither_amplitude": 0.1}},
            "prbs.register_length",
            "2 primitive polynomials, fewer than the 4 PRBS channels (2 setpoints + 2 dithered inputs)",
        ),
        ({"mismatch": {"delay_samples": [0, 0, -9, 0]}}, "mismatch.delay_samples", "negative"),
        ({"pmr": {"window": "no_such_window"}}, "pmr.window", "window"),
    ],
)
def test_bad_values_name_file_field_and_value(tmp_path, change, field, words):
    path = _write(tmp_path, change)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert str(path) in message and field in message and words in message


def test_unreadable_and_malformed_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        read_parameter_file(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        read_parameter_file(bad)
    bad.write_text("system:\n  gain: 1\n")
    with pytest.raises(ConfigError, match="ros__parameters"):
        read_parameter_file(bad)


def test_every_default_comes_from_the_declaration(tmp_path):
    """A file with the system block alone gets every declared default, and the dataclasses carry them."""
    from pmr_ros.config import schema

    doc = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    path = tmp_path / "system_only.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"system": doc["/**"]["ros__parameters"]["system"]}}}))
    config = load_config(path)
    assert config.pmr.method == schema.parameter("pmr.method").default == "parametric"
    assert config.pmr.tau_index_threshold == schema.parameter("pmr.tau_index_threshold").default == 8.0
    assert config.parametric.max_condition == schema.parameter("parametric.max_condition").default
    assert config.diagnostician.window_samples == schema.parameter("diagnostician.window_samples").default
    np.testing.assert_array_equal(config.mismatch.gain_pct, 0.0)
    flat = flatten_parameters(config.parameters)
    for name, spec in schema.parameters().items():
        if not spec.required and spec.block not in ("system", "plant"):
            assert flat[name] == spec.default, name


def test_declared_scenarios_are_the_cores():
    from pmr_ros.config import schema
    from pmr_ros.core.sim.model import SCENARIOS

    assert schema.parameter("run.scenario").choices == SCENARIOS


@pytest.mark.parametrize(
    "change,field,words",
    [
        (
            {"mpc": {"predicton_horizon": 5}},
            "mpc.predicton_horizon",
            "unknown parameter; did you mean mpc.prediction_horizon?",
        ),
        ({"system": {"gian": [1.0, 2.0, 3.0, 4.0]}}, "system.gian", "did you mean system.gain?"),
        (
            {"diagnostician": {"windw_samples": 10}},
            "diagnostician.windw_samples",
            "did you mean diagnostician.window_samples?",
        ),
        ({"mcp": {"prediction_horizon": 5}}, "mcp", "unknown block"),
    ],
)
def test_a_typo_is_an_error_naming_the_nearest_known_key(tmp_path, change, field, words):
    path = _write(tmp_path, change)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {field}") and words in message
    if field == "mcp":
        assert "did you mean mpc?" in message


def test_a_block_that_is_not_a_mapping_says_so(tmp_path):
    for block, value in (("mpc", 5), ("noise", [1, 2])):
        with pytest.raises(ConfigError, match=f"{block} = .*must be a mapping of parameters"):
            load_config(_write_raw(tmp_path, {block: value}))


def _write_raw(tmp_path: Path, change: dict) -> Path:
    doc = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    doc["/**"]["ros__parameters"].update(change)
    path = tmp_path / "raw.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_configuration_without_a_model_is_refused(tmp_path):
    path = tmp_path / "no_system.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"mpc": {"prediction_horizon": 30}}}}))
    with pytest.raises(ConfigError, match="system: missing: a configuration needs the controller's model"):
        load_config(path)


def test_command_line_values_are_blamed_on_the_command_line():
    with pytest.raises(ConfigError) as info:
        load_config(overrides={"run": {"seed": 99999999999999999999}})
    assert str(info.value).startswith("command line: run.seed") and "wood_berry" not in str(info.value)


def test_a_file_that_is_not_utf8_is_one_line(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes((config_dir() / "wood_berry.yaml").read_bytes() + "# 20 \u00b0C\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"not UTF-8 text: byte 0xb0 on line \d+") as info:
        load_config(path)
    assert "\n" not in str(info.value)


def test_malformed_yaml_is_one_line_with_the_place(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("/**:\n  ros__parameters:\n    system: [1, 2\n")
    with pytest.raises(ConfigError, match=r"not valid YAML: .* at line \d+, column \d+") as info:
        load_config(path)
    assert "\n" not in str(info.value)


def _industrial(tmp_path: Path, **blocks) -> Path:
    params = {
        "system": {
            "name": "two_by_three",
            "sample_time": 1.0,
            "output_names": ["level", "temperature"],
            "input_names": ["feed", "steam", "reflux"],
            "gain": [0.05, 0.0, -0.04, 1.5, 2.0, 0.0],
            "time_constant": [0.0, 0.0, 0.0, 10.0, 14.0, 0.0],
            "delay": [2.0, 0.0, 1.0, 3.0, 1.0, 0.0],
            "element_type": ["integrating", "none", "integrating", "foptd", "foptd", "none"],
        },
        **blocks,
    }
    path = tmp_path / "industrial.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": params}}))
    return path


def test_non_square_models_with_empty_and_integrating_elements(tmp_path):
    config = load_config(_industrial(tmp_path))
    model = config.model
    assert (model.n_outputs, model.n_inputs) == (2, 3) and config.warnings == ()
    assert list(model.element_type.ravel()) == ["integrating", "none", "integrating", "foptd", "foptd", "none"]
    assert np.isnan(model.time_constant[0, 0]) and model.gain[0, 1] == 0.0 and model.slowest_time_constant == 14.0
    elements = model.element_models()
    assert elements["G11"][2].kind == "integrating" and elements["G11"][2].time_constant is None
    assert elements["G12"][2].kind == "none"


def test_an_integrating_element_given_a_time_constant_is_a_warning(tmp_path):
    path = _industrial(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["/**"]["ros__parameters"]["system"]["time_constant"][0] = 7.0
    path.write_text(yaml.safe_dump(doc))
    config = load_config(path)
    assert config.warnings == (f"{path}: system.time_constant[0] (G11) = 7 is ignored: G11 is integrating",)
    assert np.isnan(config.model.time_constant[0, 0])


def test_a_plant_block_is_the_plant_and_excludes_a_mismatch(tmp_path):
    plant = {
        "gain": [0.05, 0.3, -0.04, 1.5, 2.0, 0.0],
        "time_constant": [0.0, 8.0, 0.0, 10.0, 14.0, 0.0],
        "delay": [2.0, 4.0, 1.0, 3.0, 1.0, 0.0],
        "element_type": ["integrating", "foptd", "integrating", "foptd", "foptd", "none"],
    }
    config = load_config(_industrial(tmp_path, plant=plant))
    truth = config.plant()
    assert truth.element_type[0, 1] == "foptd" and truth.gain[0, 1] == 0.3 and truth.delay_samples[0, 1] == 4
    assert config.model.element_type[0, 1] == "none"  # an unmodeled interaction
    with pytest.raises(ConfigError, match="mismatch: cannot be given with a plant block"):
        load_config(_industrial(tmp_path, plant=plant, mismatch={"gain_pct": 10.0}))
    with pytest.raises(ConfigError, match="run.scenario: cannot be given with a plant block"):
        load_config(_industrial(tmp_path, plant=plant, run={"scenario": "gain"}))
    bad = {**plant, "element_type": ["integrating", "foptd", "ramp", "foptd", "foptd", "none"]}
    with pytest.raises(ConfigError, match=r"plant.element_type\[2\] \(G13\) = 'ramp'"):
        load_config(_industrial(tmp_path, plant=bad))


def test_dither_settings_are_per_input(tmp_path):
    config = load_config(_industrial(tmp_path, excitation={"mv_dither_amplitude": [0.1, 0.0, 0.2]}))
    np.testing.assert_array_equal(config.excitation.mv_dither_amplitude, [0.1, 0.0, 0.2])
    assert config.excitation.active and not load_config(_industrial(tmp_path)).excitation.active
    with pytest.raises(ConfigError, match="excitation.mv_dither_amplitude = .*needs 3 entries"):
        load_config(_industrial(tmp_path, excitation={"mv_dither_amplitude": [0.1, 0.2]}))
