"""Ctrl-C and SIGTERM as stop requests (pmr_ros.ros.signals)."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from pmr_ros.ros.signals import STOP_SIGNALS, stop_requests


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
