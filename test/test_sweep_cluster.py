"""``sweep --scheduler`` where no Dask scheduler answers: one line, bounded, nothing left (issue 21, item 9)."""

from __future__ import annotations

import http.server
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pmr_ros.cli import main
from pmr_ros.sweep import store

SMALL = ["--nu", "1,3", "--seeds", "1", "--samples", "2048", "--methods", "classic", "--quiet"]
TIMEOUT_S = 1.0


@pytest.fixture
def http_server():
    """A plain HTTP server on localhost: it accepts the connection and never speaks Dask."""

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _refused(capsys, out: Path, address: str, *extra: str) -> tuple[str, float]:
    started = time.monotonic()
    code = main(
        ["sweep", "--out", str(out), "--scheduler", address, "--connect-timeout", str(TIMEOUT_S), *SMALL, *extra]
    )
    took = time.monotonic() - started
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"pmr-ros: error: --scheduler {address}: "), err
    return err[0], took


def test_an_http_server_is_not_taken_for_a_scheduler(tmp_path, capsys, http_server):
    line, took = _refused(capsys, tmp_path / "o", http_server)
    assert "cannot connect to a Dask scheduler there" in line or "not a Dask scheduler" in line
    # each of its three steps (connect, ask, answer) is bounded by the timeout: it ends, where it hung before
    assert took < 3 * TIMEOUT_S + 5.0, took
    assert not (tmp_path / "o").exists()


def test_a_closed_port_is_one_line_and_leaves_no_sweep(tmp_path, capsys):
    line, _ = _refused(capsys, tmp_path / "o", f"tcp://127.0.0.1:{_closed_port()}")
    assert "cannot connect to a Dask scheduler there" in line
    assert not (tmp_path / "o").exists()


def test_a_failed_connect_keeps_an_earlier_sweep_even_with_force(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / store.RESULTS_FILE).write_text("earlier results\n")
    (out / store.MANIFEST_FILE).write_text("{}\n")
    _refused(capsys, out, f"tcp://127.0.0.1:{_closed_port()}", "--force")
    assert (out / store.RESULTS_FILE).read_text() == "earlier results\n"
    assert (out / store.MANIFEST_FILE).read_text() == "{}\n"


def test_a_malformed_address_says_what_one_looks_like(tmp_path, capsys):
    line, _ = _refused(capsys, tmp_path / "o", "localhost")
    assert "not a Dask address" in line and "tcp://" in line


def test_no_traceback_when_the_process_ends(tmp_path):
    """A failed distributed Client printed a ``Client.__del__`` traceback at exit; the whole stderr is one line."""
    address = f"tcp://127.0.0.1:{_closed_port()}"
    argv = ["sweep", "--out", str(tmp_path / "o"), "--scheduler", address, "--connect-timeout", "1", *SMALL]
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run([sys.executable, "-m", "pmr_ros.cli", *argv], capture_output=True, text=True, env=env)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "o").exists()
