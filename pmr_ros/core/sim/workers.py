"""Local worker processes: a fork server's executor whose killed workers end the run, not hang it.

:func:`worker_pool` is the one pool of the sweep, the benchmark, a monitor's
windows and a fleet: a ``concurrent.futures.ProcessPoolExecutor`` whose workers a
fork server starts (:func:`worker_context`), each with its module imported once
(:func:`preload_for`, :func:`start_fork_server`).  A worker killed mid-task (the
out-of-memory killer, SIGKILL) breaks the executor, so every task not done fails
at once; a ``multiprocessing.Pool`` would replace the worker and wait for its task
forever.  :func:`completed` streams the results as they come and turns a broken
pool into :class:`WorkerEnded` (how many were done), which each command words as
its one line.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from functools import partial
from typing import Any, TypeVar

__all__ = [
    "WorkerEnded",
    "completed",
    "preload_for",
    "start_fork_server",
    "worker_context",
    "worker_count",
    "worker_pool",
]

_Task = TypeVar("_Task")
_Result = TypeVar("_Result")


def worker_count(jobs: int | None, *, tasks: int | None = None) -> int:
    """Local worker processes for ``tasks`` tasks: ``jobs``, by default the cores; at least 1, at most one a task.

    Examples
    --------
    >>> worker_count(4, tasks=3), worker_count(2, tasks=0), worker_count(1)
    (3, 1, 1)
    """
    count = jobs or os.cpu_count() or 1
    return max(1, count if tasks is None else min(count, tasks))


def worker_context() -> multiprocessing.context.BaseContext:
    """The multiprocessing context for pools of batch runs: ``forkserver``.

    A plain fork copies a process that may already hold ROS 2 middleware
    threads (a node set run in the same process, as in the test suite or a
    shell that also diagnoses); such a child can crash in C++ code it
    inherited mid-operation.  Workers from a fork server start from a clean
    process instead.
    """
    return multiprocessing.get_context("forkserver")


def preload_for(context: multiprocessing.context.BaseContext, work: Callable[..., Any]) -> None:
    """Have the fork server of ``context`` import the module of ``work`` when it starts.

    Each worker otherwise imports it after the fork (2 s for the diagnosis's modules, most of it
    scipy.signal), and in turn: the pool waits on a worker's pipe while the worker, mid-way through reading
    its initial arguments, imports the module that defines its initializer.  A fork server's modules are set
    when it starts; one already running (a pool earlier in this process) keeps its own, and the workers
    import what it lacks themselves.
    """
    module = getattr(work, "__module__", None)
    if context.get_start_method() == "forkserver" and module not in (None, "__main__"):
        context.set_forkserver_preload([module])


def start_fork_server(initializer: Callable[..., None]) -> None:
    """Start :func:`worker_context`'s fork server now, importing ``initializer``'s module, and do not wait for it.

    The server imports while this process goes on (2 s for the diagnosis's modules); a :func:`worker_pool` made
    later with the same initializer connects to it and forks its workers at once.  Nothing happens when the
    server already runs.
    """
    import multiprocessing.forkserver

    context = worker_context()
    if context.get_start_method() == "forkserver":
        preload_for(context, initializer)
        multiprocessing.forkserver.ensure_running()


def _start_worker(initializer: Callable[..., None] | None, *initargs: Any) -> None:
    """A pool worker's start: Ctrl-C (sent to the whole group) left to the main process, then the initializer."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if initializer is not None:
        initializer(*initargs)


@contextmanager
def worker_pool(
    jobs: int, initializer: Callable[..., None] | None = None, initargs: tuple[Any, ...] = ()
) -> Iterator[ProcessPoolExecutor]:
    """An executor of ``jobs`` :func:`worker_context` workers, each set up by ``initializer(*initargs)``.

    The initializer's module is imported once by the fork server, which then forks the workers
    (:func:`preload_for`); every worker ignores Ctrl-C (:func:`_start_worker`). A worker that ends mid-task
    (SIGKILL, the out-of-memory killer) breaks the executor: every future not done raises
    ``BrokenProcessPool`` instead of being waited for forever, as a ``multiprocessing.Pool`` would.
    Shut down and waited for when the block ends; when it raises (a Ctrl-C, a worker's error, a broken
    pool) the tasks not begun are cancelled and the workers terminated, not waited for.
    """
    context = worker_context()
    if initializer is not None:
        preload_for(context, initializer)
    pool = ProcessPoolExecutor(
        max_workers=jobs, mp_context=context, initializer=partial(_start_worker, initializer), initargs=initargs
    )
    try:
        yield pool
    except BaseException:
        _terminate(pool)
        raise
    pool.shutdown(wait=True)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Cancel what ``pool`` has not begun and terminate its workers: ``terminate_workers()`` of Python 3.14."""
    terminate = getattr(pool, "terminate_workers", None)
    if terminate is not None:
        terminate()
        return
    # Python < 3.14 has no public way to stop a worker mid-task; shutdown(wait=False) leaves it running its task
    # (a sweep point, a window share: minutes). So terminate the executor's private ``_processes``, read before
    # shutdown forgets them, as 3.14 does; its manager thread then fails the futures left and joins them.
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.exitcode is None:
            process.terminate()


class WorkerEnded(RuntimeError):
    """A worker process ended mid-task (killed? out of memory?): the tasks not done by then are lost.

    Attributes
    ----------
    done, total : int
        The tasks whose results came, and all the tasks.
    unfinished : tuple
        The tasks whose results did not come, in the order they were given.
    """

    def __init__(self, *, done: int, total: int, unfinished: tuple[Any, ...] = ()) -> None:
        super().__init__(
            f"a worker process ended before its tasks were done (killed? out of memory?): {done} of {total} done"
        )
        self.done, self.total, self.unfinished = done, total, unfinished


def completed(pool: ProcessPoolExecutor, work: Callable[[_Task], _Result], tasks: Iterable[_Task]) -> Iterator[_Result]:
    """``work(task)`` of every task, run on ``pool``, each result as soon as it is done (in the order they finish).

    Raises
    ------
    WorkerEnded
        A worker process ended mid-task (the pool is broken): raised after every result that did come.
    Exception
        What ``work`` raised for a task, as soon as it is known.
    """
    futures = {pool.submit(work, task): task for task in tasks}
    lost: set[Future[_Result]] = set()
    for future in as_completed(futures):
        try:
            result = future.result()
        except BrokenProcessPool:  # this task's or another's worker ended; those done before still come
            lost.add(future)
            continue
        yield result
    if lost:
        unfinished = tuple(task for future, task in futures.items() if future in lost)
        raise WorkerEnded(done=len(futures) - len(lost), total=len(futures), unfinished=unfinished)
