"""Ctrl-C and SIGTERM as stop requests (pmr_ros.ros.signals)."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from pmr_ros.ros.signals import STOP_SIGNALS, RosInitError, rclpy_session, stop_requests


@pytest.mark.parametrize("number", STOP_SIGNALS)
def test_a_stop_signal_is_noted_not_raised_and_the_old_handler_comes_back(number):
    before = signal.getsignal(number)
    with stop_requests() as stop:
        os.kill(os.getpid(), number)
        # Python runs the handler at the next bytecode boundary in the main thread
        for _ in range(1000):
            if stop:
                break
        assert stop == [number]
    assert signal.getsignal(number) is before


def test_off_the_main_thread_nothing_is_installed():
    seen = {}

    def body():
        with stop_requests() as stop:
            seen["handlers"] = {sig: signal.getsignal(sig) for sig in STOP_SIGNALS}
            seen["stop"] = stop

    before = {sig: signal.getsignal(sig) for sig in STOP_SIGNALS}
    thread = threading.Thread(target=body)
    thread.start()
    thread.join()
    assert seen["handlers"] == before and seen["stop"] == []


def test_an_rclpy_session_runs_rclpy_until_its_end_and_takes_sigterm_as_a_request(ros_domain):
    import rclpy

    with rclpy_session([]) as stop:
        assert rclpy.ok()
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            if stop:
                break
        assert stop == [signal.SIGTERM] and rclpy.ok()  # noted, rclpy left running
    assert not rclpy.ok()


def test_an_rclpy_session_that_cannot_start_says_why_and_leaves_the_handlers(ros_domain):
    before = {sig: signal.getsignal(sig) for sig in STOP_SIGNALS}
    with pytest.raises(RosInitError, match="nonexistent"):
        with rclpy_session(["prog", "--ros-args", "--params-file", "/nonexistent/params.yaml"]):
            pass
    assert {sig: signal.getsignal(sig) for sig in STOP_SIGNALS} == before
