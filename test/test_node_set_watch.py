"""The node set's watch: only progress toward the run's end counts, and every wait ends in one line."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from pmr_ros.ros.run_watch import REAL_TIME_ALLOWANCE_S, RunLimits, RunStalled, RunWatch

STALL_S, VERDICT_S, START_S = 2.0, 10.0, 20.0
LABELS = {"r": "r on /pmr/setpoint", "u": "u on /pmr/manipulated_input", "y": "y on /pmr/measured_output"}


def _diagnostician(**state):
    d = SimpleNamespace(busy=False, run_complete=False, aligner=SimpleNamespace(newest=dict.fromkeys("ruy")))
    d.finish_run = lambda: setattr(d, "run_complete", True)
    d.__dict__.update(state)
    return d


def _listener(recorded=None):
    counts = dict(recorded or {})
    return SimpleNamespace(final=None, final_has_verdict=False, estimates=None, counts=counts, recorded=lambda: counts)


def _watch(plant, diagnostician=None, listener=None, rate_hz=0.0, others=()):
    limits = RunLimits(100, STALL_S, VERDICT_S, START_S, rate_hz)
    d = diagnostician or _diagnostician()
    return RunWatch(plant, d, listener or _listener(), limits, labels=LABELS, others=others)


def _took(d, k):
    d.aligner.newest = dict.fromkeys("ruy", k)


def test_a_plant_that_stops_before_its_last_sample_is_a_stall():
    plant = SimpleNamespace(sample=10, finished=False)
    watch = _watch(plant)
    watch.check(now=0.0)
    watch.check(now=STALL_S)
    with pytest.raises(RunStalled, match="plant is at sample 10 of 100"):
        watch.check(now=STALL_S + 0.1)


def test_a_plant_that_never_starts_fails_after_its_start_bound():
    plant = SimpleNamespace(sample=-1, finished=False)
    watch = _watch(plant)
    watch.check(now=watch.created + START_S)
    with pytest.raises(RunStalled, match=f"no sample within {START_S:g} s"):
        watch.check(now=watch.created + START_S + 0.1)


def test_a_real_time_run_has_a_wall_clock_bound_however_steadily_it_goes():
    plant = SimpleNamespace(sample=0, finished=False)
    watch = _watch(plant, rate_hz=50.0)
    bound = 100 * (1 / 50.0 + REAL_TIME_ALLOWANCE_S) + STALL_S
    watch.check(now=0.0)
    t = 0.0
    while t + 1.0 < bound:  # a sample every second: never a stall, but far slower than 50 samples/s
        t += 1.0
        plant.sample += 1
        watch.check(now=t)
    with pytest.raises(RunStalled, match=r"real-time run did not end within 14 s \(100 samples at 50 samples/s\)"):
        plant.sample += 1
        watch.check(now=bound + 0.1)


def test_no_final_verdicts_from_an_idle_diagnostician_after_the_last_sample_is_a_stall():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician()
    _took(d, 99)
    watch = _watch(plant, d)
    watch.check(now=0.0)
    assert d.run_complete  # told the run is over
    with pytest.raises(RunStalled, match=r"no final verdicts \(for sample 99\) on /diagnostics"):
        watch.check(now=STALL_S + 0.1)


def test_a_busy_diagnostician_gets_the_verdict_timeout_and_no_more():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician(busy=True)
    _took(d, 99)
    watch = _watch(plant, d)
    watch.check(now=0.0)
    watch.check(now=VERDICT_S)  # a long diagnosis: past the stall timeout, within the verdict timeout
    with pytest.raises(RunStalled, match="worker still busy.*no final verdicts"):
        watch.check(now=VERDICT_S + 0.1)


def test_samples_the_diagnostician_takes_up_to_the_last_are_progress():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician()
    _took(d, 80)
    watch = _watch(plant, d)
    watch.check(now=0.0)
    for i, k in enumerate((85, 90, 95), start=1):  # a backlog being taken: each within the stall timeout
        _took(d, k)
        watch.check(now=i * STALL_S)
    with pytest.raises(RunStalled, match="diagnostician has taken r on /pmr/setpoint at sample 95"):
        watch.check(now=4 * STALL_S + 0.1)


def test_messages_after_the_last_sample_are_no_progress():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician()
    _took(d, 99)
    watch = _watch(plant, d)
    watch.check(now=0.0)
    for i in range(1, 4):  # a stray producer goes on: later stamps, and old ones again
        d.aligner.newest = {"r": 99, "u": 99, "y": 99 + 10 * i}
        watch.check(now=i * STALL_S / 4)
    with pytest.raises(RunStalled, match="no final verdicts"):
        watch.check(now=STALL_S + 0.1)


def test_a_listener_missing_samples_names_the_topic():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician()
    _took(d, 99)
    watch = _watch(plant, d, _listener({"r": 100, "u": 98, "y": 100}))
    watch.check(now=0.0)
    with pytest.raises(RunStalled, match=r"not recorded every sample: u on /pmr/manipulated_input \(98 of 100"):
        watch.check(now=STALL_S + 0.1)


def test_final_verdicts_without_estimates_and_an_unfinished_node_are_named():
    plant, d = SimpleNamespace(sample=99, finished=True), _diagnostician()
    _took(d, 99)
    listener = _listener()
    listener.final, listener.final_has_verdict = object(), True
    recorder = SimpleNamespace(done=False, get_name=lambda: "bag_recorder")
    watch = _watch(plant, d, listener, others=[recorder])
    watch.check(now=0.0)
    with pytest.raises(RunStalled, match="no estimates for sample 99"):
        watch.check(now=STALL_S + 0.1)
    listener.estimates = object()
    watch.check(now=STALL_S + 0.2)  # the estimates came: progress
    with pytest.raises(RunStalled, match="waiting for bag_recorder to be done"):
        watch.check(now=2 * STALL_S + 0.3)


def test_a_namespaced_run_names_its_own_diagnostics_and_estimates_topics():
    plant, d, listener = SimpleNamespace(sample=99, finished=True), _diagnostician(), _listener()
    _took(d, 99)
    names = {"diagnostics": "/column_a/diagnostics", "estimates": "/column_a/pmr/estimates"}
    watch = RunWatch(plant, d, listener, RunLimits(100, STALL_S, VERDICT_S, START_S), labels={**LABELS, **names})
    watch.check(now=0.0)
    with pytest.raises(RunStalled, match=r"no final verdicts \(for sample 99\) on /column_a/diagnostics;"):
        watch.check(now=STALL_S + 0.1)
    listener.final, listener.final_has_verdict = object(), True
    watch.check(now=STALL_S + 0.2)  # the verdicts came: progress
    with pytest.raises(RunStalled, match="no estimates for sample 99 on /column_a/pmr/estimates"):
        watch.check(now=2 * STALL_S + 0.3)
