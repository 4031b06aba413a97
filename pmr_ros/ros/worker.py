"""One background thread that runs a node's slow jobs in order, off the executor's thread.

The diagnostician's numerical work (a diagnosis of a 16,384-sample window
takes 50-500 ms) must not starve its subscriptions: while it runs on the
executor's thread no message is taken, and a lockstep producer waiting for
the consumer's progress stalls the whole loop.  The node takes a snapshot of
what a job needs on its own thread (so the result is the one it would have
computed there, whatever arrives meanwhile) and hands the job to a
:class:`SerialWorker`; jobs run one at a time in submission order, so the
statuses go out in the order they were due.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

__all__ = ["SerialWorker"]


class SerialWorker:
    """Runs submitted jobs one after another on a thread of its own.

    Parameters
    ----------
    name : str
        Prefix of the thread's name.
    on_error : callable
        Called with a one-line description when a job raises (the job is
        dropped; the next ones run).
    """

    def __init__(self, name: str, on_error: Callable[[str], None]) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
        self._on_error = on_error
        self._lock = threading.Lock()
        self._idle = threading.Condition(self._lock)
        self._pending = 0
        self._closed = False
        self.done = 0

    @property
    def pending(self) -> int:
        """Jobs submitted and not finished (the running one included)."""
        with self._lock:
            return self._pending

    def submit(self, job: Callable[[], None]) -> bool:
        """Queue ``job``; False (not queued) once the worker is shut down."""
        with self._lock:
            if self._closed:
                return False
            self._pending += 1
        self._pool.submit(self._run, job)
        return True

    def _run(self, job: Callable[[], None]) -> None:
        try:
            job()
        except Exception as exc:  # a failing job must not kill the worker; say what happened
            self._on_error(f"{type(exc).__name__}: {exc}")
        finally:
            with self._lock:
                self._pending -= 1
                self.done += 1
                self._idle.notify_all()

    def wait_idle(self, timeout_s: float) -> bool:
        """Block until no job is pending or ``timeout_s`` passed; whether it is idle."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            while self._pending:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._idle.wait(left)
        return True

    def shutdown(self) -> None:
        """Run no further jobs: finish the running one, drop the queued ones, join the thread."""
        with self._lock:
            self._closed = True
        self._pool.shutdown(wait=True, cancel_futures=True)
        with self._lock:
            self._pending = 0
            self._idle.notify_all()
