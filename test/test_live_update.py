"""The live model update through the ROS shell: impact on /diagnostics, the model topics, the controller's switch."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from rclpy.parameter import Parameter
from ros_fixtures import spin_until  # noqa: E402

from pmr_ros.config import ConfigError, flatten_parameters, load_config
from pmr_ros.config.schema import parameter
from pmr_ros.config.write import system_tree
from pmr_ros.contract.layout import diagnosis_from_array, status_values
from pmr_ros.contract.model_topics import active_model_text, read_active_model, system_parameters, with_system
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.results import compare_diagnoses
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.ros import convert
from pmr_ros.ros.parameters import parameter_overrides, ros_value
from pmr_ros.service.closing import close_diagnosis, model_file_text

SAMPLES = 4096
"""The module's run (was 8,192): the node set's impact is compared with the batch's on the same data, equal at any
length; every element of the full scenario is a mismatch at 4,096 samples (G21's gain -15.0 %, test_nodes)."""
WINDOW = {"window_samples": SAMPLES, "first_sample": 0, "last_sample": SAMPLES - 1}


@pytest.fixture(scope="module")
def wood_berry():
    config = load_config(overrides={"pmr": {"method": "parametric"}, "run": {"samples": SAMPLES}})
    record = simulate(config)
    diagnosis = diagnose(record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    return config, close_diagnosis(diagnosis, config)


def test_the_impact_travels_on_diagnostics_and_reads_back(wood_berry):
    _, closed = wood_berry
    assert closed.diagnosis.impact is not None and closed.proposes
    statuses = convert.diagnosis_statuses(
        closed.diagnosis, prefix="pmr/wood_berry", hardware_id="wood_berry", window=WINDOW
    )
    values = status_values(statuses[0])
    assert values["impact.rank"] in (1, 2, 3, 4) and values["impact.ise_ratio"] > 0
    assert values["impact_all.ise_ratio"] == closed.diagnosis.impact.ise_ratio  # lossless
    back, _ = diagnosis_from_array(convert.diagnostic_array(statuses, SAMPLES - 1.0), prefix="pmr/wood_berry")
    assert back == closed.diagnosis  # every element's impact and the all-together figures
    assert compare_diagnoses(back, closed.diagnosis) == []


def test_the_proposal_is_the_corrected_model_with_the_verdicts_it_rests_on(wood_berry):
    config, closed = wood_berry
    text = model_file_text(config, closed.update, closed.diagnosis, window=WINDOW)
    assert f"(samples 0..{SAMPLES - 1})" in text and "verdict G21: mismatch - gain" in text
    changed = with_system(config, flatten_nested(system_parameters(text, "proposal")), "proposal")
    assert changed.model.element_models() == closed.update.model.element_models()
    with pytest.raises(ConfigError, match="system: missing"):
        system_parameters("/**:\n  ros__parameters:\n    mpc: {}\n", "proposal")


def flatten_nested(flat):
    """``system.*`` dotted values back to the block."""
    return {key.split(".", 1)[1]: value for key, value in flat.items()}


def test_the_active_model_payload_round_trips_and_refuses_garbage():
    model = load_config().model
    active = read_active_model(active_model_text(model, first_sample=12, revision=3), "t")
    assert (active.first_sample, active.revision) == (12, 3) and active.system == system_tree(model)
    for text, words in (("[1, 2]", "system: missing"), ("first_sample: -1\nrevision: 0\nsystem: {}", "first_sample")):
        with pytest.raises(ConfigError, match=words):
            read_active_model(text, "t")


def test_only_the_system_block_is_live_for_the_controller():
    assert parameter("system.gain").live == ("mpc_controller", "pmr_diagnostician")
    assert parameter("mpc.prediction_horizon").live == ()


def _controller(context, config):
    from pmr_ros.nodes.mpc_controller import MpcControllerNode

    params = parameter_overrides(flatten_parameters(config.parameters))
    return MpcControllerNode(context=context, parameter_overrides=params)


def _system_change(model):
    return [
        Parameter(name, value=ros_value(v)) for name, v in flatten_parameters({"system": system_tree(model)}).items()
    ]


def test_the_controller_takes_a_new_model_atomically_and_refuses_a_bad_one(ros_context):
    from pmr_ros.contract.topics import topic
    from pmr_ros.ros.messages import message_class, qos_profile

    config = load_config()
    node = _controller(ros_context, config)
    listener = rclpy.create_node("model_listener", context=ros_context)
    executor = rclpy.executors.SingleThreadedExecutor(context=ros_context)
    heard = []
    try:
        t = topic("active_model")
        listener.create_subscription(message_class(t), t.name, lambda m: heard.append(m.data), qos_profile(t.qos))
        executor.add_node(node)
        executor.add_node(listener)
        assert spin_until(executor, lambda: len(heard) == 1, 30.0)
        assert read_active_model(heard[0], "t").revision == 0
        before = node.model
        refused = node.set_parameters([Parameter("mpc.prediction_horizon", value=50)])[0]
        assert not refused.successful  # read-only for the controller
        short = node.set_parameters_atomically([Parameter("system.gain", value=[1.0, 2.0, 3.0])])
        assert not short.successful and "system.gain" in short.reason and "\n" not in short.reason
        renamed = replace(config.model, output_names=("a", "b"))
        other = node.set_parameters_atomically(_system_change(renamed))
        assert not other.successful and "channels" in other.reason and node.model is before
        new = replace(config.model, gain=config.model.gain * 1.1)
        assert node.set_parameters_atomically(_system_change(new)).successful
        assert node.model is before  # switched at the next sample boundary, not in the callback
        node._y[0], node._r[0] = np.zeros(2), np.zeros(2)
        node._answer()
        assert node.model is not before
        assert spin_until(executor, lambda: len(heard) == 2, 30.0)
        active = read_active_model(heard[-1], "t")
        assert (active.revision, active.first_sample) == (1, 0) and active.system == system_tree(new)
        np.testing.assert_array_equal(node.controller.model.gain, new.gain)
    finally:
        executor.shutdown(timeout_sec=1.0)
        listener.destroy_node()
        node.destroy_node()


def test_the_node_sets_diagnostics_carry_the_impact_the_batch_computes(ros_domain, wood_berry):
    """In-process: the diagnostician's statuses hold the impact of the same data's batch diagnosis."""
    from pmr_ros.node_set import NodeSetOptions, run_node_set

    config, closed = wood_berry
    result = run_node_set(config, NodeSetOptions(private=True))
    assert result.diagnosis.impact is not None
    assert all((e.impact is not None) == (e.verdict == "mismatch") for e in result.diagnosis)
    # the same r, u, y sample for sample: verdicts exact, numbers and impact figures within the stated tolerance
    assert compare_diagnoses(result.diagnosis, closed.diagnosis) == []
