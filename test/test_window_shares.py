"""Contiguous window shares for pool workers: every window once, few cold starts, results and errors streamed."""

import os
import random
import signal

import pytest

from pmr_ros.core.sim.workers import worker_context, worker_pool
from pmr_ros.service.refusal import ServiceError
from pmr_ros.service.window_shares import MIN_STEAL, WindowShares, share_bounds, take_window


@pytest.mark.parametrize(("tasks", "shares"), [(352, 2), (10, 3), (3, 4), (0, 2), (1, 1), (101, 7)])
def test_shares_are_contiguous_cover_every_window_once_and_are_even(tasks, shares):
    bounds = share_bounds(tasks, shares)
    spans = [(bounds[2 * k], bounds[2 * k + 1]) for k in range(shares)]
    assert [i for begin, end in spans for i in range(begin, end)] == list(range(tasks))
    sizes = [end - begin for begin, end in spans]
    assert max(sizes) - min(sizes) <= 1 and sizes == sorted(sizes, reverse=True)


def test_a_share_of_no_workers_is_refused():
    with pytest.raises(ValueError, match="0 shares"):
        share_bounds(5, 0)


def _walk(tasks: int, jobs: int, seed: int) -> dict[int, list[int]]:
    """Workers taking windows in a random order of turns (unequal speeds): what each took, in order."""
    rng, bounds = random.Random(seed), share_bounds(tasks, jobs)
    taken: dict[int, list[int]] = {share: [] for share in range(jobs)}
    active = set(range(jobs))
    while active:
        share = rng.choice(sorted(active))
        index = take_window(bounds, share)
        if index is None:
            active.discard(share)
        else:
            taken[share].append(index)
    return taken


@pytest.mark.parametrize(("tasks", "jobs", "seed"), [(352, 2, 0), (352, 2, 1), (40, 3, 2), (7, 2, 3), (500, 8, 4)])
def test_workers_take_every_window_once_in_runs_of_consecutive_windows(tasks, jobs, seed):
    taken = _walk(tasks, jobs, seed)
    assert sorted(i for mine in taken.values() for i in mine) == list(range(tasks))
    # a worker's cold starts: its first window and each stolen one; far fewer than the windows
    cold = sum(1 + sum(b != a + 1 for a, b in zip(mine, mine[1:], strict=False)) for mine in taken.values() if mine)
    assert cold <= jobs * (2 + tasks.bit_length())


def test_a_share_with_fewer_than_min_steal_windows_left_stays_with_its_owner():
    bounds = [5, 5, 2, 2 + MIN_STEAL - 1]
    assert take_window(bounds, 0) is None and bounds == [5, 5, 2, 2 + MIN_STEAL - 1]
    bounds = [5, 5, 2, 2 + MIN_STEAL]
    assert take_window(bounds, 0) == 2 + MIN_STEAL // 2 and bounds[3] == 2 + MIN_STEAL // 2  # the back half taken


_SHARES: WindowShares | None = None


def _init(shares: WindowShares) -> None:
    global _SHARES
    _SHARES = shares


def _square_all(share: int) -> None:
    assert _SHARES is not None
    while (task := _SHARES.take(share)) is not None:
        if task == "bad":
            raise ValueError("window 'bad' failed")
        _SHARES.put((task, task * task))


def test_results_come_back_from_pool_workers_once_each():
    tasks = list(range(60))
    shares = WindowShares(tasks, 2, worker_context())
    with worker_pool(2, _init, (shares,)) as pool:
        got = list(shares.results([pool.submit(_square_all, k) for k in range(2)], poll_s=0.05))
    assert sorted(got) == [(i, i * i) for i in tasks]


def test_a_failing_window_raises_in_the_parent():
    shares = WindowShares([1, 2, "bad", 3], 2, worker_context())
    with pytest.raises(ValueError, match="window 'bad' failed"), worker_pool(2, _init, (shares,)) as pool:
        list(shares.results([pool.submit(_square_all, k) for k in range(2)], poll_s=0.05))


def _die_on_bad(share: int) -> None:
    assert _SHARES is not None
    while (task := _SHARES.take(share)) is not None:
        if task == "die":
            os.kill(os.getpid(), signal.SIGKILL)  # the OOM killer's way: no exception, no result
        _SHARES.put((task, task))


def test_a_worker_killed_mid_run_is_one_line_not_a_wait_forever():
    tasks = [1, 2, "die", *range(3, 40)]
    shares = WindowShares(tasks, 2, worker_context())
    with pytest.raises(ServiceError, match=r"window worker process ended .*: \d+ of 40 windows diagnosed") as caught:
        with worker_pool(2, _init, (shares,)) as pool:
            list(shares.results([pool.submit(_die_on_bad, k) for k in range(2)], poll_s=0.05))
    assert caught.value.code == 1
