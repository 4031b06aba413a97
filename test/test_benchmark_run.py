"""``pmr-ros benchmark --quick``: every method runs, the scores match the results and the export (issue 26)."""

from __future__ import annotations

import math
import os
import re
import shutil
import signal
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from session_share import shared_folder
from test_benchmark_journal import _figures_not_drawn

from pmr_ros.benchmark.dataset import read_run
from pmr_ros.benchmark.runner import METHODS, RunTask, run_one
from pmr_ros.benchmark.scoring import label_results, score
from pmr_ros.benchmark.units import unit_config
from pmr_ros.cli import main
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.peers import from_diagnosis

TINY = ["--quick", "--samples", "2048", "--quiet"]
"""Two Wood-Berry runs of 2,048 samples, one without and one with the coloured disturbance."""


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """The quick benchmark's folder, run once per session (its tests only read it; test/session_share.py)."""

    def benchmark(out):
        out.mkdir()
        assert main(["benchmark", *TINY, "--out", str(out), "--export", str(out / "export")]) == 0

    return shared_folder(tmp_path_factory, "test_benchmark_run_quick", benchmark)


def test_quick_runs_every_method_on_every_element_and_writes_the_report(quick):
    results = pd.read_parquet(quick / "results.parquet")
    assert set(results["method"]) == set(METHODS)
    assert len(results) == 2 * len(METHODS) * 4 and not results["reasons"].str.startswith("failed").any()
    roc = pd.read_csv(quick / "roc.csv")
    assert {"parametric", "pem_bj", "partial_correlation"} <= set(roc["method"])
    assert roc["false_alarm"].between(0, 1).all() and roc["detection"].between(0, 1).all()
    report = (quick / "benchmark.md").read_text()
    for heading in ("## Headline", "## Where a peer beats ours", "wood_berry, coloured output disturbance"):
        assert heading in report
    assert all((quick / "figures" / f"benchmark_{n}.png").stat().st_size > 1000 for n in ("detection", "roc", "time"))


def test_the_scores_are_the_results_against_the_labels(quick):
    """scores.csv recomputed by hand from results.parquet and the export's labels.csv, pandas alone."""
    results = pd.read_parquet(quick / "results.parquet")
    labels = pd.read_csv(quick / "export" / "labels.csv")
    scores = pd.read_csv(quick / "scores.csv")
    both = results.merge(labels, on=["run", "element"], suffixes=("", "_true"))
    for (method, disturbance), lines in both.groupby(["method", "disturbance"]):
        line = scores[(scores["method"] == method) & (scores["disturbance"] == disturbance)].iloc[0]
        bad = (lines[["gain_pct_true", "tau_pct_true", "delay_samples_true"]] != 0).any(axis=1)
        assert line["detection"] == pytest.approx(lines["detected"][bad].mean(), nan_ok=True)
        assert line["false_alarm"] == pytest.approx(lines["detected"][~bad].mean(), nan_ok=True)
        error = (lines["gain_pct"] - lines["gain_pct_true"]).abs().dropna()
        assert line["gain_error"] == pytest.approx(error.median() if len(error) else math.nan, nan_ok=True)


def test_scoring_ours_from_the_export_gives_the_run_s_numbers(quick):
    export = quick / "export"
    runs = pd.read_csv(export / "runs.csv")
    labels = pd.read_csv(export / "labels.csv")
    model_table = pd.read_parquet(export / "models" / "wood_berry.parquet")
    config = unit_config("wood_berry")
    model = config.model
    assert_allclose(model_table["gain"], model.gain.ravel(), rtol=1e-12)
    assert_allclose(model_table["delay_samples"], model.delay.ravel() / model.sample_time, rtol=1e-12)
    rows = []
    for run in runs["run"]:
        table = pd.read_parquet(export / "runs" / f"run_{run:05d}.parquet")
        frames = read_run(export, run)  # the package's reader returns the same columns
        assert_allclose(frames["y"].to_numpy(), table[[f"y_{n}" for n in model.output_names]].to_numpy(), rtol=0)
        r, u, y = (table[[f"{p}_{n}" for n in names]].to_numpy() for p, names in (
            ("r", model.output_names), ("u", model.input_names), ("y", model.output_names)))  # fmt: skip
        d = diagnose(r, u, y, model=model, pmr=config.pmr, parametric=config.parametric, method="parametric")
        for o in from_diagnosis(d).values():
            rows.append({"run": run, "method": "parametric", "element": o.element, "detected": o.detected,
                         "verdict": o.verdict, "evidence": o.evidence, "gain_pct": o.gain_pct,
                         "gain_lo": o.gain_interval[0], "gain_hi": o.gain_interval[1], "tau_pct": o.tau_pct,
                         "tau_lo": o.tau_interval[0], "tau_hi": o.tau_interval[1],
                         "delay_samples": o.delay_samples, "cpu_s": 0.0})  # fmt: skip
    mine = score(label_results(pd.DataFrame(rows), labels)).drop(columns="cpu_s")
    theirs = pd.read_csv(quick / "scores.csv")
    theirs = theirs[theirs["method"] == "parametric"].drop(columns="cpu_s").reset_index(drop=True)
    assert list(mine.columns) == list(theirs.columns)
    numbers = [c for c in mine.columns if mine[c].dtype.kind == "f"]
    # rates (counts over runs) agree exactly; estimates only to the row fit's convergence (~1e-6 relative): the
    # same run's data in another memory layout (the run's views of the batch arrays, these read from Parquet)
    # round differently at 1e-16, which moves a fitted dK by up to 4e-6 pp (measured) -- docs/limits.md
    assert_allclose(mine[numbers].to_numpy(float), theirs[numbers].to_numpy(float), rtol=1e-5, atol=1e-12)
    assert (mine[["method", "unit", "disturbance", "samples", "runs"]] == theirs[
        ["method", "unit", "disturbance", "samples", "runs"]]).all().all()  # fmt: skip
    assert np.isfinite(mine["gain_error"]).all()


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--units", "nowhere"], "--units: unknown unit 'nowhere'"),
        (["--methods", "parametric,oracle"], "--methods 'parametric,oracle'"),
        (["--samples", "12x"], "--samples '12x'"),
        (["--quick", "--samples", "32768"], "leaves no run"),
    ],
)
def test_a_bad_selection_is_one_line(argv, words, tmp_path, capsys):
    assert main(["benchmark", *argv, "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and "Traceback" not in err[0]


def test_a_scenario_file_without_a_column_is_one_line(tmp_path, capsys):
    broken = tmp_path / "scenarios.csv"
    broken.write_text("run,unit,samples\n1,wood_berry,2048\n")
    assert main(["benchmark", "--scenarios", str(broken), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(broken) in err[0] and "no column 'disturbance'" in err[0]


def test_an_unreachable_scheduler_is_one_clear_line(tmp_path, capsys, monkeypatch):
    from pmr_ros.sweep import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    argv = ["benchmark", *TINY, "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:9"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler tcp://127.0.0.1:9: cannot connect" in err[0]


def test_on_a_dask_cluster_the_results_are_the_local_ones(quick, tmp_path):
    import logging

    from distributed import LocalCluster

    methods = "parametric,classic,partial_correlation"
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
        silence_logs=logging.ERROR,
    ) as cluster:  # fmt: skip
        argv = [
            "benchmark",
            *TINY,
            "--methods",
            methods,
            "--out",
            str(tmp_path),
            "--scheduler",
            cluster.scheduler_address,
        ]
        with _figures_not_drawn():  # the results are this test's claim; test_quick_... checks the report's figures
            assert main(argv) == 0
    remote = pd.read_parquet(tmp_path / "results.parquet").drop(columns="cpu_s")
    local = pd.read_parquet(quick / "results.parquet")
    local = local[local["method"].isin(methods.split(","))].drop(columns="cpu_s").reset_index(drop=True)
    assert (remote[["run", "method", "element", "verdict", "detected"]] == local[
        ["run", "method", "element", "verdict", "detected"]]).all().all()  # fmt: skip
    numbers = ["evidence", "gain_pct", "gain_lo", "gain_hi", "tau_pct", "delay_samples"]
    assert_allclose(remote[numbers].to_numpy(float), local[numbers].to_numpy(float), rtol=1e-9, atol=1e-12)


def test_report_only_scores_the_results_again_to_the_same_numbers(quick, tmp_path):
    copy = shutil.copytree(quick, tmp_path / "quick")  # report-only writes scores.csv: not into the shared folder
    before = pd.read_csv(copy / "scores.csv")
    report = tmp_path / "again.md"
    assert main(["benchmark", "--report-only", "--out", str(copy), "--report", str(report), "--quiet"]) == 0
    after = pd.read_csv(copy / "scores.csv")
    pd.testing.assert_frame_equal(before, after, rtol=1e-12)
    assert "## Headline" in report.read_text() and (tmp_path / "figures" / "benchmark_roc.png").is_file()


KILLED_RUN = 132
"""The last of ``--units wood_berry --samples 2048 --runs-per-cell 2`` (runs 1, 2, 131, 132; dealt by number)."""


def _die_on_the_last_run(task: RunTask) -> tuple:
    """The pool's work, but run :data:`KILLED_RUN` ends its worker."""
    if task.run == KILLED_RUN:
        os.kill(os.getpid(), signal.SIGKILL)  # the out-of-memory killer's way: no exception, no result
    return run_one(task)


def test_a_killed_worker_ends_the_benchmark_in_one_line_and_its_finished_runs_are_kept(tmp_path, capsys, monkeypatch):
    from pmr_ros.benchmark.journal import Journal
    from pmr_ros.service import benchmark_run

    out = tmp_path / "o"
    argv = ["benchmark", "--units", "wood_berry", "--samples", "2048", "--runs-per-cell", "2"]
    argv += ["--methods", "classic", "--out", str(out), "--quiet"]
    monkeypatch.setattr(benchmark_run, "run_one", _die_on_the_last_run)  # what the pool's workers run
    assert main([*argv, "--jobs", "2"]) == 1
    err = capsys.readouterr().err
    found = re.fullmatch(
        r"pmr-ros: error: a benchmark worker process ended before its runs were done \(killed\? out of memory\?\): "
        r"(\d) of 4 runs done, their rows in (\S+); continue with --resume\n",
        err,
    )
    assert found, err
    assert Path(found[2]) == out / "runs"
    # the runs done before the worker ended (two at least: the killing run began when a worker came free)
    kept = {run for run, _method in Journal(out / "runs").done()}
    assert len(kept) == int(found[1]) >= 2 and KILLED_RUN not in kept and kept <= {1, 2, 131}
    monkeypatch.undo()
    with _figures_not_drawn():  # the runs are the claim, not the report
        assert main([*argv, "--jobs", "1", "--resume"]) == 0  # the rest, from where it stopped
    assert set(pd.read_parquet(out / "results.parquet")["run"]) == {1, 2, 131, 132}
