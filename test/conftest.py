"""Shared fixtures of the pmr_ros test suite."""

from __future__ import annotations

import signal

import pytest
from session_share import SharedValues

from pmr_ros.config import load_config


def pytest_configure(config):
    """Ctrl-C as a terminal gives it, whoever started the suite.

    A command a non-interactive shell starts in the background (``./test.sh &``, some CI runners) inherits
    SIGINT ignored, and Python then leaves it ignored: the tests that send Ctrl-C to a pool or a node
    would see nothing happen, and every process they start would inherit it too.  A handled signal is
    reset to its default in a new program, so the processes the tests start take Ctrl-C as from a shell.
    """
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def wood_berry():
    """The shipped Wood-Berry configuration."""
    return load_config()


@pytest.fixture(scope="session")
def shared(tmp_path_factory):
    """``shared(name, compute)``: ``compute()`` once per test session, shared by the xdist workers.

    ``name`` must say every input of ``compute`` (test/session_share.py); for read-only results.
    """
    return SharedValues(tmp_path_factory)


# ROS 2 isolation fixtures (a private rclpy Context and ROS domain per test): test/ros_fixtures.py
from ros_fixtures import children, ros, ros_context, ros_domain  # noqa: E402,F401
