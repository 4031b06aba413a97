"""Consecutive windows for a pool's workers: each walks a contiguous share and, when done, takes half of another.

A worker's pieces (:class:`~pmr_ros.core.pmr.piecewise.PieceCache`) serve the
window after its last one: that window computes one new day, a window anywhere
else computes every day it holds (for a 4x8 with 14-day windows, 0.57 s of CPU
against 0.20-0.33 s).  Chunks dealt by the pool as workers come free (16 for a
year's 352 windows on 2 workers) started cold whenever a worker's next chunk did
not follow its last.  Shares start cold once per worker and once per steal: a
worker whose share is done takes the back half of the largest share left
(:func:`take_window`), so the workers still finish together.

Results come back one window at a time through a queue, as the windows are
done, not at the end of a share: the parent unpickles them while the workers
run, and a failing window is reported as soon as its share fails.  A worker
that dies (killed, out of memory) is reported too: it breaks the executor
(:func:`~pmr_ros.core.sim.workers.worker_pool`), whose shares' futures then fail
rather than the windows it held being waited for forever.
"""

from __future__ import annotations

import queue
from collections.abc import Iterator, MutableSequence, Sequence
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.context import BaseContext
from typing import Any

from .refusal import ServiceError

__all__ = ["MIN_STEAL", "WindowShares", "share_bounds", "take_window"]

MIN_STEAL = 4
"""The fewest windows left in a share for another worker to take the back half of them.

A stolen window starts cold (about a warm window's time more); below four, the owner's warm windows finish them
sooner than a thief's cold start would."""


def share_bounds(tasks: int, shares: int) -> list[int]:
    """``[next_0, end_0, next_1, end_1, ...]``: ``tasks`` windows in ``shares`` contiguous shares, as even as can be.

    Examples
    --------
    >>> share_bounds(10, 3)
    [0, 4, 4, 7, 7, 10]
    """
    if shares < 1 or tasks < 0:
        raise ValueError(f"share_bounds: {tasks} tasks in {shares} shares")
    size, larger = divmod(tasks, shares)
    cuts = [k * size + min(k, larger) for k in range(shares + 1)]  # the first ``larger`` shares one window more
    return [bound for k in range(shares) for bound in (cuts[k], cuts[k + 1])]


def take_window(bounds: MutableSequence[int], share: int, *, min_steal: int = MIN_STEAL) -> int | None:
    """The next window of ``share``; when its own are done, the first of the back half of the largest share left.

    The stolen half becomes ``share``'s: its next windows follow the stolen one.  ``bounds`` is
    :func:`share_bounds`' layout and is updated in place (the caller holds the lock when it is shared).

    Parameters
    ----------
    bounds : mutable sequence of int
        ``[next_0, end_0, ...]``.
    share : int
        The taker's share.
    min_steal : int
        A share with fewer windows left is left to its owner.

    Returns
    -------
    int or None
        A window index; None when nothing is left to take.

    Examples
    --------
    >>> bounds = [0, 2, 2, 10]
    >>> take_window(bounds, 0), take_window(bounds, 0), take_window(bounds, 0), bounds
    (0, 1, 6, [7, 10, 2, 6])
    """
    begin, end = bounds[2 * share], bounds[2 * share + 1]
    if begin < end:
        bounds[2 * share] = begin + 1
        return begin
    left = [bounds[2 * k + 1] - bounds[2 * k] for k in range(len(bounds) // 2)]
    largest = max(range(len(left)), key=left.__getitem__)
    if left[largest] < max(min_steal, 1):
        return None
    victim_next, victim_end = bounds[2 * largest], bounds[2 * largest + 1]
    middle = victim_next + (victim_end - victim_next + 1) // 2  # the owner keeps the front half, the larger one
    bounds[2 * largest + 1] = middle
    bounds[2 * share], bounds[2 * share + 1] = middle + 1, victim_end
    return middle


class WindowShares:
    """The shares of ``tasks`` for ``jobs`` workers, and the queue their results come back through.

    Made in the parent and handed to each pool worker in its initializer's arguments (the bounds are shared
    memory, the queue a pipe).  A worker runs ``take(share)`` until None and sends each result with ``put``;
    the parent submits one such task per share and reads the results from :meth:`results`.

    Parameters
    ----------
    tasks : sequence
        The windows, in order; a worker gets them by index.
    jobs : int
        Workers (one share each).
    context : multiprocessing context
        The pool's (its start method decides how the lock and queue reach the workers).
    """

    def __init__(self, tasks: Sequence[Any], jobs: int, context: BaseContext):
        self.tasks = tuple(tasks)
        self._bounds = context.Array("q", share_bounds(len(self.tasks), jobs))
        self._queue = context.Queue()

    def take(self, share: int) -> Any | None:
        """The next task of ``share`` (:func:`take_window`), or None when every window is taken."""
        with self._bounds.get_lock():
            index = take_window(self._bounds.get_obj(), share)  # type: ignore[arg-type]  # a ctypes array of int64
        return None if index is None else self.tasks[index]

    def put(self, result: Any) -> None:
        """Send one window's result to the parent."""
        self._queue.put(result)

    def results(self, running: Sequence[Future[Any]], *, poll_s: float = 0.5) -> Iterator[Any]:
        """Every window's result as it comes, until all ``len(tasks)`` have; ``running``: the shares' futures.

        The futures are looked at whenever the queue is quiet for ``poll_s`` seconds.

        Raises
        ------
        Exception
            What a worker's share raised (a window's error), as soon as its future holds it.
        ServiceError
            A worker process ended before the windows were done (one line; exit code 1).
        """
        for done in range(len(self.tasks)):
            while True:
                try:
                    yield self._queue.get(timeout=poll_s)
                    break
                except queue.Empty:
                    self._check(running, done)

    def _check(self, running: Sequence[Future[Any]], done: int) -> None:
        """Raise what a share's future that ended without its windows holds."""
        for future in running:
            if not future.done() or future.exception() is None:
                continue
            try:
                future.result()  # raises the worker's error here
            except BrokenProcessPool:  # a worker ended (SIGKILL, the out-of-memory killer): the pool is broken
                raise ServiceError(
                    f"a window worker process ended before its windows were done (killed? out of memory?): "
                    f"{done} of {len(self.tasks)} windows diagnosed",
                    code=1,
                ) from None
