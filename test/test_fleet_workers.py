"""A fleet's local processes: an entry that ends its worker is failed alone, the others keep their results."""

from __future__ import annotations

import os
import signal
from pathlib import Path

from pmr_ros.service.fleet import WORKER_ENDED, FleetEntry, failed_entry, run_local


def _entry(name: str) -> FleetEntry:
    return FleetEntry(name=name, params=Path(f"{name}.yaml"), data=Path(f"{name}.csv"))


def _work(entry: FleetEntry) -> tuple[str, int]:
    if entry.name.startswith("oom"):
        os.kill(os.getpid(), signal.SIGKILL)  # the out-of-memory killer's way: no exception, no result
    return entry.name, len(entry.name)


def test_every_entry_runs_on_local_processes():
    entries = [_entry(f"C{i:02d}") for i in range(6)]
    assert run_local(entries, jobs=2, work=_work) == {e.name: (e.name, 3) for e in entries}


def test_an_entry_that_ends_its_worker_is_failed_and_the_others_still_run():
    entries = [_entry(name) for name in ("C01", "oom02", "C03", "C04", "oom05", "C06")]
    found = run_local(entries, jobs=2, work=_work)
    assert found["oom02"] == failed_entry("oom02", WORKER_ENDED)
    assert found["oom05"] == failed_entry("oom05", WORKER_ENDED)
    assert {name: found[name] for name in ("C01", "C03", "C04", "C06")} == {
        n: (n, 3) for n in ("C01", "C03", "C04", "C06")
    }
    rows, report = found["oom02"]
    assert rows[0]["verdict"] == "failed" and "killed? out of memory?" in rows[0]["reason"] and report is None


def test_a_failed_entry_is_one_row_with_its_reason_on_one_line():
    rows, report = failed_entry("C07", "data C07.csv:\n  no such file")
    assert report is None and len(rows) == 1
    assert rows[0] | {"reason": None} == {
        "controller": "C07",
        "element": None,
        "verdict": "failed",
        "onset": None,
        "ise_ratio": None,
        "size_over_tolerance": None,
        "report": None,
        "reason": None,
    }
    assert rows[0]["reason"] == "data C07.csv: no such file"
