"""ROS 2 test isolation: each test gets its own rclpy Context in its own ROS domain, and owns its nodes.

Discovery is limited to this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``)
and every test claims a domain id that no test of this pytest session had
before and no concurrent run holds (a lock file, with a cool-down after its
release), so tests cannot hear each other, leftovers of earlier tests or
anything else on the machine.  The ``ros`` fixture owns a test's nodes,
executor and child processes and ends them however the test ends.  Imported
by ``test/conftest.py``.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

DOMAIN_IDS = range(1, 102)
"""Domain ids the tests draw from: 1..101, the range ROS 2 documents as safe on Linux.  Above 101 a
domain's DDS ports (7400 + 250 x domain + ...) fall into Linux's ephemeral port range (32768-60999),
where any other socket may hold them.  (An empty recorder bag once blamed on this range was DDS
discovery taking up to 2.6 s: see ``simulation.discovery_settle_s``.)"""

COOLDOWN_S = 10.0
"""A domain id released by a test (of any pytest run) is not claimed again for this long [s]: the last
messages of its processes, killed or not, must not reach the next test."""

_USED_THIS_SESSION: set[int] = set()
"""Domain ids this pytest session has claimed: never claimed twice."""


def _lock_folder() -> Path:
    folder = Path(tempfile.gettempdir()) / "pmr_ros_test_domains"
    folder.mkdir(exist_ok=True)
    return folder


def _released_recently(handle) -> bool:
    handle.seek(0)
    text = handle.read().strip()
    try:
        return time.time() - float(text) < COOLDOWN_S
    except ValueError:
        return False


def _try_claim(domain: int):
    """The locked lock file of ``domain``, or None when another holder has it or released it just now."""
    handle = open(_lock_folder() / f"{domain}.lock", "a+")  # noqa: SIM115 - held until released
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        return None
    if _released_recently(handle):
        fcntl.flock(handle, fcntl.LOCK_UN)
        handle.close()
        return None
    return handle


def _release(handle) -> None:
    handle.seek(0)
    handle.truncate()
    handle.write(f"{time.time():.3f}")
    handle.flush()
    fcntl.flock(handle, fcntl.LOCK_UN)
    handle.close()


@contextmanager
def claimed_domain() -> Iterator[int]:
    """Hold a ROS domain id that no other test of this session ever had and no other holder has now."""
    start = os.getpid() % len(DOMAIN_IDS)
    for step in range(len(DOMAIN_IDS)):
        domain = DOMAIN_IDS[(start + step) % len(DOMAIN_IDS)]
        if domain in _USED_THIS_SESSION:
            continue
        handle = _try_claim(domain)
        if handle is None:
            continue
        _USED_THIS_SESSION.add(domain)
        try:
            yield domain
        finally:
            _release(handle)
        return
    raise RuntimeError(
        f"no free ROS domain id for the test: this session used {len(_USED_THIS_SESSION)} of {len(DOMAIN_IDS)}, "
        "the others are held by concurrent runs or were released less than "
        f"{COOLDOWN_S:g} s ago"
    )


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
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


class RosOwner:
    """Owns a test's nodes, executors and child processes, and ends them all whatever happens.

    ``ros.add(node)`` adopts a node (and adds it to the test's executor),
    ``ros.spin_until(predicate)`` spins them, ``ros.start(argv, log)`` starts a
    child process; :meth:`close` (the fixture's teardown) shuts the executor
    down, destroys every node in reverse order and kills every child still
    running, even when the test failed half-way.
    """

    def __init__(self, context) -> None:
        from pmr_ros.node_set import make_executor

        self.context = context
        self.nodes: list = []
        # the node set's own executor (pmr-ros run's default): a test's in-process loop of thousands of samples
        # ran 3-4 times slower on rclpy's SingleThreadedExecutor, which rebuilds its wait set at every spin
        self.executor = make_executor("events", context)
        self.processes: list[subprocess.Popen] = []
        self._logs: list = []

    def add(self, node):
        """Adopt ``node``: spun by :attr:`executor`, destroyed at the end of the test."""
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def create_node(self, name: str, **kwargs):
        """A plain rclpy node on the test's Context, adopted."""
        import rclpy

        return self.add(rclpy.create_node(name, context=self.context, **kwargs))

    def spin_until(self, predicate: Callable[[], bool], timeout_s: float = 10.0) -> bool:
        """Spin the test's nodes until ``predicate()`` holds or ``timeout_s`` passes; whether it held."""
        return spin_until(self.executor, predicate, timeout_s)

    def spin_for(self, seconds: float) -> None:
        """Spin the test's nodes for ``seconds`` of wall time."""
        spin_until(self.executor, lambda: False, seconds)

    def start(self, argv: list[str], log: Path, env: dict[str, str] | None = None) -> subprocess.Popen:
        """A child process (stdout and stderr into ``log``), killed at the end of the test if still running."""
        handle = open(log, "w+")  # noqa: SIM115 - closed in close()
        self._logs.append(handle)
        proc = subprocess.Popen(argv, stdout=handle, stderr=subprocess.STDOUT, env=env or dict(os.environ))
        self.processes.append(proc)
        return proc

    def close(self) -> None:
        """Kill the children, shut the executor down, destroy the nodes (newest first)."""
        for proc in self.processes:
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=30)
        for handle in self._logs:
            handle.close()
        self.executor.shutdown(timeout_sec=1.0)
        for node in reversed(self.nodes):
            node.destroy_node()


@pytest.fixture
def ros(ros_context) -> Iterator[RosOwner]:
    """The test's nodes, executor and child processes (:class:`RosOwner`), ended after it in all cases."""
    owner = RosOwner(ros_context)
    try:
        yield owner
    finally:
        owner.close()


@pytest.fixture
def children() -> Iterator[list[subprocess.Popen]]:
    """Child processes a test starts (append them): killed after it if still running."""
    procs: list[subprocess.Popen] = []
    try:
        yield procs
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=30)


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
