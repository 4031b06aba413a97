"""Node parameters come from the declaration: which node declares what, descriptors, values."""

from __future__ import annotations

import pytest

from pmr_ros.config import schema
from pmr_ros.ros import parameters as p


def test_each_node_declares_the_blocks_it_uses():
    names = {
        node: {q.name for q in p.node_parameters(node)}
        for node in ("wood_berry_plant", "prbs_setpoint", "mpc_controller", "pmr_diagnostician")
    }
    system = {q.name for q in schema.blocks()["system"].parameters}
    assert all(system <= declared for declared in names.values())
    # the diagnostician simulates the configured MPC and setpoints for the control impact
    assert (
        "mpc.prediction_horizon" in names["mpc_controller"] and "mpc.prediction_horizon" in names["pmr_diagnostician"]
    )
    assert "prbs.amplitude" in names["pmr_diagnostician"] and "mpc.u_max" not in names["wood_berry_plant"]
    assert "pmr.method" in names["pmr_diagnostician"] and "pmr.method" not in names["wood_berry_plant"]
    assert "run.seed" in names["prbs_setpoint"] and "run.samples" not in names["prbs_setpoint"]
    assert "mismatch.gain_pct" in names["wood_berry_plant"] and "mismatch.gain_pct" not in names["mpc_controller"]
    assert "simulation.real_time_rate_hz" in names["mpc_controller"]


def test_descriptors_carry_the_declared_description_range_and_read_only_flag():
    spec = schema.parameter("prbs.register_length")
    desc = p.descriptor(spec, read_only=True)
    assert "LFSR" in desc.description and desc.read_only
    assert (desc.integer_range[0].from_value, desc.integer_range[0].to_value) == (3, 24)
    tau_band = p.descriptor(schema.parameter("pmr.tau_band"), read_only=False)
    assert (
        not tau_band.read_only
        and "<= 3.14159" in tau_band.additional_constraints
        and "> 0" in tau_band.additional_constraints
    )
    assert p.descriptor(schema.parameter("system.gain"), read_only=False).dynamic_typing


def test_ros_value_and_parameter_overrides():
    assert p.ros_value([1, 2.5]) == [1.0, 2.5]
    assert p.ros_value([1, 2]) == [1, 2]
    assert p.ros_value(3) == 3
    assert p.plain_value((1, 2)) == [1, 2]
    params = p.parameter_overrides({"system.gain": [1, 2.5], "run.seed": 4})
    assert [(x.name, x.value) for x in params] == [("system.gain", [1.0, 2.5]), ("run.seed", 4)]
    # the data block is no node's (its mixed lists are no ROS parameter); a typo stays for the node to refuse
    params = p.parameter_overrides({"data.bad_values": [-9999, "Bad"], "run.sed": 4})
    assert [x.name for x in params] == ["run.sed"]


@pytest.mark.parametrize(
    ("name", "value", "words"),
    [
        ("diagnostician.window_samples", 2.5, "whole number"),
        ("diagnostician.stale_timeout_s", 0.0, "must be > 0"),
        ("simulation.real_time_rate_hz", -1.0, "must be >= 0"),
        ("pmr.overlap", 1.0, "< 1"),
        ("pmr.method", "bayes", "one of classic, parametric"),
    ],
)
def test_declared_checks_name_the_parameter(name, value, words):
    with pytest.raises(schema.ConfigError, match=words) as err:
        schema.parameter(name).check(value, source="node")
    assert err.value.field == name
