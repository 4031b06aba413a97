"""The parametric method through the ROS shell: /diagnostics, estimates, the node set."""

import json

import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from shipped import with_impact_samples
from simulated import diagnose_record

from pmr_ros import cli  # noqa: E402
from pmr_ros.config import load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array, read_estimates  # noqa: E402
from pmr_ros.core.results import ElementDiagnosis, ParametricResult  # noqa: E402
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402
from pmr_ros.ros.convert import diagnosis_statuses, diagnostic_array, element_level, estimates_message  # noqa: E402


@pytest.fixture(scope="module")
def parametric_diagnosis():
    config = load_config()
    record = simulate(config, samples=8192)
    return diagnose_record(record, config, method="parametric")


def test_diagnostics_carry_the_parametric_numbers_losslessly(parametric_diagnosis):
    window = {"window_samples": 8192, "first_sample": 0, "last_sample": 8191}
    statuses = diagnosis_statuses(
        parametric_diagnosis, prefix="pmr/wood_berry", hardware_id="wood_berry", window=window
    )
    msg = diagnostic_array(statuses, 8191.0)
    g21 = next(s for s in msg.status if s.name == "pmr/wood_berry/G21")
    assert "[" in g21.message and "MISMATCH" in g21.message  # numbers with intervals, for people
    back, info = diagnosis_from_array(msg)
    assert back.method == "parametric"
    assert back.elements == parametric_diagnosis.elements
    assert info["levels"]["G21"] == "ERROR"  # three properties off


def test_estimates_topic_has_the_intervals(parametric_diagnosis):
    values = read_estimates(estimates_message(parametric_diagnosis, 8191.0, "wood_berry"))
    g12 = values["G12"]
    assert (
        g12["parametric.gain_mismatch_pct_low"]
        < g12["parametric.gain_mismatch_pct"]
        < g12["parametric.gain_mismatch_pct_high"]
    )
    assert g12["parametric.delay_mismatch_samples"] == 1 and g12["parametric.delay_confidence"] > 0.95


def test_inconclusive_without_mismatch_is_a_warning(parametric_diagnosis):
    element = parametric_diagnosis.elements["G11"]

    def with_verdicts(gain, tau, delay):
        p = ParametricResult(
            **{**element.parametric.__dict__, "gain_verdict": gain, "tau_verdict": tau, "delay_verdict": delay}
        )
        return ElementDiagnosis(**{**element.__dict__, "parametric": p})

    inconclusive = with_verdicts("ok", "inconclusive", "ok")
    assert inconclusive.verdict == "inconclusive" and element_level(inconclusive) == DiagnosticStatus.WARN
    assert element_level(with_verdicts("ok", "ok", "ok")) == DiagnosticStatus.OK


def test_node_set_with_method_parametric_matches_batch(tmp_path, ros_domain, capsys):
    nodes_json, batch_json = tmp_path / "nodes.json", tmp_path / "batch.json"
    # 2,048 samples (was 8,192) and impact simulations of 1,024 (was 4,096): the two paths' elements, impact
    # included, are equal at any length
    config = with_impact_samples(tmp_path, 1024)
    common = ["run", "--method", "parametric", "--samples", "2048", "--config", str(config)]
    assert cli.main([*common, "--json", str(nodes_json)]) == 0
    assert cli.main([*common, "--batch", "--json", str(batch_json)]) == 0
    nodes, batch = json.loads(nodes_json.read_text()), json.loads(batch_json.read_text())
    assert nodes["method"] == batch["method"] == "parametric"
    assert nodes["elements"] == batch["elements"]
    assert any(e["impact"] is not None for e in nodes["elements"].values())  # compared with the rest
    assert "interval" in capsys.readouterr().out


def test_diagnostician_method_parameter_is_described_and_checked(ros):
    from rclpy.parameter import Parameter

    from pmr_ros.config import flatten_parameters
    from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode
    from pmr_ros.ros.parameters import parameter_overrides

    params = parameter_overrides(flatten_parameters(load_config().parameters))
    node = ros.add(PmrDiagnosticianNode(context=ros.context, parameter_overrides=params))
    assert "parametric" in node.describe_parameter("pmr.method").description
    assert node.describe_parameter("parametric.gain_tolerance_pct").description
    assert node.config.pmr.method == "parametric"
    refused = node.set_parameters([Parameter("pmr.method", value="bogus")])[0]
    assert not refused.successful and "pmr.method" in refused.reason and "classic, parametric" in refused.reason
    refused = node.set_parameters([Parameter("parametric.confidence_level", value=1.5)])[0]
    assert not refused.successful and "must be > 0 and < 1" in refused.reason
    ok = node.set_parameters([Parameter("pmr.method", value="classic")])[0]
    assert ok.successful and node.config.pmr.method == "classic"
