"""The ROS 2 node set: lockstep throughput, and that no sample is lost across processes, even on a busy machine.

    .venv/bin/python benchmarks/bench_nodes.py [--samples N] [--runs R] [--busy B] [--domain-id D] [--skip-one-process]

1. One process: the four nodes on one executor (EventsExecutor, then SingleThreadedExecutor).
2. Four processes (the console scripts, one params file), R runs: samples/s from the first y on the wire
   to the final verdicts, and whether each run's verdicts cover the full window (0 .. N-1).
3. ``pmr-ros replay`` of the reference bag into a ``pmr_diagnostician`` process as fast as the flow
   control lets it: the diagnostician's final window must hold all 8192 samples (a missing r, u or y
   would have restarted it), and the samples/s.
4. ``pmr-ros record`` of a live four-process set, stopped by SIGINT and by SIGTERM half-way: the samples
   in each bag, and whether any is missing between the first and the last on r, u, y and the clock.

With ``--busy B``, B busy loops (``python3 -c 'while True: pass'``) run during 2-4.  Localhost discovery
in domain D (default 215: not one of the tests' domains 1..101, and its DDS ports, from 7400 + 250 x 215 =
61150 on, lie above Linux's ephemeral ports, 32768-60999).  Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

NODES = ("pmr_diagnostician", "mpc_controller", "prbs_setpoint", "wood_berry_plant")
BIN = Path(sys.executable).parent
ROOT = Path(__file__).resolve().parents[1]
DOMAIN_ID = 215  # outside the tests' 1..101 (test/ros_fixtures.py): a run beside the suite never hears a test


def one_process(samples: int, executor: str, domain_id: int) -> float:
    from pmr_ros.config import load_config
    from pmr_ros.node_set import NodeSetOptions, run_node_set

    config = load_config(overrides={"run": {"samples": samples}})
    result = run_node_set(config, NodeSetOptions(domain_id=domain_id, private=True, executor_kind=executor))
    assert result.diagnosis.status == "ok", result.diagnosis.reason
    return result.samples_per_second


@contextlib.contextmanager
def busy_loops(count: int) -> Iterator[None]:
    """``count`` processes spinning on a core each, while inside."""
    procs = [subprocess.Popen(["python3", "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


class Listener:
    """A node of this process: the first y on the wire and the final /diagnostics of a run."""

    def __init__(self, context, last_sample: int) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        from pmr_ros.contract.topics import topic
        from pmr_ros.ros.messages import message_class, qos_profile

        self.last_sample, self.first_y, self.final, self.final_at, self.newest_y = last_sample, None, None, None, -1
        self.node = rclpy.create_node("bench_listener", context=context)
        for key, callback in (("measured_output", self._on_y), ("diagnostics", self._on_diagnostics)):
            t = topic(key)
            self.node.create_subscription(message_class(t), t.name, callback, qos_profile(t.qos))
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def _on_y(self, msg) -> None:
        self.first_y = self.first_y or time.monotonic()
        self.newest_y = max(self.newest_y, msg.header.stamp.sec)

    def _on_diagnostics(self, msg) -> None:
        from pmr_ros.contract.layout import diagnosis_from_array

        diagnosis, info = diagnosis_from_array(msg, "pmr_diagnostician")
        if info.get("last_sample") == self.last_sample and self.final is None:
            self.final, self.final_at = (diagnosis, info), time.monotonic()

    def spin_until(self, predicate, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not predicate() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        return predicate()

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()


@contextlib.contextmanager
def ros_context(domain_id: int) -> Iterator[object]:
    import rclpy
    from rclpy.context import Context

    os.environ.update({"ROS_DOMAIN_ID": str(domain_id), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


def run_file(folder: Path, samples: int) -> Path:
    path = folder / f"run_{samples}.yaml"
    path.write_text(
        "/**:\n  ros__parameters:\n"
        f"    run:\n      samples: {samples}\n"
        f"    diagnostician:\n      window_samples: {samples}\n      update_period_samples: {samples}\n      "
        f"min_samples: {samples}\n"
    )
    return path


def start(argv: list[str], log: Path) -> subprocess.Popen:
    with open(log, "w") as handle:
        return subprocess.Popen(argv, stdout=handle, stderr=subprocess.STDOUT)


def start_nodes(folder: Path, params: Path, names=NODES) -> list[subprocess.Popen]:
    """The node executables as processes, each with the system and the run's params files."""
    system = ROOT / "config" / "wood_berry.yaml"
    argv = ["--ros-args", "--params-file", str(system), "--params-file", str(params)]
    return [start([str(BIN / name), *argv], folder / f"{name}.log") for name in names]


def stop(procs: list[subprocess.Popen], how: int = signal.SIGINT) -> list[int | None]:
    """Signal every process; kill what has not stopped after 30 s; the exit codes."""
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(how)
    codes = []
    for proc in procs:
        try:
            codes.append(proc.wait(timeout=30))
        except subprocess.TimeoutExpired:
            proc.kill()
            codes.append(None)
    return codes


def four_processes(context, folder: Path, samples: int) -> tuple[float, str]:
    """One run of the four node processes: samples/s and what the final verdicts covered."""
    listener = Listener(context, samples - 1)
    procs = start_nodes(folder, run_file(folder, samples))
    try:
        if not listener.spin_until(lambda: listener.final is not None, 1200.0):
            return 0.0, f"no final verdicts (newest y {listener.newest_y})"
        diagnosis, info = listener.final
        window = f"window {info.get('first_sample')}..{info.get('last_sample')}, {diagnosis.status}"
        return samples / (listener.final_at - listener.first_y), window
    finally:
        stop(procs)
        listener.close()


def replay_count(context, folder: Path) -> str:
    """``pmr-ros replay`` of the reference bag into a diagnostician process; what its final window held."""
    from pmr_ros.bag.reader import open_bag

    bag = ROOT / "bags" / "wood_berry_full"
    samples = open_bag(bag).counts["/clock"]
    listener = Listener(context, samples - 1)
    params = folder / "replay_params.yaml"
    params.write_text(open_bag(bag).run_config().params_yaml())
    diagnostician = start_nodes(folder, params, names=("pmr_diagnostician",))
    try:
        replay = start([str(BIN / "pmr-ros"), "replay", str(bag), "--linger", "1"], folder / "replay.log")
        listener.spin_until(lambda: listener.final is not None and replay.poll() is not None, 1200.0)
        stop([replay])
        line = (folder / "replay.log").read_text().strip().splitlines()[-1]
        if listener.final is None:
            return f"no final verdicts; {line}"
        diagnosis, info = listener.final
        return (
            f"{info['window_samples']} of {samples} samples in the diagnostician's window ({diagnosis.status}); {line}"
        )
    finally:
        stop(diagnostician)
        listener.close()


def recorded_range(bag_path: Path) -> str:
    """Per signal topic of a bag: messages, first..last sample and how many between are missing."""
    from pmr_ros.bag.reader import open_bag

    bag = open_bag(bag_path)
    parts = []
    for name in ("/pmr/setpoint", "/pmr/manipulated_input", "/pmr/measured_output", "/clock"):
        stamps = sorted(
            (m.clock if hasattr(m, "clock") else m.header.stamp).sec
            for m in (bag.decode(x) for x in bag.messages({name}))
        )
        missing = (stamps[-1] - stamps[0] + 1 - len(set(stamps))) if stamps else 0
        parts.append(
            f"{name} {len(stamps)} ({stamps[0] if stamps else '-'}..{stamps[-1] if stamps else '-'}, {missing} missing)"
        )
    return ("complete, " if bag.complete else "NOT closed, ") + "; ".join(parts)


def record_live(context, folder: Path, samples: int) -> list[str]:
    """Two ``pmr-ros record`` of a live four-process set, stopped by SIGINT and SIGTERM half-way."""
    listener = Listener(context, samples - 1)
    recorders = {
        how: start(
            [str(BIN / "pmr-ros"), "record", str(folder / f"bag_{how.name}"), "--no-parameters"],
            folder / f"record_{how.name}.log",
        )
        for how in (signal.SIGINT, signal.SIGTERM)
    }
    procs = start_nodes(folder, run_file(folder, samples))
    out = []
    try:
        for how, at in ((signal.SIGINT, samples // 3), (signal.SIGTERM, 2 * samples // 3)):
            listener.spin_until(lambda at=at: listener.newest_y >= at, 1200.0)
            seen = listener.newest_y
            (code,) = stop([recorders[how]], how)
            out.append(f"{how.name} at y({seen}): exit {code}; {recorded_range(folder / f'bag_{how.name}')}")
        return out
    finally:
        stop(procs)
        stop(list(recorders.values()))
        listener.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--busy", type=int, default=0, help="busy loops during the multi-process parts")
    parser.add_argument("--domain-id", type=int, default=DOMAIN_ID, help=f"ROS domain (default {DOMAIN_ID})")
    parser.add_argument("--skip-one-process", action="store_true")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(
        f"lockstep node set, Wood-Berry full mismatch, {os.cpu_count()} cores, load {load:.2f}, {args.busy} busy loops"
    )
    if not args.skip_one_process:
        for executor in ("events", "single"):
            rate = one_process(args.samples, executor, args.domain_id)
            print(f"  one process, {executor:6s} executor : {rate:7.0f} samples/s", flush=True)
    folder = Path(tempfile.mkdtemp(prefix="bench_nodes_"))
    with ros_context(args.domain_id) as context, busy_loops(args.busy):
        for run in range(args.runs):
            started = time.monotonic()
            rate, window = four_processes(context, folder, args.samples)
            print(
                f"  four processes, run {run + 1}: {rate:7.0f} samples/s, {window} "
                f"({time.monotonic() - started:.1f} s wall)",
                flush=True,
            )
        print(f"  replay into a diagnostician process: {replay_count(context, folder)}", flush=True)
        for line in record_live(context, folder, args.samples):
            print(f"  record of the live set, {line}", flush=True)
    print(f"  (logs in {folder}; load at the end {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
