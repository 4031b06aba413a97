"""The node set's stall watch: a silent loop is a stall, a diagnostician still at work is not."""

import time
from types import SimpleNamespace

import pytest

from pmr_ros.node_set import NodeSetError, _Watch

TIMEOUT_S = 0.2


def _diagnostician(**state):
    fields = {"busy": False, "messages_received": 0, "run_complete": False}
    fields.update(state)
    return SimpleNamespace(**fields, finish_run=lambda: None)


def _wait_past_timeout(watch: _Watch) -> None:
    time.sleep(TIMEOUT_S * 1.5)
    watch.check()


def test_a_plant_that_stops_before_its_last_sample_is_a_stall():
    plant = SimpleNamespace(sample=10, finished=False)
    watch = _Watch(plant, 100, TIMEOUT_S, _diagnostician())
    watch.check()
    with pytest.raises(NodeSetError, match="stalled at sample 10 of 100"):
        _wait_past_timeout(watch)


def test_no_final_verdicts_from_an_idle_diagnostician_after_the_last_sample_is_a_stall():
    plant = SimpleNamespace(sample=99, finished=True)
    watch = _Watch(plant, 100, TIMEOUT_S, _diagnostician())
    watch.check()
    with pytest.raises(NodeSetError, match="no final verdicts"):
        _wait_past_timeout(watch)


def test_a_diagnosis_running_after_the_last_sample_is_progress_however_long_it_takes():
    plant = SimpleNamespace(sample=99, finished=True)
    diagnostician = _diagnostician(busy=True)
    watch = _Watch(plant, 100, TIMEOUT_S, diagnostician)
    for _ in range(3):  # three stall timeouts of a busy diagnostician
        _wait_past_timeout(watch)
    diagnostician.busy = False
    watch.check()  # idle from now on: the silence counts again
    with pytest.raises(NodeSetError, match="no final verdicts"):
        _wait_past_timeout(watch)


def test_samples_still_reaching_the_diagnostician_are_progress():
    plant = SimpleNamespace(sample=99, finished=True)
    diagnostician = _diagnostician()
    watch = _Watch(plant, 100, TIMEOUT_S, diagnostician)
    for _ in range(3):
        diagnostician.messages_received += 5  # a backlog of queued samples being taken
        _wait_past_timeout(watch)
    with pytest.raises(NodeSetError, match="no final verdicts"):
        _wait_past_timeout(watch)
