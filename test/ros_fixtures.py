"""ROS 2 test isolation: each test gets its own rclpy Context in its own ROS domain.

Discovery is limited to this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``)
and every test claims a domain id no other test (in this or a concurrent
pytest run) holds, through a lock file, so tests cannot hear each other or
anything else on the machine.  Imported by ``test/conftest.py``.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

DOMAIN_IDS = range(120, 200)
"""Domain ids the tests draw from (Fast DDS ports stay below 65535 up to 232)."""


@contextmanager
def claimed_domain() -> Iterator[int]:
    """Hold a ROS domain id that no other holder of this function uses meanwhile."""
    folder = Path(tempfile.gettempdir()) / "pmr_ros_test_domains"
    folder.mkdir(exist_ok=True)
    start = os.getpid() % len(DOMAIN_IDS)
    for step in range(len(DOMAIN_IDS)):
        domain = DOMAIN_IDS[(start + step) % len(DOMAIN_IDS)]
        handle = open(folder / f"{domain}.lock", "w")  # noqa: SIM115 - held until released below
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        try:
            yield domain
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
            handle.close()
        return
    raise RuntimeError("no free ROS domain id for the test")


def ros_environment(domain: int) -> dict[str, str]:
    """Environment variables of an isolated run in ``domain`` (for child processes too)."""
    return {"ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}


@pytest.fixture
def ros_domain(monkeypatch) -> Iterator[int]:
    """A ROS domain id of this test alone, with localhost-only discovery in the environment."""
    with claimed_domain() as domain:
        for key, value in ros_environment(domain).items():
            monkeypatch.setenv(key, value)
        yield domain


@pytest.fixture
def ros_context(ros_domain):
    """An initialised rclpy Context of this test alone, shut down afterwards."""
    import rclpy  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    rclpy.try_shutdown(context=context)


def spin_until(executor, predicate: Callable[[], bool], timeout_s: float = 10.0) -> bool:
    """Spin ``executor`` until ``predicate()`` holds or ``timeout_s`` passes; whether it held."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.02)
    return True


def console_script_candidates(name: str) -> list[Path]:
    """Where an executable of pmr_ros may be installed, in the order :func:`console_script` tries them.

    1. ``<prefix>/lib/pmr_ros/<name>`` of the ament index (a sourced colcon
       workspace; setup.cfg's ``script_dir``): what ``ros2 run pmr_ros <name>``
       starts, so ``colcon test`` runs the built executables;
    2. next to the interpreter (``pip install [-e] .`` into a venv: ./test.sh);
    3. on ``PATH``.
    """
    from pmr_ros.resources import PACKAGE, ament_prefixes

    candidates = [prefix / "lib" / PACKAGE / name for prefix in ament_prefixes()]
    candidates.append(Path(sys.executable).parent / name)
    on_path = shutil.which(name)
    if on_path:
        candidates.append(Path(on_path))
    return candidates


def console_script(name: str) -> str:
    """Path of an installed executable of pmr_ros; its absence fails the test (./test.sh installs them all)."""
    candidates = console_script_candidates(name)
    for candidate in candidates:
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    tried = ", ".join(str(c) for c in candidates)
    pytest.fail(
        f"console script {name} not installed (looked in {tried}): run ./test.sh, which installs pmr_ros "
        "with pip install -e ., or source a colcon workspace"
    )
