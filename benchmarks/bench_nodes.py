"""Lockstep throughput of the ROS 2 node set: samples per second, one process and four.

    .venv/bin/python benchmarks/bench_nodes.py [--samples N] [--domain-id D]

One process: the four nodes on one executor (EventsExecutor, then
SingleThreadedExecutor), discovery private to the process.  Four processes:
the console scripts with one params file, localhost discovery in domain D;
timed from the first y on the wire to the final verdicts on /diagnostics.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

NODES = ("pmr_diagnostician", "mpc_controller", "prbs_setpoint", "wood_berry_plant")


def one_process(samples: int, executor: str) -> float:
    from pmr_ros.config import load_config
    from pmr_ros.node_set import NodeSetOptions, run_node_set

    config = load_config(overrides={"run": {"samples": samples}})
    result = run_node_set(config, NodeSetOptions(private=True, executor_kind=executor))
    assert result.diagnosis.status == "ok", result.diagnosis.reason
    return result.samples_per_second


def four_processes(samples: int, domain_id: int) -> float:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    from pmr_ros.config import config_dir
    from pmr_ros.contract.layout import diagnosis_from_array
    from pmr_ros.contract.topics import topic
    from pmr_ros.ros.topics import message_class, qos_profile

    os.environ.update({"ROS_DOMAIN_ID": str(domain_id), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    folder = Path(tempfile.mkdtemp(prefix="bench_nodes_"))
    run_file = folder / "run.yaml"
    run_file.write_text(
        "/**:\n  ros__parameters:\n"
        f"    run:\n      samples: {samples}\n"
        f"    diagnostician:\n      window_samples: {samples}\n      update_period_samples: {samples}\n      "
        f"min_samples: {samples}\n"
    )
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = rclpy.create_node("bench_listener", context=context)
    times: dict[str, float] = {}

    def on_y(msg):
        times.setdefault("first_y", time.monotonic())

    def on_diagnostics(msg):
        _, info = diagnosis_from_array(msg)
        if info.get("last_sample") == samples - 1:
            times.setdefault("final", time.monotonic())

    for key, callback in (("measured_output", on_y), ("diagnostics", on_diagnostics)):
        t = topic(key)
        node.create_subscription(message_class(t), t.name, callback, qos_profile(t.qos))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    procs = []
    try:
        procs = start_nodes([config_dir() / "wood_berry.yaml", run_file])
        deadline = time.monotonic() + 600
        while "final" not in times and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        if "final" not in times:
            raise RuntimeError("no final verdicts from the four processes")
        return samples / (times["final"] - times["first_y"])
    finally:
        stop_nodes(procs)
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def start_nodes(params_files: list[Path]) -> list[subprocess.Popen]:
    """The four node executables as processes, each with the given params files."""
    bindir = Path(sys.executable).parent
    arguments = [item for path in params_files for item in ("--params-file", str(path))]
    return [
        subprocess.Popen(
            [str(bindir / name), "--ros-args", *arguments], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        for name in NODES
    ]


def stop_nodes(procs: list[subprocess.Popen]) -> None:
    """Ctrl-C every process; kill what has not stopped after 10 s."""
    for proc in procs:
        proc.send_signal(signal.SIGINT)
    for proc in procs:
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "91")))
    args = parser.parse_args()
    print(f"lockstep node set, {args.samples} samples, Wood-Berry full mismatch, {os.cpu_count()} cores")
    for executor in ("events", "single"):
        print(
            f"  one process, {executor:6s} executor : {one_process(args.samples, executor):7.0f} samples/s", flush=True
        )
    print(
        f"  four processes                : {four_processes(args.samples, args.domain_id):7.0f} samples/s", flush=True
    )


if __name__ == "__main__":
    main()
