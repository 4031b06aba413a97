"""Console-script entry points that take Ctrl-C and SIGTERM from the first line of pmr_ros on.

A console script imports its module before it calls ``main``, and importing
rclpy, numpy and scipy takes a second or more.  A ``KeyboardInterrupt`` raised
in the middle of that lands inside a C extension's import and ends in a
traceback (or an ``ImportError`` about ``datetime``, from numpy).  So these
wrappers, which import nothing heavy, only *note* a SIGINT or SIGTERM while
the command's modules load; if one came, they exit quietly once the import
is complete, without running the command.  Then SIGINT and SIGTERM raise
``KeyboardInterrupt`` again (as Ctrl-C does), and each command takes them its
own way (nodes: :mod:`pmr_ros.ros.signals`, ``pmr-ros``: :mod:`pmr_ros.cli`);
one it did not catch still ends quietly.

What no Python code can take: a signal in the first tenth of a second or so,
while CPython initialises itself, before the first line of the script runs.
"""

from __future__ import annotations

import importlib
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any

__all__ = [
    "mpc_controller",
    "pmr_diagnostician",
    "pmr_diagnostician_lifecycle",
    "pmr_ros",
    "prbs_setpoint",
    "wood_berry_plant",
]

EXIT_INTERRUPTED = 130
"""``pmr-ros``'s exit code when interrupted (a node stopped by a signal exits 0, as when running)."""

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _load(module: str) -> Callable[[], Any] | None:
    """``module.main``, imported while stop signals are only noted; None if one came meanwhile."""
    noted: list[int] = []
    on_main_thread = threading.current_thread() is threading.main_thread()
    if on_main_thread:
        for number in STOP_SIGNALS:
            signal.signal(number, lambda signum, frame: noted.append(signum))
    try:
        main = importlib.import_module(module).main
    finally:
        if on_main_thread:
            for number in STOP_SIGNALS:
                signal.signal(number, _interrupt)
    return None if noted else main


def _run(module: str, interrupted: int) -> int:
    """Import ``module`` and return its ``main()``; ``interrupted`` if a stop signal ended it first."""
    try:
        main = _load(module)
        if main is not None:
            return int(main() or 0)
    except KeyboardInterrupt:
        pass
    print(f"{sys.argv[0].rpartition('/')[2]}: interrupted", file=sys.stderr)
    return interrupted


def pmr_ros() -> int:
    """``pmr-ros``."""
    return _run("pmr_ros.cli", EXIT_INTERRUPTED)


def wood_berry_plant() -> int:
    """``wood_berry_plant``."""
    return _run("pmr_ros.nodes.plant", 0)


def prbs_setpoint() -> int:
    """``prbs_setpoint``."""
    return _run("pmr_ros.nodes.prbs_setpoint", 0)


def mpc_controller() -> int:
    """``mpc_controller``."""
    return _run("pmr_ros.nodes.mpc_controller", 0)


def pmr_diagnostician() -> int:
    """``pmr_diagnostician``."""
    return _run("pmr_ros.nodes.pmr_diagnostician", 0)


def pmr_diagnostician_lifecycle() -> int:
    """``pmr_diagnostician_lifecycle``: the diagnostician as a managed node."""
    return _run("pmr_ros.nodes.managed_diagnostician", 0)
