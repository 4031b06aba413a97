"""The four node processes under two busy loops, several runs in a row: verdicts over the full window each time.

Starts two busy loops (``python -c "while True: pass"``, killed at the end),
then, ``--runs`` times, the four nodes as processes (pmr_diagnostician,
mpc_controller, prbs_setpoint, wood_berry_plant, each with the shipped
Wood-Berry params file and a run file whose window is the whole run) and a
watcher of /diagnostics.  A run passes when the diagnostician's verdict for
the last sample covers the whole run (first sample 0, window = samples,
status ok).  Per run it prints one line: pass or FAIL, the window, the wall
time; for a failed run, the warnings of the nodes' logs (kept in
``--log-dir``).  Plain rclpy and the nodes' entry points of the pmr_ros on
the path.  Use scripts/load_check.sh, which claims a ROS domain first.

    usage: python scripts/load_check.py [--runs 5] [--samples 8192] [--busy 2] [--timeout 600]

Exit status: 0 when every run passed, 1 otherwise.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

NODES = ("pmr_diagnostician", "mpc_controller", "prbs_setpoint", "wood_berry_plant")


def _node(name: str, files: list[Path], log: Path) -> subprocess.Popen:
    """One node as a process, started through its console-script entry point."""
    code = f"import sys; from pmr_ros.entry import {name}; sys.exit({name}())"
    args = [sys.executable, "-c", code, "--ros-args"]
    for file in files:
        args += ["--params-file", str(file)]
    return subprocess.Popen(args, stdout=log.open("w"), stderr=subprocess.STDOUT)


def _run_file(folder: Path, samples: int) -> Path:
    path = folder / "run.yaml"
    path.write_text(
        "/**:\n  ros__parameters:\n"
        f"    run:\n      samples: {samples}\n"
        f"    diagnostician:\n      window_samples: {samples}\n      update_period_samples: {samples}\n"
        f"      min_samples: {samples}\n"
    )
    return path


def _final_verdict(samples: int, timeout_s: float, procs: dict[str, subprocess.Popen]) -> tuple[dict | None, str]:
    """The info of the diagnostician's verdict on the last sample (None if none came); what ended the wait."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from pmr_ros.contract.layout import diagnosis_from_array

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("load_check_watcher", context=context)
    found: list[dict] = []

    def on_diagnostics(msg) -> None:
        diagnosis, info = diagnosis_from_array(msg, "pmr_diagnostician")
        if info.get("last_sample") == samples - 1:
            found.append({**info, "status": diagnosis.status})

    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, qos)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + timeout_s
    why = "timeout"
    try:
        while not found and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
            dead = [n for n, p in procs.items() if p.poll() is not None]
            if dead:
                why = f"{', '.join(dead)} exited"
                break
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.shutdown(context=context)
    return (found[0] if found else None), ("verdict" if found else why)


def _stop(procs: dict[str, subprocess.Popen]) -> None:
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    for proc in procs.values():
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _warnings(folder: Path) -> list[str]:
    """The warning and error lines of the nodes' logs (what a failed run lost or waited on)."""
    lines = []
    for name in NODES:
        log = folder / f"{name}.log"
        if log.exists():
            lines += [
                f"{name}: {x}" for x in log.read_text().splitlines() if "WARN" in x or "ERROR" in x or "rror" in x
            ]
    return lines


def one_run(number: int, *, samples: int, timeout_s: float, folder: Path) -> bool:
    """Start the four nodes, wait for the verdict on the last sample, stop them; print one line; whether it passed."""
    from pmr_ros.config import config_dir

    folder.mkdir(parents=True, exist_ok=True)
    files = [config_dir() / "wood_berry.yaml", _run_file(folder, samples)]
    started = time.monotonic()
    procs = {name: _node(name, files, folder / f"{name}.log") for name in NODES}
    try:
        info, why = _final_verdict(samples, timeout_s, procs)
    finally:
        wall = time.monotonic() - started
        _stop(procs)
    full = bool(info) and info.get("first_sample") == 0 and info.get("window_samples") == samples
    full = full and info is not None and info.get("status") == "ok"
    window = (
        f"samples {info.get('first_sample')}..{info.get('last_sample')}, window {info.get('window_samples')}, "
        f"status {info.get('status')}"
        if info
        else f"no verdict on sample {samples - 1} ({why})"
    )
    print(f"run {number}: {'pass' if full else 'FAIL'}: {window}; wall {wall:.1f} s; logs in {folder}", flush=True)
    plant = folder / "wood_berry_plant.log"
    start = [x for x in plant.read_text().splitlines() if "starting" in x] if plant.exists() else []
    print(f"    plant: {start[0].split(']: ', 1)[-1] if start else 'no start line'}", flush=True)
    if not full:
        for line in _warnings(folder)[:20]:
            print(f"    {line}", flush=True)
    return full


def main(argv: list[str] | None = None) -> int:
    """Busy loops on, ``--runs`` four-process runs, busy loops off; 0 when every run gave the full window."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--samples", type=int, default=8192)
    parser.add_argument("--busy", type=int, default=2, help="busy loops beside the runs (default: 2)")
    parser.add_argument("--timeout", type=float, default=600.0, help="longest wait for one run's verdict [s]")
    parser.add_argument("--log-dir", type=Path, default=None)
    args = parser.parse_args(argv)
    folder = args.log_dir or Path(tempfile.mkdtemp(prefix="pmr_ros_load_check_"))
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
    passed = 0
    try:
        print(
            f"{args.busy} busy loops; {args.runs} runs of the four node processes, {args.samples} samples", flush=True
        )
        for number in range(1, args.runs + 1):
            passed += one_run(number, samples=args.samples, timeout_s=args.timeout, folder=folder / f"run_{number}")
    finally:
        for proc in busy:
            proc.kill()
            proc.wait()
    print(f"{passed} of {args.runs} runs gave verdicts over the full window", flush=True)
    return 0 if passed == args.runs else 1


if __name__ == "__main__":
    sys.exit(main())
