"""Console-script entry points that take Ctrl-C and SIGTERM from the first instant.

A console script imports its module before it calls ``main``, and importing
rclpy, numpy and scipy takes a second or more; a Ctrl-C meanwhile would end in
a ``KeyboardInterrupt`` traceback.  These wrappers import nothing heavy: they
make SIGINT and SIGTERM raise ``KeyboardInterrupt`` (as Ctrl-C does), import
the command and run it, and turn an interrupt that the command did not handle
itself into a quiet exit.  Once running, each command takes the signals its
own way (nodes: :mod:`pmr_ros.ros.signals`, ``pmr-ros``: :mod:`pmr_ros.cli`).
"""

from __future__ import annotations

import importlib
import signal
import sys
import threading
from types import FrameType

__all__ = ["mpc_controller", "pmr_diagnostician", "pmr_ros", "prbs_setpoint", "wood_berry_plant"]

EXIT_INTERRUPTED = 130
"""``pmr-ros``'s exit code when interrupted (a node stopped by a signal exits 0, as when running)."""


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _run(module: str, interrupted: int) -> int:
    """Import ``module`` and return its ``main()``; ``interrupted`` if a signal came first."""
    if threading.current_thread() is threading.main_thread():
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, _interrupt)
    try:
        main = importlib.import_module(module).main
        return int(main() or 0)
    except KeyboardInterrupt:
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
