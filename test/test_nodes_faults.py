"""The live diagnostician against a publisher it discovers late, and against gaps (real topics, one process).

Each test runs in its own ROS domain and rclpy Context (test/ros_fixtures.py) and destroys its nodes.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from ros_fixtures import spin_until

from pmr_ros.config import flatten_parameters, load_config
from pmr_ros.contract.layout import diagnosis_from_array
from pmr_ros.contract.topics import topic
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode
from pmr_ros.ros.convert import signal_message, text_message
from pmr_ros.ros.messages import message_class, qos_profile
from pmr_ros.ros.parameters import parameter_overrides

pytestmark = pytest.mark.ros

SAMPLES = 4096
WINDOW = {
    "diagnostician.window_samples": SAMPLES,
    "diagnostician.update_period_samples": SAMPLES,
    "diagnostician.min_samples": SAMPLES,
    "diagnostician.max_lag_samples": 64,
    "diagnostician.stale_timeout_s": 600.0,
    "impact.samples": 0,  # not checked here (test_nodes does): 9 closed loops of 4,096 samples per verdict saved
}
LATE = 600
"""Samples of r and y published before the u publisher exists: its transient-local backlog (depth 1000)."""


@cache
def _record():
    return simulate(load_config(), samples=SAMPLES)


class _Loop:
    """A diagnostician and a feeder node publishing a recorded run on r, u and y."""

    def __init__(self, context) -> None:
        flat = flatten_parameters(load_config().parameters)
        flat.update(WINDOW)
        self.diag = PmrDiagnosticianNode(context=context, parameter_overrides=parameter_overrides(flat))
        self.feeder = rclpy.create_node("feeder", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.pubs: dict = {}
        self.received: list = []
        t = topic("diagnostics")
        self.feeder.create_subscription(message_class(t), t.name, self.received.append, qos_profile(t.qos))
        for node in (self.diag, self.feeder):
            self.executor.add_node(node)

    def publisher(self, signal: str):
        key = {"r": "setpoint", "u": "manipulated_input", "y": "measured_output"}[signal]
        t = topic(key)
        self.pubs[signal] = self.feeder.create_publisher(message_class(t), t.name, qos_profile(t.qos))
        return self.pubs[signal]

    def send(self, signal: str, k: int) -> None:
        rec, model = _record(), self.diag.config.model
        values = {"r": rec.r, "u": rec.u, "y": rec.y}[signal][k]
        names = model.input_names if signal == "u" else model.output_names
        self.pubs[signal].publish(signal_message(values, names, k * model.sample_time))

    def final(self):
        out = [diagnosis_from_array(m) for m in self.received]
        return [(d, i) for d, i in out if i.get("last_sample") == SAMPLES - 1]

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.diag.destroy_node()
        self.feeder.destroy_node()


@pytest.fixture
def loop(ros_context):
    built = _Loop(ros_context)
    yield built
    built.close()


def test_a_publisher_discovered_late_loses_no_sample(loop):
    """The publisher of u appears after r and y passed sample 599; its backlog completes every pending sample."""
    for signal in ("r", "y"):
        loop.publisher(signal)
    assert spin_until(loop.executor, lambda: all(p.get_subscription_count() for p in loop.pubs.values()), 10.0)
    for k in range(LATE):
        loop.send("r", k), loop.send("y", k)
    assert spin_until(loop.executor, lambda: loop.diag.messages_received >= 2 * LATE, 60.0)
    assert loop.diag.aligner.stretch_last is None  # nothing complete without u
    u = loop.publisher("u")
    for k in range(LATE):  # published before the diagnostician matched: kept by transient-local durability
        loop.send("u", k)
    assert spin_until(loop.executor, lambda: u.get_subscription_count() >= 1, 10.0)
    assert spin_until(loop.executor, lambda: loop.diag.messages_received >= 3 * LATE, 60.0), "the backlog never came"
    assert loop.diag.aligner.stretch_length == LATE and loop.diag.aligner.gaps == 0
    for k in range(LATE, SAMPLES):
        for signal in ("r", "y", "u"):
            loop.send(signal, k)
        if k % 200 == 0:
            spin_until(loop.executor, lambda k=k: loop.diag.messages_received >= 3 * (k + 1), 60.0)
    assert spin_until(loop.executor, lambda: bool(loop.final()), 120.0), "no verdict for the whole run"
    (diagnosis, info), *_ = loop.final()
    assert diagnosis.status == "ok" and info["first_sample"] == 0 and info["window_samples"] == SAMPLES
    rec, config = _record(), loop.diag.config
    expected = diagnose(rec.r, rec.u, rec.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    assert {n: e.verdict for n, e in diagnosis.elements.items()} == {n: e.verdict for n, e in expected.elements.items()}
    for name, element in diagnosis.elements.items():
        np.testing.assert_allclose(
            element.parametric.gain_mismatch_pct, expected.elements[name].parametric.gain_mismatch_pct, rtol=1e-6
        )


def alias_bomb(levels: int = 9) -> str:
    """A 1 KB "billion laughs": ``levels`` lines of nine aliases each, 9**levels strings when expanded."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + f"\nsystem: *a{levels - 1}\nfirst_sample: 0\nrevision: 1\n"


def test_an_alias_bomb_on_the_model_topic_is_rejected_and_the_diagnostician_goes_on(loop):
    """The latched model topic carries a 1 KB alias bomb: one warning, the model kept, the verdicts as before."""
    t = topic("active_model")
    bomb = loop.feeder.create_publisher(message_class(t), t.name, qos_profile(t.qos))
    model_before = loop.diag.config.model
    bomb.publish(text_message("active_model", alias_bomb()))
    assert spin_until(loop.executor, lambda: bool(loop.diag.warnings), 20.0), "the bomb was never taken"
    assert "alias bomb" in loop.diag.warnings[0], loop.diag.warnings
    assert loop.diag.config.model is model_before
    for signal in ("r", "u", "y"):
        loop.publisher(signal)
    assert spin_until(loop.executor, lambda: all(p.get_subscription_count() for p in loop.pubs.values()), 10.0)
    for k in range(SAMPLES):
        for signal in ("r", "u", "y"):
            loop.send(signal, k)
        if k % 200 == 0:
            spin_until(loop.executor, lambda k=k: loop.diag.messages_received >= 3 * (k + 1), 60.0)
    assert spin_until(loop.executor, lambda: bool(loop.final()), 120.0), "no verdict after the bomb"
    (diagnosis, info), *_ = loop.final()
    assert diagnosis.status == "ok" and info["first_sample"] == 0 and info["window_samples"] == SAMPLES
    rec, config = _record(), loop.diag.config
    expected = diagnose(rec.r, rec.u, rec.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    assert {n: e.verdict for n, e in diagnosis.elements.items()} == {n: e.verdict for n, e in expected.elements.items()}
