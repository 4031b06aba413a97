"""Local worker pools: set up once per worker, ended on an error or a Ctrl-C, a killed worker reported at once."""

from __future__ import annotations

import pytest


def _script_env(folder, files: dict[str, str]) -> dict[str, str]:
    """Write ``files`` (name -> text) into ``folder``; the environment in which a script there imports them."""
    import os
    from pathlib import Path

    for name, text in files.items():
        (folder / name).write_text(text)
    return {**os.environ, "PYTHONPATH": f"{folder}:{Path(__file__).resolve().parent.parent}"}


def test_worker_pools_start_from_a_fork_server():
    from pmr_ros.core.sim.workers import worker_context

    assert worker_context().get_start_method() == "forkserver"


def test_a_worker_pool_sets_up_its_workers_and_is_torn_down_on_an_error():
    import math

    from pmr_ros.core.sim.workers import completed, worker_pool

    with worker_pool(2, math.isfinite, (1.0,)) as pool:  # any picklable initializer
        assert sorted(completed(pool, math.sqrt, [4.0, 9.0])) == [2.0, 3.0]
    with pytest.raises(ValueError, match="math domain error"), worker_pool(2, math.isfinite, (1.0,)) as pool:
        list(completed(pool, math.sqrt, [-1.0]))  # the worker's error reaches the caller; the pool is shut down
    with pytest.raises(RuntimeError, match="after shutdown"):
        pool.submit(math.sqrt, 4.0)


def _sigint_ignored(_: object) -> bool:
    import signal

    return signal.getsignal(signal.SIGINT) == signal.SIG_IGN


def test_pool_workers_leave_ctrl_c_to_the_main_process_with_and_without_an_initializer():
    import math

    from pmr_ros.core.sim.workers import completed, worker_pool

    with worker_pool(2) as pool:
        assert list(completed(pool, _sigint_ignored, range(4))) == [True] * 4
    with worker_pool(2, math.isfinite, (1.0,)) as pool:
        assert list(completed(pool, _sigint_ignored, range(4))) == [True] * 4
    assert not _sigint_ignored(None)  # the test can fail: this process does not ignore it


def _sleep_or_fail(seconds: float) -> float:
    import time

    if seconds < 0:
        raise ValueError("a task failed")
    time.sleep(seconds)
    return seconds


def test_an_error_in_the_block_terminates_the_workers_mid_task_rather_than_waiting_for_them():
    import time

    from pmr_ros.core.sim.workers import completed, worker_pool

    start = time.perf_counter()
    with pytest.raises(ValueError, match="a task failed"), worker_pool(2) as pool:
        processes = list(pool._processes.values())  # noqa: SLF001  # to see them end
        list(completed(pool, _sleep_or_fail, [60.0, 0.5, -1.0, 60.0]))  # the 60 s tasks are running
    for process in processes:
        process.join(10)
    assert time.perf_counter() - start < 20 and all(p.exitcode is not None for p in processes)


def _die_on_negative(value: int) -> int:
    import os
    import signal

    if value < 0:
        os.kill(os.getpid(), signal.SIGKILL)  # the out-of-memory killer's way: no exception, no result
    return value


def test_a_killed_worker_is_worker_ended_after_the_results_that_came_not_a_wait_forever():
    from pmr_ros.core.sim.workers import WorkerEnded, completed, worker_pool

    got = []
    with pytest.raises(WorkerEnded, match=r"ended before its tasks were done .*: 3 of 5 done") as caught:
        with worker_pool(1) as pool:  # one worker: the tasks before the killing one are done first
            got.extend(completed(pool, _die_on_negative, [1, 2, 3, -1, 4]))
    assert got == [1, 2, 3] and (caught.value.done, caught.value.total) == (3, 5)
    assert caught.value.unfinished == (-1, 4)  # in the order given


def test_ctrl_c_of_the_process_group_ends_a_pool_promptly_without_the_workers_tracebacks(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    # a task that says when it has begun (a worker's output is the script's), then takes a minute; one write
    # of a whole line, atomic on a pipe: print's text and newline could interleave with the other worker's
    naps = "import os, time\n\ndef nap(seconds):\n    os.write(1, b'started\\n')\n    time.sleep(seconds)\n"
    script = (
        "import sys\n"
        "import naps\n"
        "from pmr_ros.core.sim.workers import completed, worker_pool\n"
        "if __name__ == '__main__':\n"
        "    try:\n"
        "        with worker_pool(2) as pool:\n"
        "            list(completed(pool, naps.nap, [60, 60, 60]))\n"
        "    except KeyboardInterrupt:\n"
        "        print('interrupted', flush=True)\n"
        "        sys.exit(130)\n"
    )
    env = _script_env(tmp_path, {"naps.py": naps, "main_script.py": script})
    child = subprocess.Popen(
        [sys.executable, str(tmp_path / "main_script.py")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,  # its own process group, as a shell gives a command: Ctrl-C reaches every member
    )
    try:
        assert child.stdout is not None
        assert [child.stdout.readline(), child.stdout.readline()] == ["started\n"] * 2  # both workers in a task
        start = time.perf_counter()
        os.killpg(child.pid, signal.SIGINT)
        out, err = child.communicate(timeout=30)
    finally:
        if child.poll() is None:  # a failed test leaves no process behind
            os.killpg(child.pid, signal.SIGKILL)
            child.communicate()
    assert child.returncode == 130 and out == "interrupted\n" and "Traceback" not in err, err
    assert time.perf_counter() - start < 10


def test_a_worker_pool_has_its_initializer_module_imported_by_the_fork_server_started_early_or_not(tmp_path):
    import subprocess
    import sys

    # a module that remembers which process imported it: a worker forked from a fork server that imported it
    # holds the server's pid there, a worker that imported it itself its own
    probe = "import os\nIMPORTED_BY = os.getpid()\n\ndef setup():\n    pass\n"
    script = (
        "import os\n"
        "import probe_module\n"
        "from pmr_ros.core.sim.workers import start_fork_server, worker_pool\n"
        "def imported_before_fork(_):\n"
        "    import probe_module\n"
        "    return probe_module.IMPORTED_BY != os.getpid()\n"
        "def fork_servers():\n"
        "    import psutil\n"
        "    return sum('forkserver' in ' '.join(p.cmdline()) for p in psutil.Process().children())\n"
        "if __name__ == '__main__':\n"
        "    print(fork_servers())\n"
        "    if os.environ.get('START_EARLY'):\n"
        "        start_fork_server(probe_module.setup)\n"
        "        start_fork_server(probe_module.setup)  # one server, however often asked\n"
        "        print(fork_servers())\n"
        "    with worker_pool(2, probe_module.setup, ()) as pool:\n"
        "        print(list(pool.map(imported_before_fork, range(4))))\n"
    )
    env = _script_env(tmp_path, {"probe_module.py": probe, "main_script.py": script})
    for early, printed in (("", ["0"]), ("1", ["0", "1"])):  # start_fork_server: the server runs before any pool
        done = subprocess.run(
            [sys.executable, str(tmp_path / "main_script.py")],
            capture_output=True,
            text=True,
            env={**env, "START_EARLY": early},
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        assert done.stdout.split("\n")[:-1] == [*printed, "[True, True, True, True]"]


def test_worker_count_is_the_jobs_asked_or_the_cores_at_least_one_and_at_most_one_a_task(monkeypatch):
    import os

    from pmr_ros.core.sim.workers import worker_count

    monkeypatch.setattr(os, "cpu_count", lambda: 6)
    assert [worker_count(None), worker_count(0), worker_count(2), worker_count(None, tasks=4)] == [6, 6, 2, 4]
    assert [worker_count(3, tasks=8), worker_count(3, tasks=0), worker_count(1, tasks=5)] == [3, 1, 1]
    monkeypatch.setattr(os, "cpu_count", lambda: None)  # unknown: one process
    assert worker_count(None, tasks=9) == 1
