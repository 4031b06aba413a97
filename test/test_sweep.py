"""pmr-ros sweep: plan, tuning, CSV, resume, interruption, report, and the CLI's errors."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import signal
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from session_share import shared_folder

from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.core.pmr.classic import diagnose_classic
from pmr_ros.core.records import Record
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import SCENARIOS
from pmr_ros.progress import ProgressBar, format_duration
from pmr_ros.report.sweep_paper import paper_comparison_applies
from pmr_ros.sweep import execute as sweep_execute
from pmr_ros.sweep import store
from pmr_ros.sweep.analysis import breakdowns, earliest, run_correctness, summarize
from pmr_ros.sweep.plan import (
    PlanError,
    SweepPlan,
    SweepPoint,
    element_index,
    nu_grid,
    parse_nu_list,
    row_time_constant_ratio,
)
from pmr_ros.sweep.tuning import STABILITY_LIMIT, loop_spectral_radius, stable_tuning

SAMPLES = 2048
SMALL = ["--nu", "1,3", "--seeds", "1", "--samples", str(SAMPLES), "--methods", "classic,parametric", "--quiet"]


# --- plan -------------------------------------------------------------------------------------


def test_default_nu_grid_is_the_papers():
    grid = nu_grid(1.0, 10.0, 0.25)
    assert len(grid) == 37 and grid[0] == 1.0 and grid[-1] == 10.0 and grid[5] == 2.25


@pytest.mark.parametrize(
    "args", [(5.0, 2.0, 0.25), (0.0, 2.0, 0.5), (1.0, 2.0, 0.0), (1.0, 2.0, -1.0), (1.0, float("inf"), 1.0)]
)
def test_bad_nu_grid(args):
    with pytest.raises(PlanError):
        nu_grid(*args)


def test_nu_list():
    assert parse_nu_list("3, 1,2.25,1") == (1.0, 2.25, 3.0)
    for text in ("", " , ", "0,1", "1,-2", "1,x"):
        with pytest.raises(PlanError):
            parse_nu_list(text)


def test_element_index_and_row_ratio(wood_berry):
    assert element_index(wood_berry.model, "G21") == (1, 0)
    with pytest.raises(PlanError, match="unknown element"):
        element_index(wood_berry.model, "G33")
    model = wood_berry.model.with_time_constant(0, 0, 16.7 * 2.25)
    assert row_time_constant_ratio(model, 0, 0) == pytest.approx(16.7 * 2.25 / 21.0)
    assert row_time_constant_ratio(wood_berry.model, 1, 0) == pytest.approx(10.9 / 14.4)


def test_plan_points_and_runs(wood_berry):
    plan = SweepPlan(elements=("G11", "G21"), nu=(1.0, 2.0), seeds=(1, 2), samples=100)
    points = plan.points(wood_berry.model)
    assert [(p.element, p.nu) for p in points] == [("G11", 1.0), ("G11", 2.0), ("G21", 1.0), ("G21", 2.0)]
    assert points[1].time_constant == pytest.approx(33.4)
    assert points[0].model(wood_berry.model) is wood_berry.model
    assert len(plan.runs()) == 10 and plan.total_runs == 40


# --- tuning -----------------------------------------------------------------------------------


def test_baseline_tuning_is_kept_and_slow_points_get_a_longer_horizon(wood_berry):
    plants = [wood_berry.plant(s) for s in SCENARIOS]
    base = stable_tuning(wood_berry.model, plants, wood_berry.mpc)
    assert base.tuning == wood_berry.mpc and base.stable
    model = wood_berry.model.with_time_constant(0, 0, 16.7 * 5)
    assert loop_spectral_radius(model, model, wood_berry.mpc) > 1.0  # the configured horizon is unstable there
    slow = stable_tuning(model, [model], wood_berry.mpc)
    assert slow.stable and slow.spectral_radius < STABILITY_LIMIT
    assert slow.tuning.prediction_horizon > wood_berry.mpc.prediction_horizon
    assert slow.tuning.control_horizon == wood_berry.mpc.control_horizon


# --- the command, end to end --------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory):
    """The small sweep's folder, swept once per session (its tests only read it; test/session_share.py)."""

    def sweep(out):
        assert main(["sweep", "--out", str(out), "--jobs", "2", *SMALL]) == 0

    return shared_folder(tmp_path_factory, "small_sweep", sweep)


def test_small_sweep_csv_shape(small_sweep):
    with (small_sweep / store.RESULTS_FILE).open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0].keys()) == store.COLUMNS
    # 2 methods x 2 sweeps x 2 nu x 5 scenarios x 1 seed x 4 elements
    assert len(rows) == 2 * 2 * 2 * 5 * 1 * 4
    assert {r["sweep"] for r in rows} == {"tau_G11", "tau_G21"}
    assert {r["method"] for r in rows} == {"classic", "parametric"}
    assert {(r["method"], r["sweep"], r["nu"], r["scenario"], r["seed"], r["element"]) for r in rows}.__len__() == len(
        rows
    )
    parametric = [r for r in rows if r["method"] == "parametric"]
    assert all(
        r["tau_mismatch_pct"] and float(r["gain_mismatch_pct_low"]) <= float(r["gain_mismatch_pct_high"])
        for r in parametric
    )
    assert {r["verdict"] for r in rows} <= {"ok", "mismatch", "inconclusive"}
    assert all(r["status"] == "ok" for r in rows)
    g11 = [r for r in rows if r["sweep"] == "tau_G11" and r["nu"] == "3.0"]
    assert float(g11[0]["time_constant_swept"]) == pytest.approx(50.1)


def test_small_sweep_report(small_sweep):
    report = (small_sweep / "reproduction.md").read_text()
    assert "Breakdown points" in report and "eq. 16" in report
    # The shipped Wood-Berry column: the paper's figures stand beside ours, and the configured loop is quoted.
    assert "the paper reports ν ≈ 2.25" in report and "ν ≈ 2.5" in report and "Np = 40, Nc = 8" in report
    assert "τ11/τ12 = 16.7ν/21 for the G11 sweep, τ21/τ22 = 10.9ν/14.4 for the G21 sweep" in report
    figures = sorted(p.name for p in (small_sweep / "figures").glob("*.png"))
    assert figures == sorted(
        f"sweep_{e}_{q}{m}.png" for e in ("G11", "G21") for q in ("gain", "tau", "delay") for m in ("", "_parametric")
    )
    assert "Classic and parametric side by side" in report
    assert all((small_sweep / "figures" / f).stat().st_size < 300_000 for f in figures)
    assert json.loads((small_sweep / store.MANIFEST_FILE).read_text())["samples"] == SAMPLES


def test_baseline_point_equals_a_plain_run(small_sweep, wood_berry):
    rows = [r for r in store.read_rows(small_sweep / store.RESULTS_FILE) if r["nu"] == 1.0 and r["method"] == "classic"]
    for scenario in SCENARIOS:
        record = simulate(wood_berry, samples=SAMPLES, seed=1, scenario=scenario)
        diagnosis = diagnose_classic(
            [Record(record.r, record.u, record.y)], model=wood_berry.model, settings=wood_berry.pmr
        )
        for sweep in ("tau_G11", "tau_G21"):
            for row in (r for r in rows if r["scenario"] == scenario and r["sweep"] == sweep):
                e = diagnosis.elements[row["element"]].classic
                assert row["prediction_horizon"] == wood_berry.mpc.prediction_horizon
                # exactly equal: same loop, same arithmetic, repr-exact CSV
                assert (row["gain_ratio"], row["tau_index"], row["delay_mismatch_samples"]) == (
                    e.gain_ratio,
                    e.tau_index,
                    e.delay_mismatch_samples,
                )
                assert (row["gain_mismatch"], row["tau_mismatch"], row["delay_mismatch"]) == (
                    e.gain_mismatch,
                    e.tau_mismatch,
                    e.delay_mismatch,
                )


def test_baseline_point_equals_pmr_ros_run(small_sweep, tmp_path):
    """The same through ``pmr-ros run --batch``, with each method."""
    report = tmp_path / "run.json"
    argv = ["run", "--batch", "--scenario", "full", "--seed", "1", "--samples", str(SAMPLES), "--json", str(report)]
    main([*argv, "--method", "classic"])
    elements = json.loads(report.read_text())["elements"]
    rows = [
        r
        for r in store.read_rows(small_sweep / store.RESULTS_FILE)
        if r["nu"] == 1.0 and r["scenario"] == "full" and r["sweep"] == "tau_G11"
    ]
    classic = [r for r in rows if r["method"] == "classic"]
    assert len(classic) == 4
    for row in classic:
        e = elements[row["element"]]["classic"]
        assert row["gain_ratio"] == pytest.approx(e["gain_ratio"], rel=1e-12)
        assert row["tau_index"] == pytest.approx(e["tau_index"], rel=1e-12)
        assert row["delay_mismatch_samples"] == e["delay_mismatch_samples"]
    # and the parametric rows equal `pmr-ros run --batch --method parametric`
    main([*argv, "--method", "parametric"])
    elements = json.loads(report.read_text())["elements"]
    for row in (r for r in rows if r["method"] == "parametric"):
        e = elements[row["element"]]["parametric"]
        assert row["gain_mismatch_pct"] == pytest.approx(e["gain_mismatch_pct"], rel=1e-12)
        assert row["gain_ratio"] is None  # the classic M(0) is not a parametric column
        assert row["tau_mismatch_pct"] == pytest.approx(e["tau_mismatch_pct"], rel=1e-12)
        for bound in ("tau_mismatch_pct_low", "tau_mismatch_pct_high", "gain_mismatch_pct_low"):
            assert row[bound] == pytest.approx(e[bound], rel=1e-12)
        assert (row["gain_verdict"], row["tau_verdict"], row["delay_verdict"]) == (
            e["gain_verdict"],
            e["tau_verdict"],
            e["delay_verdict"],
        )
        assert row["delay_mismatch_samples"] == e["delay_mismatch_samples"] and row["verdict"] == e["verdict"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--nu-start", "5", "--nu-stop", "2"], "empty"),
        (["--nu", "0,1"], "positive"),
        (["--nu", ","], "empty"),
        (["--nu-step", "0"], "positive"),
        (["--nu-start", "-1"], "positive"),
        (["--nu", "1", "--elements", "G33"], "unknown element"),
        (["--nu", "1", "--elements", "G11,G11"], "twice"),
        (["--nu", "1", "--methods", "classic,bogus"], "--methods"),
    ],
)
def test_bad_input_is_one_clear_line(tmp_path, capsys, argv, message):
    code = main(["sweep", "--out", str(tmp_path / "o"), "--quiet", *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_existing_out_dir_needs_force_or_resume(small_sweep, capsys):
    code = main(["sweep", "--out", str(small_sweep), *SMALL])
    err = capsys.readouterr().err
    assert code == 2 and "--force" in err and "Traceback" not in err
    assert main(["sweep", "--out", str(small_sweep), "--force", "--resume", *SMALL]) == 2


def test_resume_after_interruption(small_sweep, tmp_path):
    full = (small_sweep / store.RESULTS_FILE).read_text().splitlines()
    out = tmp_path / "resumed"
    out.mkdir()
    # An interrupted sweep: the manifest, the first 3 runs' rows (2 methods x 4 elements each) and a torn line.
    (out / store.MANIFEST_FILE).write_text((small_sweep / store.MANIFEST_FILE).read_text())
    kept = full[: 1 + 3 * 2 * 4]
    (out / store.RESULTS_FILE).write_text("\n".join(kept) + "\n" + full[1 + 3 * 2 * 4][:40])
    calls = []
    original = sweep_execute.run_point

    def counting(config, task):
        calls.append(len(task.runs))
        return original(config, task)

    sweep_execute.run_point = counting
    try:
        assert main(["sweep", "--out", str(out), "--resume", "--jobs", "1", "--no-report", *SMALL]) == 0
    finally:
        sweep_execute.run_point = original
    assert sum(calls) == 20 - 3  # only the missing runs were simulated
    lines = (out / store.RESULTS_FILE).read_text().splitlines()
    assert lines[: len(kept)] == kept
    assert sorted(lines) == sorted(full)


RESUME = [
    "--elements",
    "G11",
    "--nu",
    "1,3.25",
    "--seeds",
    "2",
    "--samples",
    str(SAMPLES),
    "--methods",
    "classic,parametric",
    "--jobs",
    "1",
    "--quiet",
    "--no-report",
]
"""A sweep whose point G11 x 3.25 needs Np = 50 for the delay and full plants but only 40 for the others."""


def _keyed(rows: list[dict]) -> dict[tuple, dict]:
    """Rows by their identity (method, sweep, nu, scenario, seed, element)."""
    return {(r["method"], r["sweep"], round(r["nu"], 9), r["scenario"], r["seed"], r["element"]): r for r in rows}


def test_resumed_sweep_equals_the_uninterrupted_one(tmp_path, wood_berry):
    full_out, out = tmp_path / "full", tmp_path / "resumed"
    assert main(["sweep", "--out", str(full_out), *RESUME]) == 0
    full = store.read_rows(full_out / store.RESULTS_FILE)
    # Interrupted after some runs of the point nu = 3.25: its delay and full runs and (none, seed 1) are done.
    done = [
        r
        for r in full
        if r["nu"] != 3.25 or r["scenario"] in ("delay", "full") or (r["scenario"], r["seed"]) == ("none", 1)
    ]
    remaining = sorted(
        {r["scenario"] for r in full} - {r["scenario"] for r in done if r["nu"] == 3.25 and r["seed"] == 2}
    )
    # The test can fail: the remaining runs' scenarios alone would get a shorter horizon than the plan's five.
    model = wood_berry.model.with_time_constant(0, 0, 16.7 * 3.25)
    plants = replace(wood_berry, model=model).plant
    assert stable_tuning(model, [plants(s) for s in remaining], wood_berry.mpc).tuning.prediction_horizon == 40
    assert stable_tuning(model, [plants(s) for s in SCENARIOS], wood_berry.mpc).tuning.prediction_horizon == 50
    out.mkdir()
    (out / store.MANIFEST_FILE).write_text((full_out / store.MANIFEST_FILE).read_text())
    store.append_rows(out / store.RESULTS_FILE, done)
    assert main(["sweep", "--out", str(out), "--resume", *RESUME]) == 0
    resumed = _keyed(store.read_rows(out / store.RESULTS_FILE))
    expected = _keyed(full)
    assert len(resumed) == len(expected) == len(full) and resumed.keys() == expected.keys()
    # Exactly equal, not approximately: both sweeps ran in this process on this machine (same
    # arithmetic), and the CSV stores floats repr-exact; any difference is a different tuning or loop.
    for key, row in expected.items():
        assert resumed[key] == row, key


def test_resume_refuses_other_samples(small_sweep, capsys):
    assert (
        main(
            [
                "sweep",
                "--out",
                str(small_sweep),
                "--resume",
                "--nu",
                "1",
                "--seeds",
                "1",
                "--samples",
                "4096",
                "--quiet",
                "--no-report",
            ]
        )
        == 2
    )
    assert "different samples" in capsys.readouterr().err


def test_interrupt_keeps_finished_points(tmp_path, wood_berry, monkeypatch):
    plan = SweepPlan(elements=("G11",), nu=(1.0, 2.0, 3.0), seeds=(1,), samples=SAMPLES, scenarios=("none",))
    tasks = sweep_execute.plan_tasks(wood_berry, plan, set())
    original = sweep_execute.run_point
    done = []

    def interrupted(config, task):
        if done:
            raise KeyboardInterrupt
        done.append(task)
        return original(config, task)

    monkeypatch.setattr(sweep_execute, "run_point", interrupted)
    results = tmp_path / store.RESULTS_FILE
    with pytest.raises(KeyboardInterrupt):
        sweep_execute.execute(wood_berry, tasks, results, jobs=1, progress=False)
    rows = store.read_rows(results)
    assert len(rows) == 4 and {r["nu"] for r in rows} == {done[0].point.nu}
    left = sweep_execute.plan_tasks(wood_berry, plan, {store.run_key(r) for r in rows})
    assert sorted(t.point.nu for t in left) == [1.0, 2.0]


@pytest.fixture
def figures_named(monkeypatch):
    """The names of the figures a report asks for, not drawn: for the tests of a report's text.

    Drawing is a second a figure; test_small_sweep_report and the non-square sweep draw them (the same write_report).
    """
    from pmr_ros.report import sweep_document

    named = []

    def name_only(summary, *, path, **kwargs):
        named.append(path.name)
        return path

    monkeypatch.setattr(sweep_document, "plot_sweep", name_only)
    return named


def test_report_only_refuses_another_configuration(small_sweep, tmp_path, capsys, figures_named):
    report = tmp_path / "report.md"
    argv = ["sweep", "--out", str(small_sweep), "--report-only", "--report", str(report)]
    assert main([*argv, "--config", "config/three_by_three.yaml"]) == 2
    err = capsys.readouterr().err
    assert "another configuration" in err and "--config" in err and "Traceback" not in err and not report.exists()
    assert figures_named == []
    assert main(argv) == 0 and "Np = 40" in report.read_text()
    assert sorted(figures_named) == sorted(
        f"sweep_{e}_{q}{m}.png" for e in ("G11", "G21") for q in ("gain", "tau", "delay") for m in ("", "_parametric")
    )


def test_report_only_needs_results(tmp_path, capsys):
    assert main(["sweep", "--out", str(tmp_path), "--report-only"]) == 2
    assert "does not exist" in capsys.readouterr().err


# A 3x3 system with its own loop: none of the report's settings may be Wood-Berry's.
OTHER_LOOP = """
    mpc:
      prediction_horizon: 50
      control_horizon: 6
    noise:
      std: 0.15
"""


def test_report_of_another_system_quotes_its_own_configuration(tmp_path, figures_named):
    config_file = tmp_path / "three_by_three_np50.yaml"
    config_file.write_text((Path("config") / "three_by_three.yaml").read_text() + OTHER_LOOP)
    config = load_config(config_file)
    assert (config.mpc.prediction_horizon, config.mpc.control_horizon, float(config.noise_std[0])) == (50, 6, 0.15)
    out = tmp_path / "out"
    argv = [
        "sweep",
        "--config",
        str(config_file),
        "--out",
        str(out),
        "--elements",
        "G11,G23",
        "--nu",
        "1",
        "--seeds",
        "1",
        "--samples",
        str(SAMPLES),
        "--methods",
        "classic",
        "--jobs",
        "1",
        "--quiet",
    ]
    assert main(argv) == 0
    assert sorted(figures_named) == sorted(
        f"sweep_{e}_{q}.png" for e in ("G11", "G23") for q in ("gain", "tau", "delay")
    )
    report = (out / "reproduction.md").read_text()
    expected = [
        "three_by_three",
        "Np = 50",
        "Nc = 6",
        "σ = 0.15",
        "Ts = 1 t.u.",
        "τ of G11 = 10·ν t.u.",
        "τ of G23 = 11·ν t.u.",
        f"τ11/(τ12·τ13)^(1/2) = 10ν/{np.sqrt(12.0 * 14.0):.4g}",
        f"τ23/(τ21·τ22)^(1/2) = 11ν/{np.sqrt(15.0 * 13.0):.4g}",
        "ΔK = [10, 0, -12, 0, 15, 0, -10, 0, 12] %",
        "ΔD = [0, 0, 1, 2, 0, 0, 0, 1, 0] samples",
        "the paper comparison does not apply",
        "| G33 |",
        "2048 samples per run",
    ]
    for text in expected:
        assert text in report, text
    # Wood-Berry's settings and the paper's published figures: none may appear for another system.
    wood_berry = [
        "16.7ν",
        "16.7·ν",
        "10.9ν",
        "10.9·ν",
        "/21 ",
        "14.4 for",
        "Np = 40",
        "Nc = 8",
        "Ts = 1 min",
        "·ν min",
        "eq. (15) on",
        "paper eq. 16",
        "paper eq. 17",
        "paper ΔD",
        "the paper reports",
        "the paper:",
        "paper's breakdown",
        "Wood-Berry matrix",
        "eq. (19)",
        "beside the paper",
        "the five of Table 2",
        "Reproduction:",
        "+20.85",
        "-37.49",
        "ν ≈ 2.25",
        "ν ≈ 2.5",
    ]
    for text in wood_berry:
        assert text not in report, text


def test_paper_comparison_applies_to_the_shipped_wood_berry_column_only(wood_berry):
    assert paper_comparison_applies(wood_berry)
    assert not paper_comparison_applies(load_config("config/three_by_three.yaml"))
    # Still named wood_berry, but another system or mismatch than the paper's: its numbers do not compare.
    assert not paper_comparison_applies(load_config(overrides={"system": {"time_constant": [16.7, 21.0, 10.9, 20.0]}}))
    assert not paper_comparison_applies(load_config(overrides={"mismatch": {"gain_pct": 5.0}}))
    # Settings of the loop do not change the system: the comparison still applies.
    assert paper_comparison_applies(load_config(overrides={"mpc": {"prediction_horizon": 60}, "noise": {"std": 0.2}}))


# --- pieces -------------------------------------------------------------------------------------


def test_store_round_trip(tmp_path):
    row = dict.fromkeys(store.COLUMNS)
    row.update(
        method="classic",
        sweep="tau_G11",
        element_swept="G11",
        nu=2.25,
        scenario="full",
        seed=3,
        element="G12",
        gain_ratio=1.0 / 3.0,
        tau_index=float("nan"),
        gain_mismatch=True,
        tau_mismatch=False,
        status="ok",
        delay_mismatch_samples=-2,
        samples=16384,
        mpc_solves=7,
        mpc_failures=0,
        tracking_rms=0.5,
    )
    path = tmp_path / "r.csv"
    store.append_rows(path, [row])
    store.append_rows(path, [row])
    back = store.read_rows(path)
    assert len(back) == 2 and back[0]["gain_ratio"] == 1.0 / 3.0 and back[0]["tau_index"] is None
    assert back[0]["gain_mismatch"] is True and back[0]["delay_mismatch_samples"] == -2
    assert store.run_key(back[0]) == ("classic", "tau_G11", 2.25, "full", 3)
    assert store.complete_rows(back, 2) == back and store.complete_rows(back[:1], 2) == []
    store.rewrite(path, back[:1])
    assert len(store.read_rows(path)) == 1
    assert (
        store.config_fingerprint({"a": 1}) == store.config_fingerprint({"a": 1}) != store.config_fingerprint({"a": 2})
    )
    store.write_manifest(tmp_path, {"samples": 5})
    assert store.read_manifest(tmp_path) == {"samples": 5}
    (tmp_path / "bad.csv").write_text("x,y\n1,2\n")
    with pytest.raises(ValueError):
        store.read_rows(tmp_path / "bad.csv")


def _row(**kw):
    row = {
        "status": "ok",
        "gain_ratio": 1.1,
        "true_gain_ratio": 1.1,
        "tau_index": 20.0,
        "true_time_constant_pct": 10.0,
        "delay_mismatch_samples": 0,
        "true_delay_samples": 0,
    }
    row.update(kw)
    return row


def test_run_correctness():
    assert run_correctness(_row(), 8.0) == {"gain": True, "tau": True, "delay": True}
    assert run_correctness(_row(gain_ratio=1.14), 8.0)["gain"] is False
    assert run_correctness(_row(tau_index=-20.0), 8.0)["tau"] is False
    assert run_correctness(_row(tau_index=5.0), 8.0)["tau"] is False  # flag not raised
    assert run_correctness(_row(tau_index=5.0, true_time_constant_pct=0.0), 8.0)["tau"] is True
    assert run_correctness(_row(tau_index=9.0, true_time_constant_pct=0.0), 8.0)["tau"] is False
    assert run_correctness(_row(delay_mismatch_samples=1), 8.0)["delay"] is False
    assert run_correctness(_row(status="insufficient_data", gain_ratio=None), 8.0) == {
        "gain": False,
        "tau": False,
        "delay": False,
    }


def _synthetic(nu, seed, gain):
    base = {c: None for c in store.COLUMNS}
    base.update(
        method="classic",
        sweep="tau_G11",
        element_swept="G11",
        nu=nu,
        scenario="gain",
        seed=seed,
        element="G11",
        row_time_constant_ratio=nu * 0.8,
        prediction_horizon=40,
        loop_spectral_radius=0.97,
        mpc_solves=10,
        mpc_failures=0,
        samples=100,
        tracking_rms=1.0,
        true_time_constant_pct=0.0,
        tau_index=0.0,
    )
    base.update(_row(gain_ratio=gain, tau_index=0.0, true_time_constant_pct=0.0))
    return base


def test_summary_and_breakdown():
    rows = []
    for nu, gains in (
        (1.0, (1.1, 1.1, 1.1)),
        (2.0, (1.1, 1.5, 1.1)),
        (3.0, (1.5, 1.5, 1.1)),
        (4.0, (1.1, 1.1, 1.1)),
        (5.0, (1.5, 1.5, 1.5)),
    ):
        rows += [_synthetic(nu, s, g) for s, g in enumerate(gains)]
    summary = summarize(rows, 8.0)
    assert [p.gain_wrong for p in summary] == [0, 1, 2, 0, 3]
    assert summary[2].gain_median == 1.5 and summary[2].gain_low == 1.1
    gain = [b for b in breakdowns(summary) if b.diagnosis == "gain"][0]
    assert gain.nu == 3.0 and gain.ratio == pytest.approx(2.4) and gain.failing_share == pytest.approx(2 / 3)
    assert earliest(breakdowns(summary)).nu == 3.0
    # a diagnosis that is wrong at the first nu is reported as such, not as a breakdown
    bad = summarize([_synthetic(1.0, 0, 1.5), _synthetic(2.0, 0, 1.5)], 8.0)
    b = [x for x in breakdowns(bad) if x.diagnosis == "gain"][0]
    assert b.fails_at_baseline and b.nu is None


def test_progress_bar_shows_eta():
    stream = io.StringIO()
    bar = ProgressBar(10, stream=stream)
    bar.update(5)
    bar.update(5)
    bar.close()
    text = stream.getvalue()
    assert "5/10 runs" in text and "ETA" in text and "10/10" in text
    assert format_duration(75) == "1m15s" and format_duration(3700) == "1h01m" and format_duration(5) == "5s"


def test_point_model_changes_only_the_swept_time_constant(wood_berry):
    point = SweepPoint("G21", 1, 0, 2.5, 10.9)
    model = point.model(wood_berry.model)
    expected = wood_berry.model.time_constant.copy()
    expected[1, 0] = 10.9 * 2.5
    np.testing.assert_allclose(model.time_constant, expected)
    np.testing.assert_array_equal(model.gain, wood_berry.model.gain)


def test_load_config_is_unchanged_by_a_sweep(tmp_path):
    # a sweep in this process (--jobs 1) whose point G11 x 3.25 runs with Np = 50, not the configured 40
    argv = ["sweep", "--out", str(tmp_path / "o"), "--elements", "G11", "--nu", "3.25", "--seeds", "1"]
    assert (
        main([*argv, "--samples", str(SAMPLES), "--methods", "classic", "--jobs", "1", "--quiet", "--no-report"]) == 0
    )
    assert {r["prediction_horizon"] for r in store.read_rows(tmp_path / "o" / store.RESULTS_FILE)} == {50}
    assert load_config().mpc.prediction_horizon == 40


# --- industrial shapes and a Dask cluster --------------------------------------------------------

LEVEL_TEMPERATURE = Path(__file__).parent / "configs" / "level_temperature.yaml"


def _by_key(rows: list[dict]) -> dict[tuple, dict]:
    keyed = {(r["method"], r["sweep"], r["nu"], r["scenario"], r["seed"], r["element"]): r for r in rows}
    assert len(keyed) == len(rows)
    return keyed


def test_plan_refuses_elements_without_a_time_constant():
    model = load_config(LEVEL_TEMPERATURE).model
    assert element_index(model, "G23") == (1, 2)
    with pytest.raises(PlanError, match="G11 is integrating: it has no time constant to sweep.*G21, G23"):
        element_index(model, "G11")
    with pytest.raises(PlanError, match="G13 is an empty cell"):
        element_index(model, "G13")
    # the row's ratio counts the FOPTD neighbours only
    assert row_time_constant_ratio(model, 1, 0) == pytest.approx(10.0 / 8.0)
    assert row_time_constant_ratio(model.with_time_constant(1, 2, 8.0), 1, 2) == pytest.approx(8.0 / 10.0)


def test_a_sweep_of_a_non_square_system_with_an_integrating_row_reports_every_element(tmp_path):
    out = tmp_path / "sweep"
    argv = ["sweep", "--config", str(LEVEL_TEMPERATURE), "--out", str(out), "--elements", "G21", "--nu", "1,2"]
    assert main([*argv, "--seeds", "1", "--samples", "2048", "--methods", "classic,parametric", "--quiet"]) == 0
    rows = store.read_rows(out / store.RESULTS_FILE)
    names = ["G11", "G12", "G13", "G21", "G22", "G23"]
    assert len(rows) == 2 * 2 * 5 * len(names)  # methods x nu x scenarios x elements, one seed
    for key in {(r["method"], r["nu"], r["scenario"]) for r in rows}:
        assert sorted(r["element"] for r in rows if (r["method"], r["nu"], r["scenario"]) == key) == names
    assert {r["verdict"] for r in rows} <= {"ok", "mismatch", "inconclusive"}
    assert all(r["mpc_failures"] == 0 and r["loop_spectral_radius"] < STABILITY_LIMIT for r in rows)
    g21 = {r["time_constant_swept"] for r in rows}
    assert g21 == {10.0, 20.0}
    assert (out / "reproduction.md").is_file()


def test_a_sweep_refuses_a_plant_block_cleanly(tmp_path, capsys):
    text = LEVEL_TEMPERATURE.read_text().split("    mismatch:")[0]
    plant = (
        "    plant:\n"
        "      element_type: [integrating, integrating, foptd, foptd, none, foptd]\n"
        "      gain: [-0.05, 0.03, 0.4, 0.8, 0.0, 1.5]\n"
        "      time_constant: [0.0, 0.0, 5.0, 10.0, 0.0, 8.0]\n"
        "      delay: [1.0, 2.0, 3.0, 2.0, 0.0, 1.0]\n"
    )
    config = tmp_path / "with_plant.yaml"
    config.write_text(text + plant)
    assert main(["sweep", "--config", str(config), "--out", str(tmp_path / "o"), "--elements", "G21", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(config) in err[0] and "plant block" in err[0] and "Traceback" not in err[0]


@pytest.fixture(scope="module")
def dask_cluster():
    import logging

    from distributed import LocalCluster

    cluster = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    try:
        yield cluster
    finally:
        cluster.close()


def test_sweep_on_a_dask_cluster_writes_the_local_pools_rows(small_sweep, dask_cluster, tmp_path):
    out = tmp_path / "dask"
    argv = ["sweep", "--out", str(out), "--scheduler", dask_cluster.scheduler_address, "--no-report", *SMALL]
    assert main(argv) == 0  # the rows are this test's claim; the report is written from rows alike (small_sweep)
    local = _by_key(store.read_rows(small_sweep / store.RESULTS_FILE))
    remote = _by_key(store.read_rows(out / store.RESULTS_FILE))
    assert remote.keys() == local.keys()
    for key, row in remote.items():
        for column in store.COLUMNS:
            mine, theirs = row[column], local[key][column]
            if isinstance(mine, float) and isinstance(theirs, float):
                assert mine == pytest.approx(theirs, rel=1e-9, abs=1e-12, nan_ok=True), (key, column)
            else:
                assert mine == theirs, (key, column)
    assert json.loads((out / store.MANIFEST_FILE).read_text())["scheduler"] == dask_cluster.scheduler_address


def test_an_unreachable_scheduler_is_one_clear_line(tmp_path, capsys, monkeypatch):
    from pmr_ros.sweep import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    argv = ["sweep", "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:9", *SMALL]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler tcp://127.0.0.1:9: cannot connect" in err[0]


def _die_on_the_smallest_nu(task: sweep_execute.PointTask) -> tuple:
    """The pool's work, but the point nu = 1 (the last one dealt: slowest first) ends its worker."""
    if task.point.nu == 1.0:
        os.kill(os.getpid(), signal.SIGKILL)  # the out-of-memory killer's way: no exception, no result
    return sweep_execute._work(task)


def test_a_killed_worker_ends_the_sweep_in_one_line_and_its_finished_points_are_kept(tmp_path, capsys, monkeypatch):
    out = tmp_path / "o"
    argv = ["sweep", "--out", str(out), "--elements", "G11", "--nu", "1,2,3", "--seeds", "1"]
    argv += ["--samples", str(SAMPLES), "--methods", "classic", "--quiet", "--no-report"]
    monkeypatch.setattr(sweep_execute, "_work", _die_on_the_smallest_nu)  # what the pool's workers run
    assert main([*argv, "--jobs", "2"]) == 1
    err = capsys.readouterr().err
    found = re.fullmatch(
        r"pmr-ros: error: a sweep worker process ended before its points were done \(killed\? out of memory\?\): "
        r"(\d) of 3 points done, their rows in (\S+); continue with --resume\n",
        err,
    )
    assert found, err
    rows = store.read_rows(out / store.RESULTS_FILE)
    assert Path(found[2]) == out / store.RESULTS_FILE
    # the points done before the worker ended (nu = 2 at least: the killing point began when a worker came free)
    kept = sorted({r["nu"] for r in rows})
    assert len(kept) == int(found[1]) >= 1 and 1.0 not in kept and len(rows) == len(kept) * len(SCENARIOS) * 4
    monkeypatch.undo()
    assert main([*argv, "--jobs", "1", "--resume"]) == 0  # the rest, from where it stopped
    assert sorted({r["nu"] for r in store.read_rows(out / store.RESULTS_FILE)}) == [1.0, 2.0, 3.0]
