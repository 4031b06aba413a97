"""``pmr-ros diagnose --window``: every window of a long record diagnosed, its trend and the onsets (issue 25).

The records are our own closed loop (:mod:`drifting`), a day per lockstep run, the plant changing on known days.
"""

from __future__ import annotations

import contextlib
import io
import json
from dataclasses import asdict

import numpy as np
import pandas as pd
import pytest
from drifting import DAY, Change, drifting_data, drifting_signals
from session_share import shared_folder
from shipped import system_only_params

from pmr_ros.cli import main
from pmr_ros.commands.rolling import onset_lines
from pmr_ros.config import load_config
from pmr_ros.report.trend_page import write_trend_page
from pmr_ros.service.monitoring import WindowJob, diagnose_window, monitor, window_stretches
from pmr_ros.service.refusal import ServiceError

RAMP = Change(0, 0, "gain", day=8, size=20.0, days=14)  # G11's gain: 0 -> +20 % over two weeks from day 8
STEP = Change(1, 1, "delay", day=26, size=2)  # G22's delay: +2 samples on day 26


@pytest.fixture(scope="module")
def config():
    return load_config(None)


@pytest.fixture(scope="module")
def export(tmp_path_factory, config):
    """Four days of 1-minute closed loop as a historian export, G11's gain stepping +15 % on day 2."""
    signals = drifting_signals(config, days=4, changes=(Change(0, 0, "gain", day=2, size=15.0),))
    folder = tmp_path_factory.mktemp("export")
    stamps = pd.Timestamp("2025-03-01", tz="UTC") + pd.to_timedelta(60.0 * np.arange(4 * DAY), "s")
    frame = pd.DataFrame({"time": stamps.strftime("%Y-%m-%dT%H:%M:%SZ")})
    model = config.model
    for signal, names in (("r", model.output_names), ("u", model.input_names), ("y", model.output_names)):
        for j, name in enumerate(names):
            frame[f"{signal}_{name}"] = signals[signal][:, j]
    frame.to_csv(folder / "plant.csv", index=False)  # each day's settling samples as empty cells
    (folder / "column.yaml").write_text(system_only_params() + "    data:\n      time_unit_s: 60.0\n")
    return folder


def _run(capsys, argv):
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.fixture(scope="module")
def windows_run(export, tmp_path_factory):
    """``diagnose plant.csv --window 2d --step 1d --jobs 1 --json --trend --report``, once per session.

    For the tests that read it: ``(code, out, err, folder)``, the folder holding ``r.json``, ``trend.csv``, ``page/``.
    """

    def run(folder):
        folder.mkdir()
        argv = ["diagnose", str(export / "plant.csv"), "--config", str(export / "column.yaml"), "--window", "2d"]
        argv += ["--step", "1d", "--jobs", "1", "--json", str(folder / "r.json"), "--trend", str(folder / "trend.csv")]
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([*argv, "--report", str(folder / "page")])
        (folder / "run.json").write_text(json.dumps([code, out.getvalue(), err.getvalue()]))

    folder = shared_folder(tmp_path_factory, "test_monitor_service_windows_run", run)
    code, out, err = json.loads((folder / "run.json").read_text())
    return code, out, err, folder


def test_window_stretches_are_slices_of_the_one_record(config):
    data = drifting_data(config, days=2, changes=())
    job = WindowJob(config, data, data.usable)
    stretches = window_stretches(job, 0, 2 * DAY - 1, deviations=False)
    assert [s.y.shape[0] for s in stretches] == [DAY - 60, DAY - 60]  # each day's settling samples are left out
    assert all(np.shares_memory(s.y, data.signals["y"]) for s in stretches)  # views, not copies
    centred = window_stretches(job, DAY, 2 * DAY - 1)
    np.testing.assert_allclose(centred[0].y.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(centred[0].y + stretches[1].y.mean(axis=0), stretches[1].y, atol=1e-12)


def test_the_window_command_writes_windows_trend_and_the_last_window_on_top(windows_run):
    code, out, err, folder = windows_run
    assert code == 0, err
    report = json.loads((folder / "r.json").read_text())
    windows = report["windows"]
    assert [(w["first"], w["last"]) for w in windows] == [(0, 2 * DAY - 1), (DAY, 3 * DAY - 1), (2 * DAY, 4 * DAY - 1)]
    assert windows[0]["start"].startswith("2025-03-01T00:00") and windows[-1]["end"].startswith("2025-03-05T00:00")
    # the top level is the last window (today's readers), in the same element shape
    last = windows[-1]["elements"]["G11"]
    assert report["elements"]["G11"]["verdict"] == last["verdict"] == "mismatch"
    np.testing.assert_allclose(
        report["elements"]["G11"]["parametric"]["gain_mismatch_pct"], last["parametric"]["gain_mismatch_pct"]
    )
    # days 0-1 the model's gain, days 1-2 one day of each (+7.5 % on average), days 2-3 the new one (+15 %)
    gains = [w["elements"]["G11"]["parametric"]["gain_mismatch_pct"] for w in windows]
    np.testing.assert_allclose(gains, [0.0, 7.5, 15.0], atol=2.0)
    assert {w["elements"]["G12"]["verdict"] for w in windows} <= {"ok", "inconclusive"}
    trend = pd.read_csv(folder / "trend.csv")
    assert len(trend) == 3 * 4 and set(trend["element"]) == {"G11", "G12", "G21", "G22"}
    np.testing.assert_allclose(trend.query("element == 'G11'")["gain_mismatch_pct"], gains, rtol=1e-9)
    assert (trend["delay_mismatch_samples_high"] > trend["delay_mismatch_samples"]).all()  # dD has an interval
    assert trend["quality_usable_share"].between(0.9, 1.0).all()
    assert report["elements"]["G11"]["onset"]["gain"]["kind"] in ("insufficient",)  # three windows: too few
    assert "windows: 3 (3 ok)" in out and "G11" in out


def test_windows_run_in_parallel_as_in_one_process(export, windows_run, capsys, tmp_path):
    code, _, err, folder = windows_run  # the same windows with --jobs 1
    assert code == 0, err
    outputs = {"1": json.loads((folder / "r.json").read_text())["windows"]}
    argv = ["diagnose", str(export / "plant.csv"), "--config", str(export / "column.yaml"), "--window", "2d"]
    argv += ["--step", "1d", "--jobs", "2", "--json", str(tmp_path / "2.json"), "--quiet"]
    assert _run(capsys, argv)[0] == 0
    outputs["2"] = json.loads((tmp_path / "2.json").read_text())["windows"]
    for serial, parallel in zip(outputs["1"], outputs["2"], strict=True):
        for name, element in serial["elements"].items():
            other = parallel["elements"][name]
            assert element["verdict"] == other["verdict"]
            for key in ("gain_mismatch_pct", "tau_mismatch_pct", "delay_mismatch_samples"):
                np.testing.assert_allclose(element["parametric"][key], other["parametric"][key], rtol=1e-9)


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--window", "30d"], "--window: 30d is longer than the data (4 d)"),
        (["--window", "2d", "--step", "0"], "--step: '0' must be positive"),
        (["--window", "2d", "--step", "0d"], "--step: '0d' must be positive"),
        (["--window", "3000", "--step", "2d"], "must both be samples or both clock time"),
        (["--step", "1d"], "--step: an option of --window"),
        (["--jobs", "2"], "--jobs: an option of --window"),
        (["--window", "2d", "--trend", "t.xlsx"], "--trend t.xlsx: the trend file must end in .csv or .parquet"),
    ],
)
def test_bad_windows_are_one_line(export, capsys, extra, words):
    code, _, err = _run(
        capsys, ["diagnose", str(export / "plant.csv"), "--config", str(export / "column.yaml")] + extra
    )
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and words in lines[0] and "Traceback" not in err, err


def test_an_unreachable_scheduler_is_one_line(export, capsys):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    argv = ["diagnose", str(export / "plant.csv"), "--config", str(export / "column.yaml"), "--window", "2d"]
    code, _, err = _run(capsys, [*argv, "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"])
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "cannot connect to a Dask scheduler" in lines[0], err


def test_a_window_longer_than_the_data_is_refused_by_the_service(config):
    data = drifting_data(config, days=1, changes=())
    with pytest.raises(ServiceError, match="longer than the data"):
        monitor(data, config, window=2 * DAY, step=DAY, jobs=1)


def test_a_window_is_diagnosed_as_its_stretches_alone(config):
    data = drifting_data(config, days=4, changes=(Change(0, 0, "gain", day=2, size=15.0),))
    job = WindowJob(config, data, data.usable)
    before, after = diagnose_window(job, (0, 2 * DAY - 1)), diagnose_window(job, (2 * DAY, 4 * DAY - 1))
    np.testing.assert_allclose(before.elements["G11"].parametric.gain_mismatch_pct, 0.0, atol=2.0)
    np.testing.assert_allclose(after.elements["G11"].parametric.gain_mismatch_pct, 15.0, atol=2.0)


def test_a_drift_and_a_delay_step_are_found_on_their_days(config, tmp_path):
    """The year's structure, shortened for the suite (benchmarks/bench_monitor.py runs the year)."""
    data = drifting_data(config, days=36, changes=(RAMP, STEP))
    found = monitor(data, config, window="7d", step="1d", jobs=2)
    start = pd.Timestamp(found.windows[0]["start"])

    def day(text):
        return (pd.Timestamp(text) - start) / pd.Timedelta(days=1)

    gain, delay = found.onsets["G11"]["gain"], found.onsets["G22"]["delay"]
    assert gain["kind"] == "drift" and delay["kind"] == "step", (gain, delay)
    np.testing.assert_allclose(day(gain["onset"]), RAMP.day, atol=3)
    np.testing.assert_allclose(day(delay["onset"]), STEP.day, atol=3)
    np.testing.assert_allclose(gain["size"], RAMP.size, atol=3.0)
    # no element is a mismatch in a window that ends before its change; the unchanged ones never are
    changed = {"G11": RAMP.day, "G22": STEP.day}
    for window in found.windows:
        for name, element in window["elements"].items():
            if element["verdict"] == "mismatch":
                assert name in changed and day(window["end"]) > changed[name], (name, window["end"])
    # the terminal says when and how each moved
    lines = onset_lines(found.onsets)
    assert any(line.startswith("  G11 gain: drift from 2025-01-") for line in lines), lines
    assert any(line.startswith("  G22 delay: step from 2025-01-") for line in lines), lines
    # the trend figures render with the onsets marked
    report = {"elements": {name: {"onset": onset} for name, onset in found.onsets.items()}, "system": "wb"}
    report |= {"monitor": {"window": "7d", "step": "1d"}, "settings": {"parametric": asdict(config.parametric)}}
    page = write_trend_page(tmp_path, report, found.table)
    assert "drift" in page.read_text() and (tmp_path / "figures" / "trend_G11.png").stat().st_size > 20000


def test_the_trend_page_renders_in_a_headless_browser(windows_run, tmp_path):
    from test_report_html import _pixels_near, _screenshot

    code, _, err, folder = windows_run
    assert code == 0, err
    folder = folder / "page"
    assert 'href="trend.html"' in (folder / "index.html").read_text()
    text = (folder / "trend.html").read_text()
    assert text.count("data:image/png;base64,") == 5  # the strip and one figure per element
    assert all((folder / "figures" / f"trend_{name}.png").is_file() for name in ("G11", "G12", "G21", "G22"))
    image = _screenshot(folder / "trend.html", tmp_path / "shot.png", tmp_path)
    # the strip's red cells (G11 a mismatch in its last two windows) and the estimates' 95 % bands (light blue)
    red, blue = _pixels_near(image, (0xC6, 0x28, 0x28)), _pixels_near(image, (0xBB, 0xDE, 0xFB))
    assert red > 5000 and blue > 5000, (red, blue)
    broken = tmp_path / "broken.html"
    broken.write_text(text.replace("data:image/png;base64,", "data:image/png;base64,AAAA"))
    image = _screenshot(broken, tmp_path / "broken.png", tmp_path)
    assert _pixels_near(image, (0xC6, 0x28, 0x28)) < 500 and _pixels_near(image, (0xBB, 0xDE, 0xFB)) < 500


def test_a_bag_in_the_live_window_gives_the_live_verdicts(capsys, tmp_path):
    from pathlib import Path

    bag = Path(__file__).resolve().parents[1] / "bags" / "wood_berry_full"
    assert main(["diagnose", str(bag), "--json", str(tmp_path / "live.json")]) == 0
    live = json.loads((tmp_path / "live.json").read_text())  # the live diagnostician's window, compared with its record
    window = str(live["window"]["window_samples"])
    argv = [
        "diagnose",
        str(bag),
        "--window",
        window,
        "--step",
        "1024",
        "--jobs",
        "1",
        "--json",
        str(tmp_path / "w.json"),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    found = json.loads((tmp_path / "w.json").read_text())
    (only,) = found["windows"]
    assert (only["first"], only["last"]) == (live["window"]["first_sample"], live["window"]["last_sample"])
    for name, element in live["elements"].items():
        assert only["elements"][name]["verdict"] == element["verdict"] == "mismatch"
        np.testing.assert_allclose(
            only["elements"][name]["classic"]["gain_ratio"], element["classic"]["gain_ratio"], rtol=1e-9
        )


def test_windows_on_a_dask_cluster_are_those_of_one_process(config):
    import logging

    from distributed import LocalCluster

    data = drifting_data(config, days=3, changes=(Change(0, 0, "gain", day=1, size=15.0),))
    here = monitor(data, config, window=2 * DAY, step=DAY // 2, jobs=1)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
        silence_logs=logging.ERROR,
    ) as cluster:  # fmt: skip
        there = monitor(data, config, window=2 * DAY, step=DAY // 2, scheduler=cluster.scheduler_address)
    assert [w["first"] for w in there.windows] == [w["first"] for w in here.windows] == [0, DAY // 2, DAY]
    for mine, theirs in zip(here.windows, there.windows, strict=True):
        for name, element in mine["elements"].items():
            assert theirs["elements"][name]["verdict"] == element["verdict"]
            np.testing.assert_allclose(
                theirs["elements"][name]["parametric"]["gain_mismatch_pct"],
                element["parametric"]["gain_mismatch_pct"],
                rtol=1e-9,
            )


def test_data_without_a_date_keep_their_seconds(config):
    from dataclasses import replace

    data = replace(drifting_data(config, days=2, changes=()), start="1000 s")  # a time column of seconds
    found = monitor(data, config, window=DAY, step=DAY, jobs=1)
    assert [(w["start"], w["end"]) for w in found.windows] == [(1000.0, 1000.0 + 86400), (87400.0, 87400.0 + 86400)]


def test_start_workers_starts_the_fork_server_only_for_local_windows_on_several_processes():
    import subprocess
    import sys
    from pathlib import Path

    # one fresh process tries the three in turn, counting its fork servers after each: one only after the last
    script = (
        "import sys, psutil\n"
        "from pmr_ros.service.monitoring import start_workers\n"
        "for case in sys.argv[1:]:\n"
        "    jobs, scheduler = case.split(',')\n"
        "    start_workers(jobs=int(jobs), scheduler=scheduler or None)\n"
        "    print(sum('forkserver' in ' '.join(p.cmdline()) for p in psutil.Process().children()))\n"
    )
    root = Path(__file__).resolve().parent.parent
    env = {**__import__("os").environ, "PYTHONPATH": str(root)}
    cases = ((1, ""), (2, "tcp://127.0.0.1:1"), (2, ""))
    done = subprocess.run(
        [sys.executable, "-c", script, *(f"{jobs},{scheduler}" for jobs, scheduler in cases)],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    servers = dict(zip(cases, done.stdout.split(), strict=True))
    assert servers == {(1, ""): "0", (2, "tcp://127.0.0.1:1"): "0", (2, ""): "1"}


@pytest.mark.parametrize("jobs", [1, 2])
def test_each_window_done_is_told_as_it_comes(config, jobs):
    data = drifting_data(config, days=3, changes=())
    told = []
    found = monitor(data, config, window=DAY, step=DAY // 2, jobs=jobs, windows_done=lambda *a: told.append(a))
    assert told == [(k, len(found.windows)) for k in range(len(found.windows) + 1)] and len(told) == 6


def test_the_window_command_draws_a_progress_bar_of_windows_on_a_terminal(export, monkeypatch):
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    argv = ["diagnose", str(export / "plant.csv"), "--config", str(export / "column.yaml"), "--window", "2d"]
    assert main([*argv, "--step", "1d", "--jobs", "1"]) == 0
    drawn = terminal.getvalue()
    assert "windows [" in drawn and "3/3 windows 100%" in drawn  # four days: windows ending on days 2, 3, 4
