"""Routine operation in the configuration: measured disturbances, CV zones, setpoint steps, manual stretches."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from pmr_ros.config import ConfigError, config_dir, load_config

DVS = {
    "disturbance_names": ["feed_rate", "feed_light"],
    "disturbance_gain": [3.8, 4.9, 4.9, 6.0],
    "disturbance_time_constant": [14.9, 13.2, 13.2, 15.0],
    "disturbance_delay": [8.0, 3.0, 3.0, 0.0],
}
"""Two DVs on Wood-Berry (the feed-rate column is the literature's feed disturbance, 3.8 e^-8s/(14.9s+1) ...)."""


def _config(**blocks):
    system = {**DVS, **blocks.pop("system", {})}
    return load_config(overrides={"system": system, **blocks})


def test_the_default_has_no_disturbances_zones_steps_or_manual_stretches(wood_berry):
    assert wood_berry.disturbance_model is None and wood_berry.disturbance_plant() is None
    assert not wood_berry.mpc.zones_active and wood_berry.mpc.output_mode == ("setpoint", "setpoint")
    assert wood_berry.prbs.mode == "prbs" and not wood_berry.manual.active


def test_the_disturbance_model_is_read_row_major_with_the_dv_names():
    config = _config()
    d = config.disturbance_model
    assert d is not None and d.input_names == ("feed_rate", "feed_light") and d.output_names == ("x_D", "x_B")
    np.testing.assert_allclose(d.gain, [[3.8, 4.9], [4.9, 6.0]], rtol=0, atol=0)
    np.testing.assert_allclose(d.time_constant, [[14.9, 13.2], [13.2, 15.0]], rtol=0, atol=0)
    np.testing.assert_array_equal(d.delay_samples, [[8, 3], [3, 0]])


def test_the_true_dv_elements_carry_the_dv_mismatch_of_the_scenario():
    mismatch = {"disturbance_gain_pct": [20.0, 0.0, 0.0, -10.0], "disturbance_delay_samples": [0, 2, 0, 0]}
    config = _config(mismatch=mismatch)
    truth = config.disturbance_plant()
    assert truth is not None and config.disturbance_model is not None
    np.testing.assert_allclose(truth.gain, [[3.8 * 1.2, 4.9], [4.9, 6.0 * 0.9]], rtol=1e-12)
    np.testing.assert_array_equal(truth.delay_samples, [[8, 5], [3, 0]])
    np.testing.assert_allclose(config.disturbance_plant("none").gain, config.disturbance_model.gain, rtol=0)
    np.testing.assert_allclose(config.disturbance_plant("gain").delay, config.disturbance_model.delay, rtol=0)


def test_the_plant_block_may_give_the_true_dv_elements(tmp_path):
    base = load_config()
    plant = {
        "gain": base.model.gain.ravel().tolist(),
        "time_constant": base.model.time_constant.ravel().tolist(),
        "delay": base.model.delay.ravel().tolist(),
        "disturbance_names": DVS["disturbance_names"],
        "disturbance_gain": [1.0, 2.0, 3.0, 4.0],
        "disturbance_time_constant": 5.0,
        "disturbance_element_type": ["foptd", "none", "foptd", "integrating"],
    }
    doc = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    system = doc["/**"]["ros__parameters"]["system"]
    path = tmp_path / "plant.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"system": {**system, **DVS}, "plant": plant}}}))
    config = load_config(path)
    truth = config.disturbance_plant()
    assert truth is not None
    np.testing.assert_allclose(truth.gain, [[1.0, 0.0], [3.0, 4.0]], rtol=0)
    assert truth.element_type.tolist() == [["foptd", "none"], ["foptd", "integrating"]]


@pytest.mark.parametrize(
    "blocks,field,words",
    [
        ({"system": {"disturbance_names": ["feed", "feed"]}}, "system.disturbance_names", "names must be unique"),
        ({"system": {"disturbance_names": ["feed", "reflux"]}}, "system.disturbance_names", "already an input's name"),
        ({"system": {"disturbance_gain": [1.0, 2.0, 3.0]}}, "system.disturbance_gain", "needs 4 entries (2x2"),
        ({"system": {"disturbance_delay": [1.0, 2.0]}}, "system.disturbance_delay", "needs 4 entries (2x2"),
        (
            {"system": {"disturbance_time_constant": [14.9, 0.0, 13.2, 15.0]}},
            "system.disturbance_time_constant[1] (D12)",
            "must be > 0",
        ),
        (
            {"system": {"disturbance_element_type": ["foptd", "fopdt", "foptd", "foptd"]}},
            "system.disturbance_element_type[1] (D12)",
            "must be one of foptd, integrating, none, tf, step_response",
        ),
        ({"disturbance_signal": {"kind": ["steps", "jumps"]}}, "disturbance_signal.kind[1]", "steps, walk, prbs"),
        ({"mismatch": {"disturbance_gain_pct": [1.0, 2.0]}}, "mismatch.disturbance_gain_pct", "needs 4 entries"),
        ({"mpc": {"output_low": [0.0, 2.0], "output_high": [1.0, 1.0]}}, "mpc.output_low[1] (x_B)", "must not exceed"),
        ({"mpc": {"output_mode": ["setpoint", "band"]}}, "mpc.output_mode[1]", "setpoint, zone"),
        ({"run": {"manual_stretches": [[0, 10, "boilup"]]}}, "run.manual_stretches[0]", "is no input's name"),
        ({"run": {"manual_stretches": [[0, 10, 2]]}}, "run.manual_stretches[0]", "is no input index (0 .. 1)"),
        ({"run": {"manual_stretches": [[0, 0, 1]]}}, "run.manual_stretches[0]", "at least 1 sample"),
        ({"run": {"manual_stretches": [0, 10, 1, 50]}}, "run.manual_stretches", "flat list holds start, length"),
        ({"run": {"manual_stretches": [0, 10, 1, 50, 5, 3]}}, "run.manual_stretches[1]", "is no input index"),
        ({"prbs": {"mode": "ramps"}}, "prbs.mode", "one of prbs, steps"),
    ],
)
def test_bad_routine_input_is_one_line_naming_the_field(blocks, field, words):
    with pytest.raises(ConfigError) as err:
        _config(**blocks)
    message = str(err.value)
    assert "\n" not in message and f": {field}" in message and words in message, message


def test_a_dv_field_without_dv_names_is_refused():
    with pytest.raises(ConfigError, match="system.disturbance_gain: is given without system.disturbance_names"):
        load_config(overrides={"system": {"disturbance_gain": [1.0, 2.0]}})


def test_zones_read_infinite_limits_and_modes():
    mpc = {"output_mode": ["setpoint", "zone"], "output_low": [-math.inf, -0.5], "output_high": [math.inf, 1.5]}
    config = _config(mpc=mpc)
    assert config.mpc.output_mode == ("setpoint", "zone") and config.mpc.zones_active
    np.testing.assert_array_equal(config.mpc.output_low, [-np.inf, -0.5])
    np.testing.assert_array_equal(config.mpc.limited_outputs, [False, True])


def test_a_params_file_reads_yaml_infinities_as_limits(tmp_path):
    path = tmp_path / "zones.yaml"
    text = (config_dir() / "wood_berry.yaml").read_text()
    zones = "    mpc:\n      output_low: [-.inf, -0.5]\n      output_high: [.inf, .Inf]\n      output_mode: zone\n"
    path.write_text(text.replace("    mismatch:\n", zones + "    mismatch:\n"))
    config = load_config(path)
    np.testing.assert_array_equal(config.mpc.output_low, [-np.inf, -0.5])
    np.testing.assert_array_equal(config.mpc.output_high, [np.inf, np.inf])
    assert config.mpc.output_mode == ("zone", "zone")
    with pytest.raises(ConfigError, match="mpc.output_low.*must be finite|mpc.output_low.*number"):
        path.write_text(text.replace("    mismatch:\n", "    mpc:\n      output_low: .nan\n    mismatch:\n"))
        load_config(path)


def test_manual_stretches_resolve_names_and_indices():
    config = load_config(overrides={"run": {"manual_stretches": [[100, 50, "reflux"], [300, 20, 1]]}})
    assert config.manual.stretches == ((100, 50, 0), (300, 20, 1)) and config.manual.moves == 3


def test_setpoint_steps_and_disturbance_signal_are_read():
    prbs = {"mode": "steps", "step_interval_samples": 240.0, "step_amplitude": [0.5, 0.25]}
    signal = {"kind": ["walk", "prbs"], "amplitude": [1.0, 0.0], "mean_interval_samples": 60.0}
    config = _config(prbs=prbs, disturbance_signal=signal)
    assert config.prbs.mode == "steps" and config.prbs.step_interval_samples == 240.0
    np.testing.assert_array_equal(config.prbs.step_amplitude, [0.5, 0.25])
    assert config.disturbance_signal.kind == ("walk", "prbs")
    np.testing.assert_array_equal(config.disturbance_signal.mean_interval_samples, [60.0, 60.0])


def test_the_number_grammar_reads_yaml_infinities_not_nan():
    from pmr_ros.config.numbers import parse_number

    assert parse_number("-.inf") == -math.inf and parse_number("+.INF") == math.inf
    assert parse_number(".nan") is None and parse_number("inf") is None


def test_a_written_model_file_and_a_new_system_block_keep_the_dv_model(tmp_path):
    from pmr_ros.config.write import model_params_text, system_tree
    from pmr_ros.contract.model_topics import with_system

    config = _config()
    path = tmp_path / "model.yaml"
    path.write_text(model_params_text(config.model, settings=config.parameters))
    again = load_config(path)
    assert again.disturbance_model is not None and config.disturbance_model is not None
    np.testing.assert_array_equal(again.disturbance_model.gain, config.disturbance_model.gain)
    switched = with_system(config, system_tree(config.model), "test")
    assert switched.disturbance_model is not None
    np.testing.assert_array_equal(switched.disturbance_model.delay, config.disturbance_model.delay)


def test_flat_manual_stretches_are_the_nested_ones_and_the_tree_keeps_them_flat():
    nested = load_config(overrides={"run": {"manual_stretches": [[100, 50, "reflux"], [300, 20, 1]]}})
    flat = load_config(overrides={"run": {"manual_stretches": [100, 50, 0, 300, 20, 1]}})
    assert flat.manual.stretches == nested.manual.stretches == ((100, 50, 0), (300, 20, 1))
    # the effective tree (what the nodes and a bag's run_config get) holds the form a ROS parameter holds
    assert nested.parameters["run"]["manual_stretches"] == [100, 50, 0, 300, 20, 1]
    assert load_config().parameters["run"]["manual_stretches"] == []
