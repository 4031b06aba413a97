"""Outputs never destroy inputs, are written whole or not at all, and do not follow a stray link (issue 21, item 3)."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest
from test_bag import REFERENCE

from pmr_ros import outputs
from pmr_ros.cli import main
from pmr_ros.config import config_dir

RUN = ["run", "--batch", "--samples", "300"]
"""A run short enough to be quick; too few samples for verdicts (exit 3), but its outputs are written."""


def _error(capsys, argv, code: int = 2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err
    assert err.startswith("pmr-ros: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


def _no_temporaries(folder: Path) -> None:
    assert not [p.name for p in folder.rglob(".*.tmp")], "a temporary file was left behind"


def test_writing_the_json_onto_the_input_is_refused_and_the_input_unchanged(tmp_path, capsys):
    data = tmp_path / "data.csv"
    data.write_bytes(b"time,a\n0,1\n" * 1000)
    before = data.read_bytes()
    config = str(config_dir() / "wood_berry.yaml")
    for given in (str(data), f"{tmp_path}/../{tmp_path.name}/data.csv"):
        err = _error(capsys, ["diagnose", str(data), "--config", config, "--json", given])
        assert f"--json {given}: is the input {data}" in err
    link = tmp_path / "out.json"
    link.symlink_to(data)
    err = _error(capsys, ["diagnose", str(data), "--config", config, "--json", str(link), "--follow-symlinks"])
    assert f"--json {data}: is the input {data}" in err
    assert data.read_bytes() == before


def test_the_corrected_model_onto_the_config_is_refused(tmp_path, capsys):
    config = tmp_path / "column.yaml"
    config.write_text((config_dir() / "wood_berry.yaml").read_text())
    before = config.read_bytes()
    err = _error(capsys, [*RUN, "--config", str(config), "--write-model", str(config)])
    assert f"--write-model {config}: is the input {config}" in err
    err = _error(capsys, [*RUN, "--json", str(tmp_path / "r.json"), "--write-model", str(tmp_path / "r.json")])
    assert "is also the --json output" in err
    assert config.read_bytes() == before and not (tmp_path / "r.json").exists()


def test_a_report_into_the_bag_or_onto_an_input_is_refused(tmp_path, capsys):
    err = _error(capsys, ["diagnose", str(REFERENCE), "--report", str(REFERENCE)])
    assert f"--report {REFERENCE}: is or lies inside the input {REFERENCE}" in err
    err = _error(capsys, ["diagnose", str(REFERENCE), "--report", str(REFERENCE / "page")])
    assert "lies inside the input" in err and not (REFERENCE / "page").exists()
    data = tmp_path / "index.html"
    data.write_text("a,b\n")
    err = _error(capsys, ["diagnose", str(data), "--report", str(tmp_path)])
    assert f"the report's index.html would overwrite the input {data}" in err and data.read_text() == "a,b\n"


def test_an_output_that_is_a_symbolic_link_is_refused_unless_followed(tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    target = elsewhere / "kept.json"
    target.write_text("{}")
    link = tmp_path / "r.json"
    link.symlink_to(target)
    err = _error(capsys, [*RUN, "--json", str(link)])
    assert f"--json {link}: is a symbolic link to {target}" in err and "--follow-symlinks" in err
    assert target.read_text() == "{}"
    assert main([*RUN, "--json", str(link), "--follow-symlinks"]) == 3
    assert link.is_symlink() and json.loads(target.read_text())["command"] == "run"
    _no_temporaries(tmp_path)


def _disk_full(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_disk_leaves_the_previous_json_intact(tmp_path, capsys, monkeypatch):
    out = tmp_path / "r.json"
    assert main([*RUN, "--json", str(out)]) == 3
    capsys.readouterr()
    before = out.read_bytes()
    assert json.loads(before)["command"] == "run"
    monkeypatch.setattr(outputs.os, "fsync", _disk_full)  # the disk fills while the new report is flushed
    err = _error(capsys, [*RUN, "--seed", "9", "--json", str(out)])
    assert f"--json {out}: cannot write: No space left on device" in err
    assert out.read_bytes() == before
    _no_temporaries(tmp_path)


def test_a_write_cut_short_leaves_the_previous_file_and_no_temporary(tmp_path, monkeypatch):
    """The disk fills half-way through the bytes: the old file stays, the half-written temporary goes."""
    target = tmp_path / "index.html"
    outputs.write_text(target, "<p>old</p>")
    real = Path.write_bytes

    def half(self, data):
        real(self, data[: len(data) // 2])
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_bytes", half)
    with pytest.raises(OSError, match="No space left"):
        outputs.write_text(target, "<p>new and much longer</p>")
    monkeypatch.undo()
    assert target.read_text() == "<p>old</p>"
    _no_temporaries(tmp_path)
    os.chmod(target, 0o640)
    outputs.write_text(target, "<p>new</p>")  # a rewrite keeps the file's permissions
    assert target.read_text() == "<p>new</p>" and target.stat().st_mode & 0o777 == 0o640
