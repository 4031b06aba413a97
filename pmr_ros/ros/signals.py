"""Ctrl-C and SIGTERM as stop requests, taken between spins.

rclpy's own handlers shut the Context down from a helper thread.  Under load
that races the executor's wait: a SIGTERM'd node process could sleep in
``rcl_wait`` forever (reproduced: 2 of 25 stops of four node processes on a busy
2-core machine).  A signal that only notes a request, read by a loop that
spins with a timeout, cannot be lost that way, and it never interrupts a
callback half-way (a half-written bag record, a half-stepped plant).
:func:`rclpy_session` is that set-up for a process's default Context.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
"""The signals that ask a pmr_ros process to stop cleanly."""

_DEFAULT_HANDLERS = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}


@contextmanager
def stop_requests() -> Iterator[list[int]]:
    """While inside, Ctrl-C and SIGTERM only append their number to the yielded list.

    Initialise rclpy with ``signal_handler_options=SignalHandlerOptions.NO`` and
    spin with a timeout (``spin_once(timeout_sec=...)``), checking the list
    between spins.  The previous handlers come back on exit.  Off the main
    thread (where Python cannot set handlers) the list simply stays empty.
    """
    requests: list[int] = []
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous = {sig: signal.signal(sig, lambda number, frame: requests.append(number)) for sig in STOP_SIGNALS}
    try:
        yield requests
    finally:
        for sig, handler in previous.items():
            # None: the handler was installed outside Python (rclpy's); fall back to the default
            signal.signal(sig, handler if handler is not None else _DEFAULT_HANDLERS[sig])


class RosInitError(RuntimeError):
    """rclpy could not start (e.g. a bad ``--ros-args`` or params file); the message says why."""


@contextmanager
def rclpy_session(args: list[str] | None = None) -> Iterator[list[int]]:
    """Rclpy on the default Context, stopped by the yielded :func:`stop_requests` list.

    rclpy is initialised without its own signal handlers and shut down on exit
    (after the body has destroyed its nodes).

    Parameters
    ----------
    args : list of str, optional
        Command line with ``--ros-args`` (default: ``sys.argv``).

    Raises
    ------
    RosInitError
        When rclpy refuses to start; rcl reports a bad ``--ros-args`` or
        params file only as a generic error.
    """
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    with stop_requests() as stop:
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except Exception as exc:
            raise RosInitError(str(exc)) from None
        try:
            yield stop
        finally:
            rclpy.try_shutdown()
