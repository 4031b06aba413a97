"""A node set without final verdicts ends in one line: what is stuck, within its bounds, or why it failed.

A final diagnosis that fails ends the run at once, its line naming the exception.

Each case runs in a child process (test/stalled_run.py) so that a runner that does spin forever fails
this test after TIMEOUT_S instead of hanging the suite.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from stalled_run import FAILURE, SAMPLES, STALL_TIMEOUT_S, VERDICT_TIMEOUT_S

pytestmark = pytest.mark.ros

HERE = Path(__file__).resolve().parent

TIMEOUT_S = 180.0
"""Far above what a bounded run takes here (its start, 300 lockstep samples, then at most the verdict
timeout): only a runner that spins forever reaches it."""


def _run(case: str, domain: int, children: list) -> tuple[int, str, float]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HERE.parent), os.environ.get("PYTHONPATH", "")])}
    started = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "stalled_run.py"), case, str(domain)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    children.append(proc)
    try:
        out, _ = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        pytest.fail(f"the node set still spun after {TIMEOUT_S:g} s (its watch never fired):\n{out[-3000:]}")
    return proc.returncode, out, time.monotonic() - started


def _outcome(out: str) -> str:
    return next((line for line in reversed(out.splitlines()) if line.startswith(("NodeSetError", "finished"))), "")


def test_a_diagnosis_that_never_ends_fails_the_run_after_the_verdict_timeout(ros_domain, children):
    code, out, _ = _run("busy", ros_domain, children)
    line = _outcome(out)
    assert code == 1, out[-3000:]
    assert f"stalled ({VERDICT_TIMEOUT_S:.0f} s without progress, its diagnostician's worker still busy)" in line
    assert "no final verdicts (for sample 299) on /diagnostics; the diagnostician took every sample" in line


def test_a_producer_publishing_after_the_run_is_no_progress(ros_domain, children):
    # no verdict comes (the diagnosis fails) while a stray producer keeps y coming: the stall timeout applies
    code, out, _ = _run("publishing", ros_domain, children)
    line = _outcome(out)
    assert code == 1, out[-3000:]
    assert "no final verdicts (for sample 299)" in line, line
    silent = float(line.split("stalled (")[1].split(" s")[0])
    assert STALL_TIMEOUT_S <= silent <= VERDICT_TIMEOUT_S + 1


def test_a_final_diagnosis_that_fails_ends_the_run_at_once_naming_the_failure(ros_domain, children):
    # the last window's statuses say the diagnosis failed: no verdict will come, so no waiting for the stall timeout
    code, out, took = _run("failing", ros_domain, children)
    line = _outcome(out)
    assert code == 1, out[-3000:]
    window = f"samples 0..{SAMPLES - 1}"
    assert line == f"NodeSetError: the diagnosis of the final window ({window}) failed: {FAILURE}", line
    print(f"the failing run ended after {took:.1f} s (its process's start included)")
