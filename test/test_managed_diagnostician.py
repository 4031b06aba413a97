"""The diagnostician as a lifecycle node: configure validates, activate gives verdicts, deactivate stops."""

from __future__ import annotations

import ast
import importlib
import signal as os_signal
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from lifecycle_msgs.msg import Transition  # noqa: E402
from lifecycle_msgs.srv import ChangeState  # noqa: E402
from rclpy.lifecycle import TransitionCallbackReturn  # noqa: E402
from ros_fixtures import spin_until  # noqa: E402

from pmr_ros.config import config_dir, flatten_parameters, load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.contract.topics import topic  # noqa: E402
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402
from pmr_ros.nodes.managed_diagnostician import LIFECYCLE_NODE_NAME, ManagedDiagnosticianNode  # noqa: E402
from pmr_ros.nodes.pmr_diagnostician import NODE_NAME  # noqa: E402
from pmr_ros.ros.convert import signal_message  # noqa: E402
from pmr_ros.ros.messages import message_class, qos_profile  # noqa: E402
from pmr_ros.ros.parameters import node_parameters, parameter_overrides  # noqa: E402

pytestmark = pytest.mark.ros
ROOT = Path(__file__).resolve().parents[1]

SMALL = {
    "pmr.segment_length": 128,
    "diagnostician.window_samples": 600,
    "diagnostician.update_period_samples": 100,
    "diagnostician.min_samples": 500,
    "diagnostician.stale_timeout_s": 30.0,  # no wall-clock STALE while the test feeds
    "impact.samples": 0,
}


def _flat(**changes):
    declared = {p.name for p in node_parameters(NODE_NAME)}
    flat = {k: v for k, v in flatten_parameters(load_config().parameters).items() if k in declared}
    return {**flat, **SMALL, **changes}


def test_configure_refuses_a_bad_configuration_with_its_reason(ros):
    node = ros.add(
        ManagedDiagnosticianNode(
            context=ros.context, parameter_overrides=parameter_overrides(_flat(**{"system.gain": [1.0, 2.0]}))
        )
    )
    assert node.trigger_configure() == TransitionCallbackReturn.FAILURE
    assert "system.gain" in node.refusal and "4" in node.refusal and "\n" not in node.refusal
    assert node.config is None and node.diagnostician is None


def test_activate_gives_verdicts_and_deactivate_silence(ros):
    node = ros.add(ManagedDiagnosticianNode(context=ros.context, parameter_overrides=parameter_overrides(_flat())))
    feeder = ros.create_node("feeder")
    config = load_config()
    record = simulate(config, samples=1000)
    pubs = {}
    for signal, key in (("r", "setpoint"), ("u", "manipulated_input"), ("y", "measured_output")):
        t = topic(key)
        pubs[signal] = feeder.create_publisher(message_class(t), t.name, qos_profile(t.qos))
    received = []
    t = topic("diagnostics")
    feeder.create_subscription(message_class(t), t.name, received.append, qos_profile(t.qos))

    def send(ks):
        for k in ks:
            for signal, names in (("r", config.model.output_names), ("u", config.model.input_names),
                                  ("y", config.model.output_names)):  # fmt: skip
                values = getattr(record, signal)[k]
                pubs[signal].publish(signal_message(values, names, k * config.model.sample_time))
            if k % 50 == 49:
                ros.spin_for(0.02)

    assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS and node.refusal == ""
    assert node.diagnostician is None  # configured, not yet subscribed
    assert node.trigger_activate() == TransitionCallbackReturn.SUCCESS
    diag = node.diagnostician
    assert diag is not None and diag.get_name() == NODE_NAME
    assert spin_until(ros.executor, lambda: all(p.get_subscription_count() >= 1 for p in pubs.values()), 60.0)
    send(range(0, 700))
    assert spin_until(ros.executor, lambda: diag.messages_received >= 2100, 60.0)
    assert diag.wait_idle(60.0)

    def verdicts():
        return [d for d, i in (diagnosis_from_array(m) for m in received) if d.status == "ok"]

    assert spin_until(ros.executor, lambda: bool(verdicts()), 30.0), "no verdict while active"
    assert node.trigger_deactivate() == TransitionCallbackReturn.SUCCESS and node.diagnostician is None
    assert all(p.get_subscription_count() == 0 for p in pubs.values()) or spin_until(
        ros.executor, lambda: all(p.get_subscription_count() == 0 for p in pubs.values()), 10.0
    )
    ros.spin_for(0.5)
    heard = len(received)
    send(range(700, 1000))
    ros.spin_for(2.0)  # longer than the republish period (1 s): a live node would have published
    assert len(received) == heard, "output after deactivate"
    assert node.trigger_cleanup() == TransitionCallbackReturn.SUCCESS and node.config is None


def test_an_active_diagnostician_goes_stale_when_the_data_stop(ros):
    flat = _flat(**{"diagnostician.stale_timeout_s": 1.0})
    node = ros.add(ManagedDiagnosticianNode(context=ros.context, parameter_overrides=parameter_overrides(flat)))
    listener = ros.create_node("listener")
    received = []
    t = topic("diagnostics")
    listener.create_subscription(message_class(t), t.name, received.append, qos_profile(t.qos))
    assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
    assert node.trigger_activate() == TransitionCallbackReturn.SUCCESS

    def stale():
        decoded = [diagnosis_from_array(m) for m in received]
        return any(set(i.get("levels", {}).values()) == {"STALE"} for _, i in decoded)

    # no data at all: every element STALE within a few stale timeouts (the watchdog runs at a quarter of it)
    assert spin_until(ros.executor, stale, 10.0), [diagnosis_from_array(m)[1] for m in received[-1:]]
    statuses = received[-1].status
    assert statuses and all(s.level == DiagnosticStatus.STALE for s in statuses)


def _console_scripts() -> dict[str, str]:
    """setup.py's ``console_scripts``: name -> ``module:function``."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    entries = next(
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.keyword) and node.arg == "entry_points" and isinstance(node.value, ast.Dict)
    )
    scripts = next(
        v for k, v in zip(entries.keys, entries.values, strict=True) if ast.literal_eval(k) == "console_scripts"
    )
    pairs = (text.split("=", 1) for text in ast.literal_eval(scripts))
    return {name.strip(): target.strip() for name, target in pairs}


def test_the_console_script_resolves_to_the_lifecycle_node(monkeypatch):
    from pmr_ros import entry
    from pmr_ros.nodes import managed_diagnostician

    target = _console_scripts()[LIFECYCLE_NODE_NAME]
    function = EntryPoint(LIFECYCLE_NODE_NAME, target, "console_scripts").load()
    assert function is entry.pmr_diagnostician_lifecycle
    ran = []
    monkeypatch.setattr(entry, "_run", lambda module, interrupted: ran.append(module) or 0)
    assert function() == 0
    assert importlib.import_module(ran[0]).main is managed_diagnostician.main


def test_the_program_waits_unconfigured_and_is_driven_by_its_lifecycle_services(ros, tmp_path):
    """Started as a program, configured and activated over ``change_state``: statuses, then a clean Ctrl-C."""
    program = f"import sys; from pmr_ros.entry import {LIFECYCLE_NODE_NAME} as main; sys.exit(main())"
    params = ["--params-file", str(config_dir() / "wood_berry.yaml"), "-p", "diagnostician.stale_timeout_s:=0.5"]
    proc = ros.start([sys.executable, "-c", program, "--ros-args", *params], tmp_path / "node.log")
    driver = ros.create_node("driver")
    received = []
    t = topic("diagnostics")
    driver.create_subscription(message_class(t), t.name, received.append, qos_profile(t.qos))
    change = driver.create_client(ChangeState, f"/{LIFECYCLE_NODE_NAME}/change_state")
    assert ros.spin_until(change.service_is_ready, 60.0), (tmp_path / "node.log").read_text()
    for transition in (Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE):
        assert not received  # nothing before it is active
        future = change.call_async(ChangeState.Request(transition=Transition(id=transition)))
        assert ros.spin_until(future.done, 30.0) and future.result().success, transition
    assert ros.spin_until(lambda: bool(received), 20.0), "no /diagnostics once active"
    names = [s.name for s in received[-1].status]
    assert names == [f"pmr/wood_berry/{n}" for n in ("G11", "G12", "G21", "G22", "summary")]
    proc.send_signal(os_signal.SIGINT)
    assert proc.wait(timeout=30) == 0
    log = (tmp_path / "node.log").read_text()
    assert "Traceback" not in log and "configured: wood_berry" in log and "activated" in log, log
