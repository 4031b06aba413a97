"""The four nodes in one process over real topics, and the diagnostician against bad traffic.

Each test runs in its own ROS domain and rclpy Context (test/ros_fixtures.py).
One run of the paper's full-mismatch scenario (FULL_RUN_SAMPLES) happens once per module.
"""

from __future__ import annotations

import json
import time
from functools import cache

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from rcl_interfaces.msg import ParameterType  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from ros_fixtures import claimed_domain, ros_environment, spin_until  # noqa: E402
from shipped import with_impact_samples  # noqa: E402

from pmr_ros import cli  # noqa: E402
from pmr_ros.config import ConfigError, config_dir, flatten_parameters, load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.contract.topics import topic  # noqa: E402
from pmr_ros.core.pmr.diagnosis import diagnose_stretches  # noqa: E402
from pmr_ros.core.records import Record  # noqa: E402
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402
from pmr_ros.node_set import NodeSetOptions, run_node_set  # noqa: E402
from pmr_ros.nodes.bag_player import discovery_settle_s  # noqa: E402
from pmr_ros.nodes.plant import PlantNode  # noqa: E402
from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode  # noqa: E402
from pmr_ros.ros.convert import run_complete_message, signal_message  # noqa: E402
from pmr_ros.ros.messages import message_class, qos_profile  # noqa: E402
from pmr_ros.ros.parameters import parameter_overrides  # noqa: E402
from pmr_ros.service.closing import close_diagnosis  # noqa: E402

pytestmark = pytest.mark.ros

EXPECTED_GAIN = {"G11": 1.10, "G12": 1.15, "G21": 0.85, "G22": 0.90}
EXPECTED_TAU_SIGN = {"G11": 1, "G12": 1, "G21": -1, "G22": -1}
EXPECTED_DELAY = {"G11": 0, "G12": 1, "G21": 2, "G22": 0}

FULL_RUN_SAMPLES = 4096
"""The module's run of the full-mismatch scenario (was the configured 16,384: 52 s of a worker, the loop ~2.6 ms a
sample).  Measured with the batch core (the node set's data equal it, test below): the gain mismatch is within
1.21 pp of the injected one at 4,096 samples with the run's seed (0.55 pp at 16,384), at most 1.43 pp over seeds 1-10,
against the 3 pp checked; every verdict "mismatch", every tau sign and delay as injected at every seed."""


@pytest.fixture(scope="module")
def full_run():
    """The node set on the paper's full-mismatch scenario, FULL_RUN_SAMPLES samples, r/u/y recorded from the topics."""
    config = load_config(overrides={"run": {"samples": FULL_RUN_SAMPLES}})
    with claimed_domain() as domain, pytest.MonkeyPatch.context() as mp:
        for key, value in ros_environment(domain).items():
            mp.setenv(key, value)
        return run_node_set(config, NodeSetOptions(domain_id=domain, record=True))


def test_node_set_verdicts_from_diagnostics_match_the_injected_mismatch(full_run):
    d = full_run.diagnosis
    assert d.status == "ok", d.reason
    n = FULL_RUN_SAMPLES
    assert full_run.info["window_samples"] == n and full_run.info["last_sample"] == n - 1
    assert d.method == "parametric"  # the declared default
    for name, element in d.elements.items():
        p = element.parametric
        assert p.gain_mismatch_pct == pytest.approx(100 * (EXPECTED_GAIN[name] - 1), abs=3.0), name
        assert np.sign(p.tau_mismatch_pct) == EXPECTED_TAU_SIGN[name], name
        assert p.delay_mismatch_samples == EXPECTED_DELAY[name], name
        assert element.verdict == "mismatch"
        assert full_run.info["levels"][name] in ("WARN", "ERROR")
        assert full_run.info["messages"][name] == element.summary()
        assert full_run.estimates[name]["parametric.gain_mismatch_pct"] == p.gain_mismatch_pct
        assert full_run.estimates[name]["parametric.delay_mismatch_samples"] == p.delay_mismatch_samples
        assert full_run.estimates[name]["classic.gain_ratio"] == element.classic.gain_ratio
    assert full_run.warnings == []  # its speed is benchmarks/bench_nodes.py's to print, not a timed assertion


def _batch_diagnosis(config, r, u, y, dither=None):
    """What the diagnostician computes from these samples: verdicts, data-quality figures, the control impact."""
    diagnosis = diagnose_stretches(
        [Record(r, u, y, dither)], model=config.model, pmr=config.pmr, parametric=config.parametric,
        quality=config.quality,
    )  # fmt: skip
    return close_diagnosis(diagnosis, config).diagnosis


def test_node_set_and_batch_give_the_same_r_u_y_sample_for_sample(full_run):
    batch = simulate(full_run.config)
    node = full_run.record
    assert np.array_equal(node.r, batch.r)
    assert np.array_equal(node.u, batch.u)
    assert np.array_equal(node.y, batch.y)
    config = full_run.config
    expected = _batch_diagnosis(config, batch.r, batch.u, batch.y)
    assert all(e.data_quality is not None for e in expected)
    assert all(e.impact is not None for e in expected)  # every element of the full scenario is a mismatch
    # one process, one machine: the verdicts read back from /diagnostics are bit-identical to the batch's
    assert full_run.diagnosis.elements == expected.elements


def test_pmr_ros_run_uses_the_node_set_and_matches_batch(tmp_path, ros_domain, capsys):
    nodes_json, batch_json = tmp_path / "nodes.json", tmp_path / "batch.json"
    # impact simulations of 1,024 samples, not 4,096 (both paths compute them alike, compared below)
    common = ["run", "--samples", "2000", "--seed", "3", "--config", str(with_impact_samples(tmp_path, 1024))]
    assert cli.main([*common, "--json", str(nodes_json)]) == 0
    assert cli.main([*common, "--batch", "--json", str(batch_json)]) == 0
    out = capsys.readouterr().out
    assert out.count("G21") == 2
    nodes, batch = json.loads(nodes_json.read_text()), json.loads(batch_json.read_text())
    assert nodes["path"] == "nodes" and batch["path"] == "batch"
    assert nodes["elements"] == batch["elements"]
    assert nodes["node_set"]["window"] == {"window_samples": 2000, "first_sample": 0, "last_sample": 1999}
    assert set(nodes["node_set"]["levels"]) == {"G11", "G12", "G21", "G22"}


# -- parameters --------------------------------------------------------------


def _params(**dotted):
    flat = flatten_parameters(load_config().parameters)
    flat.update({k.replace("__", "."): v for k, v in dotted.items()})
    return parameter_overrides(flat)


def test_parameters_have_descriptors_and_invalid_changes_are_refused(ros):
    node = ros.add(PmrDiagnosticianNode(context=ros.context, parameter_overrides=_params()))
    desc = node.describe_parameter("diagnostician.window_samples")
    assert desc.description and desc.integer_range[0].from_value == 1 and not desc.read_only
    assert "< 1" in node.describe_parameter("pmr.overlap").additional_constraints
    # the control impact simulates the configured controller and setpoints; the plant's noise is not its business
    assert node.has_parameter("prbs.clock_period") and node.has_parameter("mpc.control_horizon")
    assert not node.has_parameter("noise.std") and not node.has_parameter("simulation.real_time_rate_hz")
    result = node.set_parameters([Parameter("system.gain", value=[1.0, 2.0, 3.0])])[0]
    assert not result.successful and "system.gain = [1.0, 2.0, 3.0]: needs 4 entries" in result.reason
    result = node.set_parameters([Parameter("pmr.method", value="bayes")])[0]
    assert (
        not result.successful
        and "pmr.method" in result.reason
        and node.get_parameter("pmr.method").value == "parametric"
    )
    result = node.set_parameters([Parameter("diagnostician.window_samples", value=4096)])[0]
    assert not result.successful and "must not exceed diagnostician.window_samples (4096)" in result.reason
    ok = node.set_parameters([Parameter("diagnostician.window_samples", value=10000)])[0]
    assert ok.successful and node.aligner.capacity == 10000 and node.config.diagnostician.window_samples == 10000
    ok = node.set_parameters([Parameter("system.gain", value=[1.0, 2.0, 3.0, 4.0])])[0]
    assert ok.successful and node.config.model.gain[1, 1] == 4.0


def test_simulation_nodes_are_read_only(ros):
    node = ros.add(PlantNode(context=ros.context, parameter_overrides=_params()))
    assert node.get_parameter("use_sim_time").value is True
    assert node.describe_parameter("noise.std").read_only
    result = node.set_parameters([Parameter("noise.std", value=0.2)])[0]
    assert not result.successful and "read-only" in result.reason
    assert node.describe_parameter("system.gain").type == ParameterType.PARAMETER_DOUBLE_ARRAY


def test_use_sim_time_given_explicitly_is_honoured(ros):
    params = [*_params(), Parameter("use_sim_time", value=False)]
    node = ros.add(PlantNode(context=ros.context, parameter_overrides=params))
    assert node.get_parameter("use_sim_time").value is False


def test_invalid_parameters_at_start_are_a_config_error(ros_context):
    # a node refused at start destroys itself (ConfiguredNode): nothing to own
    with pytest.raises(ConfigError, match=r"pmr.segment_length = 0") as err:
        PmrDiagnosticianNode(context=ros_context, parameter_overrides=_params(pmr__segment_length=0))
    assert "pmr_diagnostician" in str(err.value)
    with pytest.raises(ConfigError, match="system.delay"):
        PmrDiagnosticianNode(context=ros_context, parameter_overrides=_params(system__delay=[1.5, 3.0, 7.0, 3.0]))


def test_a_node_without_a_model_refuses_to_start(ros_context):
    with pytest.raises(ConfigError, match="system: missing: a configuration needs the controller's model"):
        PmrDiagnosticianNode(context=ros_context)
    # a misspelt system block: the typo is named, and the node does not fall back to a built-in model
    misspelt = [
        Parameter(name.replace("system.", "sytem."), value=p.value) if name.startswith("system.") else p
        for name, p in ((p.name, p) for p in _params())
    ]
    with pytest.raises(ConfigError, match=r"sytem\.\w+ = .*unknown parameter; did you mean system\.\w+\?"):
        PmrDiagnosticianNode(context=ros_context, parameter_overrides=misspelt)


def test_a_misspelt_parameter_is_refused_with_the_nearest_name(ros_context):
    with pytest.raises(
        ConfigError,
        match="diagnostician.windw_samples = 10: unknown parameter; did you mean diagnostician.window_samples",
    ):
        PmrDiagnosticianNode(
            context=ros_context, parameter_overrides=[*_params(), Parameter("diagnostician.windw_samples", value=10)]
        )


# -- the diagnostician against bad traffic -----------------------------------

SMALL = {
    "pmr.segment_length": 128,
    # held at 128: an automatic segment shortens to read the two stretches either side of a bad sample
    # together, and these tests are about a stretch too short to add a segment on its own
    "parametric.segment_length": 128,
    "diagnostician.window_samples": 600,
    "diagnostician.update_period_samples": 100,
    "diagnostician.min_samples": 500,
    "diagnostician.max_lag_samples": 16,
    "diagnostician.stale_timeout_s": 0.3,
    "impact.samples": 0,  # these tests are about the data; the impact's simulations would outlast the 0.3 s
}


@cache
def _record():
    return simulate(load_config(), samples=1000)


class Harness:
    """A diagnostician fed r, u, y over the real topics by a test node; collects /diagnostics."""

    def __init__(self, ros, **overrides) -> None:
        flat = flatten_parameters(load_config().parameters)
        flat.update(SMALL)
        flat.update(overrides)
        self.diag = ros.add(PmrDiagnosticianNode(context=ros.context, parameter_overrides=parameter_overrides(flat)))
        self.feeder = ros.create_node("feeder")
        self.config = self.diag.config
        self.pubs = {}
        for signal, key in (("r", "setpoint"), ("u", "manipulated_input"), ("y", "measured_output")):
            t = topic(key)
            self.pubs[signal] = self.feeder.create_publisher(message_class(t), t.name, qos_profile(t.qos))
        t = topic("diagnostics")
        self.received = []
        self.feeder.create_subscription(message_class(t), t.name, self.received.append, qos_profile(t.qos))
        self.executor = ros.executor
        assert spin_until(
            self.executor, lambda: all(p.get_subscription_count() >= 1 for p in self.pubs.values()), 60.0
        ), "the feeder did not match"

    def send(self, signal: str, k: int, values=None, names=None) -> None:
        rec = _record()
        model = self.config.model
        if values is None:
            values = {"r": rec.r, "u": rec.u, "y": rec.y}[signal][k]
        if names is None:
            names = model.input_names if signal == "u" else model.output_names
        self.pubs[signal].publish(signal_message(values, names, k * model.sample_time))
        self._sent = getattr(self, "_sent", 0) + 1

    def send_samples(self, ks, skip=()) -> None:
        for k in ks:
            for s in ("r", "y", "u"):
                if (s, k) not in skip and k not in skip:
                    self.send(s, k)
            if k % 100 == 99:
                self.settle()
        self.settle()

    def settle(self) -> None:
        """Spin until the diagnostician has taken every message sent so far."""

        def taken():
            return self.diag.messages_received >= self._sent

        assert spin_until(self.executor, taken, 60.0), "diagnostician did not take the messages"
        assert self.diag.wait_idle(30.0), "the diagnoses did not finish"

        def heard():  # the last /diagnostics the diagnostician published has reached this test's subscriber
            latest = self.diag.last_published
            return latest is None or (bool(self.received) and self.received[-1] == latest)

        # a fixed short spin lost the last verdict on a busy machine: wait for it instead
        assert spin_until(self.executor, heard, 30.0), "the last /diagnostics did not arrive"

    def statuses(self):
        return [diagnosis_from_array(m) for m in self.received]


@pytest.fixture
def harness(ros):
    return Harness(ros)


def _levels(info):
    return set(info["levels"].values())


def _assert_bad_stretch_excluded(h: Harness, first_good: int) -> None:
    """Every verdict after the bad stretch comes from a window that starts after it."""
    results = h.statuses()
    assert results, "no diagnostics published"
    for diagnosis, info in results:
        if diagnosis.status == "ok":
            assert info["first_sample"] >= first_good or info["last_sample"] < first_good - 1
    final, info = results[-1]
    assert info["last_sample"] == 999
    assert final.status == "ok" and info["first_sample"] == 400
    warn = [(d, i) for d, i in results if i.get("last_sample") == 399]
    assert warn and warn[0][0].status == "insufficient_data" and _levels(warn[0][1]) == {"WARN"}
    assert "unbroken samples, need 500" in warn[0][0].reason


def test_nan_and_inf_in_y_are_dropped_and_the_stretch_excluded(harness):
    h = harness
    h.send_samples(range(0, 300))
    h.send("r", 300), h.send("u", 300), h.send("y", 300, [float("nan"), 0.0])
    h.send("r", 301), h.send("u", 301), h.send("y", 301, [0.0, float("inf")])
    h.settle()
    h.send_samples(range(302, 1000))
    text = "\n".join(h.diag.warnings)
    assert "y on /pmr/measured_output: non-finite value x_D=nan" in text
    assert "x_B=inf" in text
    assert "a new stretch starts at sample 302" in text
    _assert_bad_stretch_excluded(h, 302)


def test_a_vector_of_the_wrong_length_is_dropped(harness):
    h = harness
    h.send_samples(range(0, 300))
    h.send("r", 300), h.send("y", 300), h.send("u", 300, [0.1, 0.2, 0.3], ("reflux", "steam", "extra"))
    h.settle()
    h.send_samples(range(301, 1000))
    text = "\n".join(h.diag.warnings)
    assert "u on /pmr/manipulated_input: 3 values [0.1, 0.2, 0.3], expected 2 (reflux, steam)" in text
    _assert_bad_stretch_excluded(h, 301)


def test_a_gap_of_missing_samples_restarts_the_window(harness):
    h = harness
    h.send_samples(range(0, 1000), skip=set(range(290, 300)))
    text = "\n".join(h.diag.warnings)
    assert "samples 290..299 missing (gap of 10)" in text
    assert "a new stretch starts at sample 300" in text
    # Enough unbroken samples after the gap by sample 799: a verdict from 300 on only.
    results = h.statuses()
    at_799 = [(d, i) for d, i in results if i.get("last_sample") == 799][0]
    assert at_799[0].status == "ok" and at_799[1]["first_sample"] == 300
    at_699 = [(d, i) for d, i in results if i.get("last_sample") == 699][0]
    assert at_699[0].status == "insufficient_data" and "400 unbroken samples" in at_699[0].reason


def test_duplicated_and_out_of_order_stamps_are_dropped_and_change_nothing(harness):
    h = harness
    h.send_samples(range(0, 301))
    h.send("y", 300, [5.0, 5.0])  # duplicated stamp, other values
    h.send("u", 295)  # out of order
    h.settle()
    h.send_samples(range(301, 1000))
    text = "\n".join(h.diag.warnings)
    assert "y on /pmr/measured_output: duplicated stamp 300 s (sample 300, newest is 300); message dropped" in text
    assert "u on /pmr/manipulated_input: out-of-order stamp 295 s" in text
    assert h.diag.aligner.gaps == 0
    rec = _record()
    r, u, y, first = h.diag.aligner.window(600)
    assert first == 400 and np.array_equal(y, rec.y[400:]) and np.array_equal(u, rec.u[400:])
    final, info = h.statuses()[-1]
    expected = _batch_diagnosis(h.config, rec.r[400:], rec.u[400:], rec.y[400:])
    assert final.elements == expected.elements


def test_a_topic_that_stops_turns_the_verdicts_stale(harness):
    h = harness
    h.send_samples(range(0, 300))
    for k in range(300, 400):
        h.send("r", k)
        h.send("y", k)
    h.settle()
    # (on a busy machine a wall-clock STALE, "no data received", may come first: stale_timeout_s is 0.3 s here)
    stale = [(d, i) for d, i in h.statuses() if _levels(i) == {"STALE"} and "stopped at sample" in d.reason]
    assert stale, "no STALE diagnostics while u is missing"
    assert "u on /pmr/manipulated_input stopped at sample 299" in stale[0][0].reason
    assert all(e.result is None for e in stale[0][0].elements.values())

    # Then everything stops: after diagnostician.stale_timeout_s of silence, STALE again from the wall-clock check.
    def silent_r_reported():
        return any("no r on /pmr/setpoint for" in d.reason and _levels(i) == {"STALE"} for d, i in h.statuses())

    assert spin_until(h.executor, silent_r_reported, 30.0)
    assert any("no u on /pmr/manipulated_input for" in w for w in h.diag.warnings)
    assert h.received[-1].status[0].level == DiagnosticStatus.STALE


def test_no_stale_warning_once_the_run_is_complete(harness):
    """A run that ended is silent on purpose: the watchdog stops, no 'no r on /pmr/setpoint for ...' follows it."""
    h = harness
    h.send_samples(range(0, 600))
    stale_timeout = h.config.diagnostician.stale_timeout_s
    h.diag.finish_run()
    published, warned = len(h.received), len(h.diag.warnings)  # (a pause while feeding may have warned before)
    spin_until(h.executor, lambda: False, 6 * stale_timeout + 1.0)  # several watchdog periods of silence
    assert list(h.diag.warnings)[warned:] == []
    later = [diagnosis_from_array(m) for m in h.received[published:]]
    assert all(_levels(i) != {"STALE"} for _, i in later)  # the last verdicts are republished as they were


def test_the_end_of_a_run_on_its_topic_stops_the_watchdog_and_a_later_sample_starts_it_again(harness):
    """A plant in another process says its run is complete on pmr/run_complete: its silence is no stale signal."""
    h = harness
    h.send_samples(range(0, 600))
    end = h.feeder.create_publisher(
        message_class(topic("run_complete")), topic("run_complete").name, qos_profile(topic("run_complete").qos)
    )
    end.publish(run_complete_message(599 * h.config.model.sample_time))
    assert spin_until(h.executor, lambda: h.diag.run_complete, 30.0), "the end of the run did not arrive"
    stale_timeout = h.config.diagnostician.stale_timeout_s
    warned = len(h.diag.warnings)
    spin_until(h.executor, lambda: False, 6 * stale_timeout + 1.0)  # several watchdog periods of silence
    assert list(h.diag.warnings)[warned:] == []
    # the run goes on after all (a sample after the announced last one): silence is watched again
    h.send_samples(range(600, 610))
    assert not h.diag.run_complete

    def silence_reported():
        return any("no r on /pmr/setpoint for" in w for w in list(h.diag.warnings)[warned:])

    assert spin_until(h.executor, silence_reported, 30.0)


def test_real_time_mode_paces_the_plant_with_a_wall_timer(ros_domain):
    config = load_config(overrides={"run": {"samples": 600}, "pmr": {"segment_length": 128}})
    options = NodeSetOptions(
        domain_id=ros_domain, record=True, extra_parameters={"simulation.real_time_rate_hz": 400.0}
    )
    result = run_node_set(config, options)
    assert result.info["last_sample"] == 599
    assert result.wall_time_s >= 0.9 * 600 / 400
    assert np.isfinite(result.record.y).all() and np.isfinite(result.record.u).all()
    assert np.array_equal(result.record.r, simulate(config).r)


def test_diagnostician_subscribes_to_r_u_y_the_active_model_and_the_end_of_a_run_only(ros):
    node = ros.add(PmrDiagnosticianNode(context=ros.context, parameter_overrides=_params()))
    # r, u, y, the controller's active model when it publishes one (any controller that publishes r, u, y
    # can be watched; pmr_ros's own tells when it switches models) and the producer's end of a run
    assert {s.topic_name for s in node.subscriptions} == {
        topic(k).resolved()
        for k in ("setpoint", "manipulated_input", "measured_output", "active_model", "run_complete")
    }


def test_node_set_runs_any_square_system_like_the_batch(ros_domain):
    # the control impact's simulations of 512 samples, not 4,096: its 9 elements' took 18 of the test's 27 s
    overrides = {"run": {"samples": 1500}, "impact": {"samples": 512}}
    config = load_config(config_dir() / "three_by_three.yaml", overrides)
    result = run_node_set(config, NodeSetOptions(domain_id=ros_domain, record=True))
    batch = simulate(config)
    assert np.array_equal(result.record.y, batch.y) and np.array_equal(result.record.u, batch.u)
    assert len(result.info["levels"]) == 9 and result.info["last_sample"] == 1499
    mismatches = [e for e in result.diagnosis.elements.values() if e.verdict == "mismatch"]
    assert mismatches and all(e.impact is not None for e in mismatches)  # the 3x3's impact, computed live


def test_mv_dither_in_the_node_set_equals_the_batch(ros_domain):
    # impact simulations of 1,024 samples, not 4,096: the node set's and the batch's are compared, equal at any length
    overrides = {
        "run": {"samples": 2000},
        "excitation": {"mv_dither_amplitude": [0.2, 0.1]},
        "impact": {"samples": 1024},
    }
    config = load_config(overrides=overrides)
    result = run_node_set(config, NodeSetOptions(domain_id=ros_domain, record=True))
    batch = simulate(config)
    assert batch.dither is not None
    assert np.array_equal(result.record.u, batch.u) and np.array_equal(result.record.y, batch.y)
    expected = _batch_diagnosis(config, batch.r, batch.u, batch.y, batch.dither)
    assert result.diagnosis.elements == expected.elements  # the diagnostician used the same instruments


def test_the_latest_statuses_are_published_again_every_publish_period(harness):
    h = harness
    assert h.diag.get_parameter("diagnostician.publish_period_s").value == 1.0  # the declared default
    changes = [
        Parameter("diagnostician.publish_period_s", value=0.1),
        Parameter("diagnostician.stale_timeout_s", value=30.0),
    ]
    assert all(r.successful for r in h.diag.set_parameters(changes))
    h.send_samples(range(0, 600))
    before = len(h.received)
    last = h.received[-1]
    assert diagnosis_from_array(last)[1]["last_sample"] == 599
    # no data for a while: the same statuses again and again (until the data turn stale)
    assert spin_until(h.executor, lambda: len(h.received) >= before + 3, 30.0)
    assert all(m.status == last.status and m.header.stamp == last.header.stamp for m in h.received[before:])


def test_lost_samples_are_counted_with_their_topic_and_stamps(harness):
    h = harness
    h.send_samples(range(0, 400), skip=set(range(290, 300)) | {("u", 350)})
    assert h.diag.lost_samples == {"r": 10, "u": 11, "y": 10}
    text = "\n".join(h.diag.warnings)
    assert "y on /pmr/measured_output: 10 sample(s) lost, stamps 290..299 s (10 lost on this topic)" in text
    assert "u on /pmr/manipulated_input: 1 sample(s) lost, stamps 350..350 s (11 lost on this topic)" in text


def test_a_diagnosis_runs_off_the_executor_thread_and_holds_the_progress_while_they_queue(harness):
    import threading

    h = harness
    release = threading.Event()
    for _ in range(3):  # the worker is busy: three jobs, two of them waiting
        h.diag.worker.submit(lambda: release.wait(30))
    try:
        for k in range(300):
            for s in ("r", "y", "u"):
                h.send(s, k)
        # every message is still taken at once, though the worker is busy
        assert spin_until(h.executor, lambda: h.diag.messages_received == 900, 60.0) and h.diag.busy
        reports = h.diag.progress.reports
        spin_until(h.executor, lambda: False, 0.3)
        assert h.diag.progress.reports == reports  # held: a lockstep producer stops max_samples_ahead on
    finally:
        release.set()
    assert h.diag.wait_idle(30.0)
    assert spin_until(h.executor, lambda: h.diag.progress.reports > reports, 30.0)


def test_the_impact_and_the_proposal_are_computed_on_the_worker_thread(ros, monkeypatch):
    import threading

    from pmr_ros.nodes import pmr_diagnostician
    from pmr_ros.service import closing as proposal

    threads = []

    def close_window(outcome, config):
        threads.append(threading.current_thread().name)
        return proposal.close_window(outcome, config)

    monkeypatch.setattr(pmr_diagnostician, "close_window", close_window)
    h = Harness(ros, **{"impact.samples": 500, "diagnostician.stale_timeout_s": 60.0})
    h.send_samples(range(1000))
    verdicts = [d for d, _ in h.statuses() if d.status == "ok"]
    assert verdicts and verdicts[-1].impact is not None  # the full scenario's mismatches, with their impact
    assert h.diag.last_proposal is not None and "(samples 400..999)" in h.diag.last_proposal
    executor = threading.current_thread().name  # the test spins the executor on this thread
    assert threads and all(name.startswith("pmr_diagnosis") and name != executor for name in threads), threads


def test_a_window_whose_diagnosis_fails_says_so_and_the_next_window_is_diagnosed(ros, monkeypatch):
    """The failed window's statuses replace the last ones (ERROR, the exception in one line); the node goes on."""
    from pmr_ros.contract import windowing

    real, calls = windowing.diagnose_stretches, []

    def diagnose_stretches(*args, **kwargs):
        calls.append(True)
        if len(calls) == 1:  # the first window with enough data: the core raises
            raise np.linalg.LinAlgError("SVD did not converge\n(on purpose, test)")
        return real(*args, **kwargs)

    monkeypatch.setattr(windowing, "diagnose_stretches", diagnose_stretches)
    h = Harness(ros)
    h.send_samples(range(600))
    failed = [(m, i) for m, (_, i) in zip(h.received, h.statuses(), strict=True) if i["status"] == "failed"]
    assert len(failed) == 1, [i["status"] for _, i in h.statuses()]
    msg, info = failed[0]
    reason = "LinAlgError: SVD did not converge (on purpose, test)"
    assert {(s.level, s.message) for s in msg.status} == {(DiagnosticStatus.ERROR, f"diagnosis failed: {reason}")}
    assert len(msg.status) == 5 and (info["first_sample"], info["last_sample"]) == (0, 499)  # G11..G22, the summary
    final, info = h.statuses()[-1]
    assert final.status == "ok" and info["last_sample"] == 599 and len(calls) > 1  # the next window: a verdict


def _node_set(ros, config, extra):
    """The four nodes of ``config`` on the test's Context, owned by the test; the flat parameters they got."""
    from pmr_ros.node_set import build_nodes

    flat = {**flatten_parameters(config.parameters), **extra}
    nodes = build_nodes(config, ros.context, extra)
    for node in nodes:
        ros.add(node)
    return nodes, flat


def _diagnostics_listener(ros):
    t = topic("diagnostics")
    received = []
    ros.create_node("listener").create_subscription(
        message_class(t), t.name, lambda m: received.append(diagnosis_from_array(m)), qos_profile(t.qos)
    )
    return received


SHORT_RUN = {
    "pmr.method": "classic",
    "pmr.segment_length": 128,
    "diagnostician.window_samples": 3000,
    "diagnostician.update_period_samples": 500,
    "diagnostician.min_samples": 800,
    "diagnostician.stale_timeout_s": 0.5,
}


def test_a_restarted_plant_resumes_the_run_and_the_window_spans_the_break(ros):
    config = load_config(overrides={"run": {"samples": 3000}})
    (diag, mpc, prbs, plant), flat = _node_set(ros, config, SHORT_RUN)
    received = _diagnostics_listener(ros)
    assert ros.spin_until(lambda: plant.sample >= 1200, 120.0), "the loop did not reach sample 1200"
    # the plant crashes: its node and its topics' writers are gone
    answered = plant.sample  # the controller answers the plant's last sample: its newest input
    ros.executor.remove_node(plant)
    ros.nodes.remove(plant)
    plant.destroy_node()
    again = ros.add(PlantNode(context=ros.context, parameter_overrides=parameter_overrides(flat)))
    assert ros.spin_until(lambda: again.finished, 120.0), f"the restarted plant stalled at {again.sample}"
    assert ros.spin_until(lambda: any(i.get("last_sample") == 2999 for _, i in received), 60.0)
    assert again.resumed_at == [answered + 2]  # sample answered + 1 is left out: a break all consumers see
    final, info = next((d, i) for d, i in reversed(received) if i.get("last_sample") == 2999)
    # the window holds both stretches around the break, less the sample left out
    assert final.status == "ok" and info["first_sample"] == 0 and info["window_samples"] == 2999
    assert diag.lost_samples == {"r": 1, "u": 1, "y": 1}
    assert any(f"samples {answered + 1}..{answered + 1} missing" in w for w in diag.warnings)


def test_a_plant_that_finds_a_run_under_way_waits_for_the_controllers_late_input_and_resumes_after_it(ros):
    """The controller's newest input reaches a restarted plant late: it resumes after it, not from sample 0.

    A consumer reports sample 1000 taken; u(1000) reaches the new plant only 3 s after it is ready (its
    history delivered late, as on a loaded machine).
    """
    config = load_config(overrides={"run": {"samples": 3000}})
    overrides = {"simulation.discovery_settle_s": 0.0, "simulation.wait_for_subscribers": 1}
    flat = {**flatten_parameters(config.parameters), **overrides}
    stub = ros.create_node("stub_loop")  # the run's consumer and its controller, as one node
    t_progress, t_u, t_y = topic("progress"), topic("manipulated_input"), topic("measured_output")
    progress = stub.create_publisher(message_class(t_progress), t_progress.name, qos_profile(t_progress.qos))
    u_pub = stub.create_publisher(message_class(t_u), t_u.name, qos_profile(t_u.qos))
    published = []
    stub.create_subscription(
        message_class(t_y), t_y.name, lambda m: published.append(m.header.stamp.sec), qos_profile(t_y.qos)
    )
    report = message_class(t_progress)(frame_id=stub.get_fully_qualified_name())
    report.stamp.sec = 1000
    progress.publish(report)
    plant = ros.add(PlantNode(context=ros.context, parameter_overrides=parameter_overrides(flat)))
    assert ros.spin_until(lambda: plant._ready_at is not None, 30.0), "the plant never found its peers"
    ready = time.monotonic()
    ros.spin_until(lambda: bool(published), 3.0)  # before the fix: sample 0 went out 0.5 s after ready
    assert not published, f"the plant started over: published samples {published[:3]}"
    u = np.zeros(config.model.n_inputs)
    u_pub.publish(signal_message(u, config.model.input_names, 1000.0 * config.model.sample_time, "stub"))
    assert ros.spin_until(lambda: bool(published), 30.0), "the plant never resumed"
    assert published[0] == 1002 * config.model.sample_time and plant.resumed_at == [1002], published
    assert time.monotonic() - ready >= 3.0


def test_a_stray_publisher_of_old_stamps_is_reported_and_does_not_stall_the_loop(ros):
    config = load_config(overrides={"run": {"samples": 3000}})
    (diag, mpc, prbs, plant), _ = _node_set(ros, config, SHORT_RUN)
    received = _diagnostics_listener(ros)
    stray = ros.create_node("stray")
    keys = (("r", "setpoint"), ("u", "manipulated_input"), ("y", "measured_output"))
    pubs = {
        s: stray.create_publisher(message_class(topic(k)), topic(k).name, qos_profile(topic(k).qos)) for s, k in keys
    }
    state = {"k": 0, "stopped_at": None}
    rng = np.random.default_rng(7)

    def old_samples():
        if plant.sample < 600 or state["stopped_at"] is not None:
            return
        if plant.sample >= 1200:
            state["stopped_at"] = plant.sample
            return
        for s, pub in pubs.items():
            names = config.model.input_names if s == "u" else config.model.output_names
            pub.publish(signal_message(rng.normal(size=2), names, float(state["k"])))
        state["k"] += 1

    stray.create_timer(0.002, old_samples)
    assert ros.spin_until(lambda: plant.finished, 180.0), f"the loop stalled at sample {plant.sample}"
    assert ros.spin_until(lambda: any(i.get("last_sample") == 2999 for _, i in received), 60.0)
    assert state["k"] > 10 and state["stopped_at"] is not None
    conflicts = [d for d, i in received if i["status"] == "conflict"]
    assert conflicts and set(conflicts[0].elements) == {"G11", "G12", "G21", "G22"}
    assert "publishers on" in conflicts[0].reason and "/stray" in conflicts[0].reason
    assert all(level == "ERROR" for _, i in received if i["status"] == "conflict" for level in i["levels"].values())
    # once the stray is silent the verdicts come back, from a window after its last message
    final, info = next((d, i) for d, i in reversed(received) if i.get("last_sample") == 2999)
    assert final.status == "ok" and info["first_sample"] >= 600


def test_the_plant_sends_sample_0_only_after_its_discovery_settle_time(ros):
    # nodes running before the plant (a recorder) need DDS discovery time, or they would lose the start
    config = load_config(overrides={"run": {"samples": 50}})
    started = time.monotonic()
    (_, _, _, plant), _ = _node_set(ros, config, {**SHORT_RUN, "simulation.discovery_settle_s": 1.5})
    assert ros.spin_until(lambda: plant.sample >= 0, 60.0), "the plant never started"
    assert time.monotonic() - started >= 1.5
    assert ros.spin_until(lambda: plant.finished, 60.0)


def test_a_private_node_set_skips_the_discovery_settle_time():
    config = load_config()
    assert NodeSetOptions(private=True).parameters(config)["simulation.discovery_settle_s"] == 0.0
    assert "simulation.discovery_settle_s" not in NodeSetOptions(private=False).parameters(config)
    # pmr-ros replay gives its consumers the same time to be discovered
    assert discovery_settle_s() == config.simulation.discovery_settle_s > 0
