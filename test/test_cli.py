"""The pmr-ros command line: report contents, exit codes, errors without tracebacks."""

import json
import subprocess
import sys

import pytest

from pmr_ros.cli import main
from pmr_ros.config import config_dir


def test_run_prints_table_and_writes_json_report(tmp_path, capsys):
    out = tmp_path / "report.json"
    code = main(["run", "--batch", "--samples", "8192", "--seed", "2", "--json", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "G21" in text and "scenario full" in text and "seed 2" in text
    report = json.loads(out.read_text())
    assert set(report["elements"]) == {"G11", "G12", "G21", "G22"}
    assert report["method"] == "parametric"  # the declared default
    for element in report["elements"].values():
        classic, parametric = element["classic"], element["parametric"]
        assert isinstance(classic["gain_ratio"], float) and isinstance(classic["gain_mismatch"], bool)
        assert isinstance(classic["tau_index"], float) and isinstance(classic["tau_mismatch"], bool)
        assert isinstance(classic["delay_mismatch_samples"], int) and isinstance(classic["delay_mismatch"], bool)
        assert isinstance(parametric["gain_mismatch_pct"], float)
        low, high = parametric["gain_mismatch_pct_low"], parametric["gain_mismatch_pct_high"]
        assert low < parametric["gain_mismatch_pct"] < high
        assert element["verdict"] == parametric["verdict"] == "mismatch"
        assert element["model"]["kind"] == "foptd"
    assert report["elements"]["G21"]["parametric"]["delay_mismatch_samples"] == 2
    assert report["elements"]["G21"]["classic"]["delay_mismatch_samples"] == 2
    assert report["injected"]["G12"] == {"gain_pct": 15.0, "time_constant_pct": 12.0, "delay_samples": 1}
    assert report["scenario"] == "full" and report["seed"] == 2 and report["status"] == "ok"


def test_insufficient_data_is_a_verdict_and_exit_3(tmp_path, capsys):
    cfg = tmp_path / "flat.yaml"
    cfg.write_text((config_dir() / "wood_berry.yaml").read_text() + "    prbs:\n      amplitude: 0.0\n")
    assert main(["run", "--batch", "--config", str(cfg), "--samples", "4096"]) == 3
    assert "INSUFFICIENT DATA" in capsys.readouterr().out


def test_bad_config_is_one_line_naming_file_and_field(tmp_path, capsys):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(
        (config_dir() / "wood_berry.yaml").read_text().replace("[16.7, 21.0, 10.9, 14.4]", "[16.7, 21.0, -10.9, 14.4]")
    )
    assert main(["run", "--batch", "--config", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert str(cfg) in err and "system.time_constant[2] (G21)" in err and "-10.9" in err


def test_missing_config_file(capsys):
    assert main(["run", "--batch", "--config", "/no/such/file.yaml"]) == 2
    assert "/no/such/file.yaml" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv,words",
    [(["run", "--scenario", "bogus"], "invalid choice: 'bogus'"), (["run", "--samples", "-5"], "must be > 0")],
)
def test_bad_options_exit_2(argv, words, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2 and words in capsys.readouterr().err


def test_console_script_error_has_no_traceback(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(
        (config_dir() / "wood_berry.yaml").read_text().replace("[1.0, 3.0, 7.0, 3.0]", "[1.0, 3.0, 7.5, 3.0]")
    )
    proc = subprocess.run(
        [sys.executable, "-m", "pmr_ros.cli", "run", "--batch", "--config", str(cfg)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert (
        "Traceback" not in proc.stderr and "system.delay[2]" in proc.stderr and "whole number of samples" in proc.stderr
    )
