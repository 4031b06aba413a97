"""Shared fixtures of the pmr_ros test suite."""

from __future__ import annotations

import pytest
from session_share import SharedValues

from pmr_ros.config import load_config


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
