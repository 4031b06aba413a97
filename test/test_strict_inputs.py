"""Bad input as a new user gives it: one line naming the file, field or option and the value, a non-zero exit.

Every test here runs the real command line (``pmr_ros.cli.main``, or the console script where a traceback
could only show in a separate process) and checks the exit code, that the error is one line, and what it names.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pmr_ros.cli import main
from pmr_ros.commands import writable_file
from pmr_ros.config import ConfigError, config_dir, load_config
from pmr_ros.config.schema import blocks

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "wood_berry_full"


def _error(capsys, argv: list[str], code: int = 2) -> str:
    """Run ``pmr-ros argv``; the one error line (usage errors exit through SystemExit)."""
    try:
        got = main(argv)
    except SystemExit as exit_:
        got = exit_.code
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    err = captured.err.strip()
    assert got == code, (argv, got, err)
    assert "\n" not in err and err.startswith("pmr-ros"), err
    return err


def _with(tmp_path: Path, change: dict, name: str = "cfg.yaml") -> Path:
    doc = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    params = doc["/**"]["ros__parameters"]
    for block, values in change.items():
        params.setdefault(block, {}).update(values) if isinstance(values, dict) else params.update({block: values})
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc))
    return path


# -- numeric options ---------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["-5", "nan", "inf", "fast"])
def test_replay_pace_must_be_a_finite_number_not_below_zero(capsys, value):
    err = _error(capsys, ["replay", str(REFERENCE), "--max-samples-per-second", value])
    assert f"--max-samples-per-second: {value}" in err or f"'{value}' is not a number" in err


@pytest.mark.parametrize(
    "argv,words",
    [
        (["replay", str(REFERENCE), "--linger", "-1"], "--linger: -1 must be a finite number >= 0"),
        (["replay", str(REFERENCE), "--rate", "0"], "--rate: 0 must be a finite number > 0"),
        (["replay", str(REFERENCE), "--rate", "nan"], "--rate: nan must be a finite number > 0"),
        (["replay", str(REFERENCE), "--wait", "-2"], "--wait: -2 must be >= 0"),
        (["record", "x", "--flush-period", "0"], "--flush-period: 0 must be a finite number > 0"),
        (["record", "x", "--duration", "inf"], "--duration: inf must be a finite number > 0"),
        (["run", "--samples", "0"], "--samples: 0 must be > 0"),
        (["run", "--samples", "1.5"], "--samples: '1.5' is not a whole number"),
        (["run", "--seed", "-1"], "--seed: -1 must be >= 0"),
        (["diagnose", str(REFERENCE), "--min-samples", "0"], "--min-samples: 0 must be > 0"),
        (["sweep", "--seeds", "0"], "--seeds: 0 must be > 0"),
        (["sweep", "--jobs", "-1"], "--jobs: -1 must be > 0"),
        (["sweep", "--nu-step", "x"], "--nu-step: 'x' is not a number"),
    ],
)
def test_every_numeric_option_is_checked_by_the_parser(capsys, argv, words):
    err = _error(capsys, argv)
    assert words in err and f"(see pmr-ros {argv[0]} --help)" in err


@pytest.mark.parametrize(
    "argv,words",
    [
        (["sweep", "--nu-start", "nan"], "--nu-start must be a positive number, got nan"),
        (["sweep", "--nu-step", "-0.5"], "--nu-step must be a positive number, got -0.5"),
        (["sweep", "--nu", "1,inf"], "--nu: every nu must be a positive number, got inf"),
        (["sweep", "--seeds", "99999999999"], "the last seed 99999999999 exceeds run.seed's maximum 2147483647"),
        (["sweep", "--first-seed", "2147483647", "--seeds", "2"], "the last seed 2147483648 exceeds"),
        (["run", "--batch", "--seed", "99999999999999999999"], "command line: run.seed = 99999999999999999999"),
        (["run", "--batch", "--samples", "99999999999"], "command line: run.samples = 99999999999: must be"),
    ],
)
def test_out_of_range_numbers_are_refused_before_any_work(capsys, tmp_path, argv, words):
    if argv[0] == "sweep":
        argv = [*argv, "--out", str(tmp_path / "out")]
    err = _error(capsys, argv)
    assert words in err
    assert not (tmp_path / "out").exists()  # nothing was started


# -- memory, checked before allocating ------------------------------------------------------------


@pytest.mark.parametrize("path", [["--batch"], []], ids=["batch", "nodes"])
def test_a_run_too_large_for_memory_is_refused_with_the_figure(capsys, path):
    err = _error(capsys, ["run", *path, "--samples", "2000000000"])
    assert re.search(r"run\.samples = 2000000000 \(command line\): needs about [\d.]+ [GT]B of memory", err), err
    assert "available: use fewer samples" in err
    assert ("simulation" in err) == bool(path) and ("diagnostician window" in err) != bool(path)


def test_the_memory_check_uses_the_machines_available_memory(capsys, monkeypatch, tmp_path):
    import pmr_ros.core.sim.memory as memory

    monkeypatch.setattr(memory, "available_bytes", lambda: 5_000_000)
    cfg = _with(tmp_path, {"run": {"samples": 16384}})
    err = _error(capsys, ["run", "--batch", "--config", str(cfg)])
    # 16384 samples x (16 B x 8 values + 56 B x 5 channels: 2 instruments and one row of 3) = 6.68 MB
    assert f"run.samples = 16384 ({cfg}): needs about 6.68 MB of memory" in err and "5 MB available" in err
    monkeypatch.setattr(memory, "available_bytes", lambda: None)  # unknown: no refusal
    assert main(["run", "--batch", "--samples", "300"]) == 3  # too short for any segment: refused, not run


def test_a_sweep_too_large_for_memory_is_refused_before_its_plan_is_built(capsys, tmp_path):
    err = _error(capsys, ["sweep", "--seeds", "2000000000", "--first-seed", "0", "--out", str(tmp_path / "o")])
    assert "740000000000 runs of 16384 samples" in err and "use fewer seeds, nu values or samples" in err
    err = _error(capsys, ["sweep", "--nu-step", "1e-9", "--out", str(tmp_path / "o")])
    assert "runs of 16384 samples" in err and "plan" in err
    assert not (tmp_path / "o").exists()


# -- output paths, checked before the run -----------------------------------------------------------


def test_run_refuses_an_unwritable_json_before_running(capsys, tmp_path):
    err = _error(capsys, ["run", "--batch", "--json", str(tmp_path / "missing" / "r.json")])
    assert f"--json {tmp_path / 'missing' / 'r.json'}: cannot write: No such file or directory" in err
    assert capsys.readouterr().out == ""
    (tmp_path / "exists.json").write_text("keep")
    writable_file(str(tmp_path / "exists.json"), "--json")
    assert (tmp_path / "exists.json").read_text() == "keep"  # checked, not touched
    writable_file(str(tmp_path / "new.json"), "--json")
    assert not (tmp_path / "new.json").exists()


def test_sweep_refuses_an_unwritable_report_before_sweeping(capsys, tmp_path):
    err = _error(capsys, ["sweep", "--out", str(tmp_path / "o"), "--report", str(tmp_path / "no" / "r.md")])
    assert f"--report {tmp_path / 'no' / 'r.md'}: cannot write" in err and not (tmp_path / "o").exists()


# -- messages that say the cause ----------------------------------------------------------------------


@pytest.mark.parametrize("method", ["parametric", "classic"])
def test_the_header_names_the_configured_method_also_without_a_verdict(capsys, method):
    assert main(["run", "--batch", "--samples", "300", "--method", method]) == 3
    out = capsys.readouterr().out.splitlines()
    assert f"({method} PMR)" in out[0] and out[1].startswith("INSUFFICIENT DATA: window too short")


def test_a_parametric_segment_longer_than_the_record_is_one_line_of_insufficient_data(capsys, tmp_path):
    cfg = _with(tmp_path, {"parametric": {"segment_length": 8192}})
    assert main(["run", "--batch", "--config", str(cfg), "--samples", "4096"]) == 3
    out = capsys.readouterr().out.splitlines()
    assert out[1].startswith("INSUFFICIENT DATA: window too short, known before simulating: 4096 samples")
    assert "Welch segments of 8192" in out[1]
    assert len(out) == 2


def test_a_diagnostician_whose_window_cannot_fit_in_memory_refuses_to_start(ros_domain):
    from ros_fixtures import console_script

    proc = subprocess.run(
        [
            console_script("pmr_diagnostician"),
            "--ros-args",
            "--params-file",
            str(config_dir() / "wood_berry.yaml"),
            "-p",
            "diagnostician.window_samples:=2000000000",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    err = proc.stderr.strip()
    assert proc.returncode == 2 and "Traceback" not in err and "\n" not in err, err
    assert "diagnostician.window_samples = 2000000000: a full window needs about 2.06 TB of memory" in err


def test_a_config_file_that_is_not_utf8_is_one_line(capsys, tmp_path):
    (tmp_path / "latin1.yaml").write_bytes((config_dir() / "wood_berry.yaml").read_bytes() + b"# 20 \xb0C\n")
    err = _error(capsys, ["run", "--batch", "--config", str(tmp_path / "latin1.yaml")])
    assert "not UTF-8 text: byte 0xb0 on line" in err, err


def test_console_script_errors_are_one_line_without_traceback(tmp_path):
    """``diagnose`` and ``replay`` as a process of their own (``run``'s: test_cli)."""
    (tmp_path / "bad_bag").mkdir()
    (tmp_path / "bad_bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    cases = [
        (["diagnose", str(tmp_path / "bad_bag")], "metadata.yaml: not valid YAML: did not find expected node"),
        (["replay", str(REFERENCE), "--max-samples-per-second", "-5"], "-5 must be a finite number >= 0"),
    ]
    for argv, words in cases:
        proc = subprocess.run(
            [sys.executable, "-m", "pmr_ros.cli", *argv], capture_output=True, text=True, timeout=120, check=False
        )
        err = proc.stderr.strip()
        assert proc.returncode == 2 and "Traceback" not in err and "\n" not in err and words in err, (argv, err)


# -- the config reader's strictness covers every declared block ---------------------------------------


def _misspelt(name: str) -> str:
    return name[:-2] + name[-1]  # drop the last but one letter


@pytest.mark.parametrize("block", list(blocks()))
def test_every_block_refuses_a_misspelt_key_naming_the_nearest(tmp_path, block):
    declared = blocks()[block].parameters
    key = declared[0].name.split(".", 1)[1]
    with pytest.raises(ConfigError) as err:
        load_config(_with(tmp_path, {block: {_misspelt(key): 1}}))
    assert f"{block}.{_misspelt(key)}" in str(err.value) and f"did you mean {block}.{key}?" in str(err.value)
    with pytest.raises(ConfigError) as err:
        load_config(_with(tmp_path, {_misspelt(block): {key: 1}}))
    assert "unknown block" in str(err.value) and f"did you mean {block}?" in str(err.value)


def test_diagnose_an_export_checks_json_first_and_refuses_a_bag_option(capsys, tmp_path):
    export = tmp_path / "plant.csv"
    export.write_text("time,r_x_D\n0,1\n")
    err = _error(capsys, ["diagnose", str(export), "--json", str(tmp_path / "no" / "r.json")])
    assert "--json" in err and "cannot write: No such file or directory" in err
    err = _error(capsys, ["diagnose", str(export), "--min-samples", "100"])
    assert f"--min-samples: an option for a bag; {export} is judged on all its clean data" in err


def test_diagnose_an_export_refuses_a_mode_column_list_of_the_wrong_length(capsys, tmp_path):
    export = tmp_path / "plant.csv"
    export.write_text("time,r_x_D\n0,1\n")
    config = _with(tmp_path, {"data": {"mode_columns": ["M1", "M2", "M3"]}})
    err = _error(capsys, ["diagnose", str(export), "--config", str(config)])
    assert "data.mode_columns" in err and "needs 1 or 2 column names (one per input or one for all), got 3" in err
