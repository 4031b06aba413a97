"""Node parameters share the config files' dotted names and the core's validation."""

from __future__ import annotations

import math

import pytest

from pmr_ros.core.config import ConfigError, load_config
from pmr_ros.ros import parameters as p


def test_default_parameters_are_the_config_files_flattened():
    flat = p.default_parameters()
    assert flat["system.gain"] == [12.8, -18.9, 6.6, -19.4]
    assert flat["prbs.clock_period"] == 8
    assert flat["diagnostician.window_samples"] == 16384
    assert flat["simulation.real_time_rate_hz"] == 0.0


def test_descriptions_come_from_the_config_comments():
    text = "/**:\n  ros__parameters:\n    a:\n      b: 1   # the b [s]\n      c: 2\n    d: x  # dee\n"
    assert p.comment_descriptions(text) == {"a.b": "the b [s]", "d": "dee"}
    assert "LFSR" in p.describe("prbs.register_length")
    assert p.describe("system.gain").startswith("K")
    assert "row-major" in p.describe("no.such.parameter")


def test_nested_inverts_flatten_and_validate_uses_the_core():
    flat = dict(p.default_parameters())
    config, settings = p.validate(flat, "test")
    assert config.model.element_names() == ["G11", "G12", "G21", "G22"]
    assert settings.lockstep and settings.window_samples == 16384
    assert p.nested({"a.b": 1, "a.c": 2, "d": 3}) == {"a": {"b": 1, "c": 2}, "d": 3}
    flat["system.gain"] = [1.0, 2.0, 3.0]
    with pytest.raises(ConfigError, match=r"system.gain = \[1.0, 2.0, 3.0\]: needs 4 entries"):
        p.validate(flat, "test")


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        ("simulation.real_time_rate_hz", -1.0, "must be >= 0"),
        ("diagnostician.window_samples", 2.5, "whole number"),
        ("diagnostician.stale_timeout_s", 0.0, "must be > 0"),
        ("diagnostician.min_samples", 20000, "must not exceed diagnostician.window_samples"),
        ("diagnostician.max_lag_samples", "x", "finite number"),
    ],
)
def test_parse_node_settings_names_the_bad_parameter(field, value, words):
    tree = p.nested({**p.default_parameters(), field: value})
    with pytest.raises(ConfigError, match=words) as err:
        p.parse_node_settings(tree, "node")
    assert err.value.field == field


def test_missing_node_setting_is_reported():
    tree = load_config().parameters
    tree = {k: v for k, v in tree.items() if k != "diagnostician"}
    with pytest.raises(ConfigError, match="diagnostician.window_samples = None: missing"):
        p.parse_node_settings(tree, "node")


def test_ros_value_and_parameter_overrides():
    assert p.ros_value([1, 2.5]) == [1.0, 2.5]
    assert p.ros_value([1, 2]) == [1, 2]
    assert p.ros_value(3) == 3
    params = p.parameter_overrides({"system.gain": [1, 2.5], "run.seed": 4})
    assert [(x.name, x.value) for x in params] == [("system.gain", [1.0, 2.5]), ("run.seed", 4)]
    assert p.FLOAT_RANGES["pmr.tau_band"][1] == math.pi
