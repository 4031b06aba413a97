"""Lockstep flow control (pmr_ros.ros.flow) and the diagnostician's worker thread (pmr_ros.ros.worker)."""

from __future__ import annotations

import struct
import threading
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip

from pmr_ros.bag.storage import typestore  # noqa: E402
from pmr_ros.ros.flow import ProgressGate, ProgressReporter, cdr_stamp_ns, stamp_ns  # noqa: E402
from pmr_ros.ros.worker import SerialWorker  # noqa: E402


def _time(ns: int):
    sec, nanosec = divmod(ns, 1_000_000_000)
    return typestore().types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def test_cdr_stamp_is_read_from_joint_states_and_clocks_without_decoding():
    ts = typestore()
    header = ts.types["std_msgs/msg/Header"](stamp=_time(1_234_500_000_007), frame_id="wood_berry")
    state = ts.types["sensor_msgs/msg/JointState"](
        header=header, name=["a"], position=np.array([1.0]), velocity=np.array([]), effort=np.array([])
    )
    data = ts.serialize_cdr(state, "sensor_msgs/msg/JointState")
    assert cdr_stamp_ns(data) == 1_234_500_000_007
    clock = ts.serialize_cdr(
        ts.types["rosgraph_msgs/msg/Clock"](clock=_time(42_000_000_000)), "rosgraph_msgs/msg/Clock"
    )
    assert cdr_stamp_ns(clock) == 42_000_000_000
    big_endian = bytes([0, 0, 0, 0]) + struct.pack(">iI", 7, 5)
    assert cdr_stamp_ns(big_endian) == 7_000_000_005
    with pytest.raises(ValueError, match="no time stamp"):
        cdr_stamp_ns(b"\x00\x01\x00\x00")
    assert stamp_ns(_time(3_000_000_001)) == 3_000_000_001


def test_a_gate_holds_the_producer_until_every_consumer_has_taken_the_sample_max_ahead_back(ros):
    consumer = ros.create_node("consumer", namespace="/column_a")
    producer = ros.create_node("producer", namespace="/column_a")
    changes = []
    gate = ProgressGate(producer, max_ahead=3, on_change=lambda: changes.append(1))
    reporter = ProgressReporter(consumer, ["r", "y"])
    try:
        name = "/column_a/consumer"
        assert ros.spin_until(lambda: name in gate.consumers(), 30.0), "the consumer is not in the graph"
        stamps = [k * 1_000_000_000 for k in range(10)]
        assert gate.open()  # nothing out yet
        gate.published(stamps[0])
        # the first sample must be taken by everyone first, on every topic: y alone is not enough
        assert gate.behind() == {name: None} and not gate.open()
        reporter.took("y", stamps[0])
        reporter.report()
        assert reporter.progress_ns is None and reporter.reports == 0
        reporter.took("r", stamps[0])
        reporter.report()
        assert ros.spin_until(lambda: gate.open(), 10.0) and changes
        for k in (1, 2):
            gate.published(stamps[k])
            assert gate.open()  # up to max_ahead (3) samples ahead of what was taken
        gate.published(stamps[3])
        assert not gate.open()  # sample 1 is needed now
        reporter.took("y", stamps[5])
        assert reporter.progress_ns == stamps[0]  # the oldest of the newest per topic
        reporter.took("r", stamps[4])
        reporter.report()
        assert ros.spin_until(lambda: gate.open(), 10.0)
        assert gate.behind() == {} and gate.consumers() == {name: stamps[4]}
        reporter.held = True  # a stopping consumer reports nothing more
        reporter.took("r", stamps[9]), reporter.took("y", stamps[9])
        reporter.report(repeat=True)
        ros.spin_for(0.3)
        assert gate.consumers() == {name: stamps[4]}
        gate.reset()
        assert gate.open()
    finally:
        reporter.destroy()
        gate.destroy()


def test_a_consumer_that_leaves_the_graph_holds_no_one(ros):
    producer = ros.create_node("producer")
    consumer = ros.create_node("consumer")
    gate = ProgressGate(producer, max_ahead=1, on_change=lambda: None)
    reporter = ProgressReporter(consumer, ["y"])
    try:
        assert ros.spin_until(lambda: "/consumer" in gate.consumers(), 30.0)
        gate.published(0)
        assert not gate.open()
        reporter.destroy()
        ros.executor.remove_node(consumer)
        ros.nodes.remove(consumer)
        consumer.destroy_node()
        assert ros.spin_until(lambda: gate.open(), 30.0), "the gate still waits for a destroyed consumer"
    finally:
        gate.destroy()


def test_a_worker_runs_jobs_in_order_off_the_callers_thread_and_survives_a_failing_one():
    errors = []
    worker = SerialWorker("test", errors.append)
    seen = []
    release = threading.Event()
    try:
        worker.submit(lambda: (release.wait(10), seen.append(("first", threading.current_thread().name))))
        worker.submit(lambda: 1 / 0)
        worker.submit(lambda: seen.append(("third", threading.current_thread().name)))
        assert worker.pending == 3 and not worker.wait_idle(0.05)
        release.set()
        assert worker.wait_idle(10.0) and worker.pending == 0 and worker.done == 3
        assert [s[0] for s in seen] == ["first", "third"]
        assert all(name.startswith("test") and name != threading.current_thread().name for _, name in seen)
        assert errors == ["ZeroDivisionError: division by zero"]
    finally:
        worker.shutdown()
    assert not worker.submit(lambda: seen.append("late")) and worker.pending == 0


def test_a_worker_shut_down_finishes_the_running_job_and_drops_the_queued_ones():
    worker = SerialWorker("test", lambda text: None)
    seen = []
    worker.submit(lambda: (time.sleep(0.2), seen.append(1)))
    for _ in range(5):
        worker.submit(lambda: seen.append(2))
    worker.shutdown()
    assert seen[0] == 1 and len(seen) < 6 and worker.pending == 0


def test_a_producer_started_late_hears_the_kept_report_once_matched(ros):
    """A restarted producer learns a run is under way from the consumers' kept reports, after the match."""
    consumer = ros.create_node("early_consumer")
    reporter = ProgressReporter(consumer, ["y"])
    reporter.took("y", 5_000_000_000)
    reporter.report()
    assert reporter.reports == 1
    producer = ros.create_node("late_producer")
    gate = ProgressGate(producer, max_ahead=1, on_change=lambda: None)
    try:
        name = "/early_consumer"
        assert ros.spin_until(lambda: name in gate.consumers() and gate.matched(), 30.0)
        assert ros.spin_until(lambda: gate.consumers() == {name: 5_000_000_000}, 10.0)
    finally:
        reporter.destroy()
        gate.destroy()
