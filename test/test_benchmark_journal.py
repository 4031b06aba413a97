"""The benchmark's journal: finished runs kept on disk at once, ``--resume`` runs only the rest (issue 26)."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from numpy.testing import assert_allclose
from session_share import shared_folder

from pmr_ros.benchmark import plots
from pmr_ros.benchmark.journal import Journal, fingerprint
from pmr_ros.benchmark.scenarios import read_scenarios
from pmr_ros.cli import main

REPO = Path(__file__).resolve().parent.parent
SELECTION = ["--units", "wood_berry", "--samples", "2048", "--runs-per-cell", "1", "--quiet"]
"""Two Wood-Berry runs of 2,048 samples (one without, one with the coloured disturbance)."""
METHODS = ["--methods", "parametric,classic"]
WORDS = ["run", "method", "element", "verdict", "detected"]
NUMBERS = ["evidence", "gain_pct", "gain_lo", "gain_hi", "tau_pct", "delay_samples"]


@contextlib.contextmanager
def _figures_not_drawn():
    """The report's four figures written as a few bytes, not drawn: the tests here are of the journal.

    A benchmark report's four figures take 3-6 s of CPU, and every benchmark here writes a report; the figures are
    drawn and checked by test_benchmark_run and here by test_report_only_scores_every_run_the_journal_holds.
    """

    def not_drawn(*args, **kwargs):
        return b"not drawn (test_benchmark_journal)"

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(plots, "length_figure", not_drawn)
        patch.setattr(plots, "roc_figure", not_drawn)
        yield


@pytest.fixture
def figures_not_drawn():
    """:func:`_figures_not_drawn` around a test: for the tests whose claim is not the report."""
    with _figures_not_drawn():
        yield


def _rows(run: int, method: str, detected: bool) -> list[dict]:
    return [{"run": run, "method": method, "element": e, "detected": detected} for e in ("G11", "G12")]


def test_the_journal_keeps_each_piece_and_reads_the_newest_of_a_pair(tmp_path):
    journal = Journal(tmp_path / "runs")
    assert journal.count() == 0 and journal.done() == set() and journal.read().empty
    journal.write(3, ("classic", "parametric"), _rows(3, "classic", False) + _rows(3, "parametric", True))
    journal.write(5, ("classic",), _rows(5, "classic", True))
    assert journal.count() == 2 and journal.done() == {(3, "classic"), (3, "parametric"), (5, "classic")}
    time.sleep(0.01)  # a later piece of the same pair (a copied-in piece): the newer one counts, not both
    journal.write(3, ("classic",), _rows(3, "classic", True))
    rows = journal.read()
    assert len(rows) == 6 and rows[(rows["run"] == 3) & (rows["method"] == "classic")]["detected"].all()
    assert not list(journal.folder.glob("*.tmp"))  # each piece whole or absent


def test_a_journal_refuses_another_scenario_file_and_starts_anew_when_told(tmp_path):
    scenarios = read_scenarios()
    key, other = fingerprint(scenarios), fingerprint(scenarios.iloc[:-1])
    assert key == fingerprint(read_scenarios()) and key != other
    journal = Journal(tmp_path / "runs")
    journal.check(key)  # a journal not begun is begun
    journal.write(1, ("classic",), _rows(1, "classic", False))
    journal.check(key)
    with pytest.raises(ValueError, match="another scenario file"):
        journal.check(other)
    journal.start(other)
    assert journal.count() == 0
    journal.check(other)


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The selection run once without a stop: the reference (run once per session: test/session_share.py)."""

    def benchmark(out):
        out.mkdir()
        with _figures_not_drawn():
            assert main(["benchmark", *SELECTION, *METHODS, "--out", str(out)]) == 0

    return pd.read_parquet(
        shared_folder(tmp_path_factory, "test_benchmark_journal_whole", benchmark) / "results.parquet"
    )


@pytest.fixture(scope="module")
def classic(tmp_path_factory):
    """The selection run with the classic PMR alone, once per session (tests copy it before they use it)."""

    def benchmark(out):
        with _figures_not_drawn():
            assert main(["benchmark", *SELECTION, "--methods", "classic", "--out", str(out)]) == 0

    return shared_folder(tmp_path_factory, "test_benchmark_journal_classic", benchmark)


def _same_results(got: pd.DataFrame, want: pd.DataFrame) -> None:
    got, want = got.reset_index(drop=True), want.reset_index(drop=True)
    pd.testing.assert_frame_equal(got[WORDS], want[WORDS])
    assert_allclose(got[NUMBERS].to_numpy(float), want[NUMBERS].to_numpy(float), rtol=1e-9, atol=1e-12)


def test_a_killed_benchmark_resumes_to_the_results_of_one_without_a_stop(whole, tmp_path, capsys, figures_not_drawn):
    out = tmp_path / "killed"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    argv = [sys.executable, "-m", "pmr_ros.cli", "benchmark", *SELECTION, *METHODS, "--out", str(out)]
    child = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while Journal(out / "runs").count() < 1 and child.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        child.send_signal(signal.SIGKILL)
    finally:
        child.wait(timeout=60)
    kept = Journal(out / "runs").count()
    assert kept == 1 and not (out / "results.parquet").exists()
    assert main(["benchmark", *SELECTION, *METHODS, "--out", str(out), "--resume"]) == 0
    said = capsys.readouterr().out
    assert "1 run in" in said and "and 1 from the journal; 2 scored" in said
    _same_results(pd.read_parquet(out / "results.parquet"), whole)


def test_resume_with_another_method_runs_only_that_method(whole, classic, tmp_path, figures_not_drawn):
    out = shutil.copytree(classic, tmp_path / "more")
    classic_before = Journal(out / "runs").read()
    assert main(["benchmark", *SELECTION, *METHODS, "--out", str(out), "--resume"]) == 0
    journal = Journal(out / "runs")
    assert journal.count() == 4  # two runs of the classic PMR, then two of ours alone
    assert {p.name.split(".")[1] for p in journal.folder.glob("run_*.parquet")} == {"classic", "parametric"}
    results = pd.read_parquet(out / "results.parquet")
    _same_results(results, whole)
    classic_after = results[results["method"] == "classic"].reset_index(drop=True)
    assert_allclose(classic_after["cpu_s"], classic_before.sort_values(["run", "element"])["cpu_s"], rtol=0)


def test_a_journal_with_runs_is_kept_unless_resumed_or_forced(classic, tmp_path, capsys, figures_not_drawn):
    out = shutil.copytree(classic, tmp_path / "kept")
    assert main(["benchmark", *SELECTION, "--methods", "classic", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds 2 finished run(s); use --resume" in err[0] and str(out) in err[0]
    assert main(["benchmark", *SELECTION, "--methods", "classic", "--out", str(out), "--resume", "--force"]) == 2
    assert "contradict" in capsys.readouterr().err
    assert main(["benchmark", *SELECTION, "--methods", "classic", "--out", str(out), "--force"]) == 0
    assert Journal(out / "runs").count() == 2


def test_resume_refuses_the_journal_of_another_scenario_file(classic, tmp_path, capsys):
    out = shutil.copytree(classic, tmp_path / "other")  # the shared folder is read, never resumed
    shorter = tmp_path / "scenarios.csv"
    lines = (REPO / "config" / "benchmark_scenarios.csv").read_text().splitlines()
    shorter.write_text("\n".join(lines[:-1]) + "\n")
    argv = ["benchmark", *SELECTION, "--methods", "classic", "--out", str(out), "--resume", "--scenarios", str(shorter)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--resume:" in err[0] and "another scenario file" in err[0]


def test_report_only_scores_every_run_the_journal_holds(classic, tmp_path, capsys):
    out = shutil.copytree(classic, tmp_path / "two")
    longer = ["--units", "wood_berry", "--samples", "4096", "--runs-per-cell", "1", "--quiet", "--methods", "classic"]
    assert main(["benchmark", *longer, "--out", str(out), "--resume"]) == 0
    assert pd.read_parquet(out / "results.parquet")["samples"].unique().tolist() == [4096]  # this selection
    capsys.readouterr()
    assert main(["benchmark", "--report-only", "--out", str(out), "--quiet"]) == 0
    assert "4 runs scored again" in capsys.readouterr().out
    results = pd.read_parquet(out / "results.parquet")
    assert sorted(results["samples"].unique()) == [2048, 4096] and results["run"].nunique() == 4
    _same_results(results[results["samples"] == 2048], pd.read_parquet(classic / "results.parquet"))
    assert "wood_berry" in (out / "benchmark.md").read_text()


def test_the_journal_seeds_one_piece_per_run_and_method(tmp_path):
    rows = pd.DataFrame(_rows(3, "classic", False) + _rows(3, "parametric", True) + _rows(5, "classic", True))
    journal = Journal(tmp_path / "runs")
    assert journal.seed(rows) == 3 and journal.count() == 3
    assert journal.done() == {(3, "classic"), (3, "parametric"), (5, "classic")}
    kept = journal.read().sort_values(["run", "method", "element"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(kept, rows.sort_values(["run", "method", "element"]).reset_index(drop=True))


def test_resume_continues_a_results_file_without_its_journal(whole, classic, tmp_path, capsys, figures_not_drawn):
    """A committed or downloaded results.parquet (no runs/ beside it) is continued: only the rest runs."""
    out = tmp_path / "shipped"
    out.mkdir()
    shutil.copy(classic / "results.parquet", out / "results.parquet")
    capsys.readouterr()
    assert main(["benchmark", *SELECTION, *METHODS, "--out", str(out), "--resume"]) == 0
    assert "2 runs in" in capsys.readouterr().out
    journal = Journal(out / "runs")
    assert {p.name.split(".")[1] for p in journal.folder.glob("run_*.parquet")} == {"classic", "parametric"}
    results = pd.read_parquet(out / "results.parquet")
    _same_results(results, whole)
    shipped = pd.read_parquet(classic / "results.parquet")  # the classic rows kept, not run again
    assert_allclose(results[results["method"] == "classic"]["cpu_s"], shipped["cpu_s"], rtol=0)


def test_resume_refuses_a_results_file_of_other_runs(classic, tmp_path, capsys):
    out = tmp_path / "foreign"
    out.mkdir()
    results = pd.read_parquet(classic / "results.parquet")
    results.loc[results["run"] == results["run"].min(), "samples"] = 4096  # not that run's length in the file
    results.to_parquet(out / "results.parquet", index=False)
    capsys.readouterr()
    assert main(["benchmark", *SELECTION, "--methods", "classic", "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--resume:" in err[0] and "results.parquet" in err[0] and "4096 samples" in err[0]
    assert Journal(out / "runs").count() == 0
