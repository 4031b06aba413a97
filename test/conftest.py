"""Shared fixtures of the pmr_ros test suite."""

from __future__ import annotations

import pytest

from pmr_ros.config import load_config


@pytest.fixture(scope="session")
def wood_berry():
    """The shipped Wood-Berry configuration."""
    return load_config()


# ROS 2 isolation fixtures (a private rclpy Context and ROS domain per test): test/ros_fixtures.py
from ros_fixtures import children, ros, ros_context, ros_domain  # noqa: E402,F401
