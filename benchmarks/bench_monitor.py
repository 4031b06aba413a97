"""Benchmark of the monitor: a year of 1-minute data in rolling windows, and a fleet of controllers (a script).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_monitor.py year [--days 365] [--shape 4x8] [--window 14d]
        [--step 1d] [--jobs N] [--cache DIR]
    PYTHONPATH=. .venv/bin/python benchmarks/bench_monitor.py fleet [--controllers 20] [--days 4] [--dask]

``year``: our own closed loop of an n x m controller (half its cells empty,
:func:`bench_scale.industrial_system`, no mismatch at first), one day per
lockstep run (test/drifting.py), one gain ramping 0 -> +20 % over two weeks
from day 120 and one delay stepping +2 samples on day 250.  Printed: the
generation time, then the monitor's wall time (every window diagnosed on
``--jobs`` processes, the trend table and the onsets), the peak memory of this
process and its workers together (:class:`PeakMemory`), and the onsets found
against the injected ones.  ``--cache DIR`` keeps the generated record.

``fleet``: ``--controllers`` generated controllers of different shapes
(2x2 .. 4x8), two of them drifting, ``--days`` of data each (4: two days
are 6 Welch segments of 512 after each day's settling, fewer than the 8 a
diagnosis needs, and every element would be inconclusive); the wall time of ``diagnose --fleet``'s
service locally and (``--dask``) on a local Dask cluster, whether the two
drifting controllers rank first, and whether both summaries agree.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "test"))
from bench_scale import industrial_system, load  # noqa: E402  (this folder is on sys.path)
from drifting import Change, drifting_signals  # noqa: E402

from pmr_ros.data import PlantData  # noqa: E402

RAMP_DAY, STEP_DAY = 120, 250


def _config(shape: str, folder: Path, seed: int = 0):
    n_out, n_in = (int(n) for n in shape.split("x"))
    tree = industrial_system(n_out, n_in, seed=seed)
    tree["mismatch"] = {key: [0] * len(value) for key, value in tree["mismatch"].items()}
    tree["system"]["name"] = f"c{seed}_{shape}"
    # 1-minute data of a model in minutes; no outlier check: an MV that sits at its limit most of the time has
    # a tiny robust step, and the cleaning would cut its moves off the limit as outliers (our data have no spikes)
    tree["data"] = {"time_unit_s": 60.0, "outlier_mad": 0.0}
    if tree["excitation"]["mv_dither_amplitude"] > 0:  # the export carries the MV dither (the instruments)
        tree["data"]["dither_columns"] = [f"d_{name}" for name in tree["system"]["input_names"]]
    return load(tree, folder)


def _elements(config) -> tuple[tuple[int, int], tuple[int, int]]:
    """The ramping gain's element (the first output's own) and the stepping delay's (the last output's own)."""
    present = np.argwhere(config.model.present)
    first, last = present[0], present[-1]
    return (int(first[0]), int(first[1])), (int(last[0]), int(last[1]))


def _signals(config, days: int, cache: Path | None) -> dict[str, np.ndarray]:
    (i, k), (j, m) = _elements(config)
    changes = (Change(i, k, "gain", day=RAMP_DAY, size=20.0, days=14), Change(j, m, "delay", day=STEP_DAY, size=2))
    path = None if cache is None else cache / f"{config.model.name}_{days}d.npz"
    if path is not None and path.exists():
        return dict(np.load(path))
    signals = {}
    for start in range(0, days, 61):  # pieces of two months: one lockstep batch each
        piece = drifting_signals(config, days=min(61, days - start), changes=_shifted(changes, start), seed=start)
        for name, values in piece.items():
            signals.setdefault(name, []).append(values)
    joined = {name: np.concatenate(parts) for name, parts in signals.items()}
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, **joined)
    return joined


def _shifted(changes: tuple[Change, ...], start: int) -> tuple[Change, ...]:
    from dataclasses import replace

    return tuple(replace(c, day=c.day - start) for c in changes)


SAMPLE_EVERY_S = 1.0
"""How often :class:`PeakMemory` reads every process's memory [s].

A proportional set size is the kernel walking the process's page tables (/proc/PID/smaps_rollup): 5 ms of
CPU per process read, 25 ms a sample with four processes.  Every 0.2 s that was 10 of the run's 105 s of CPU
and 4 s of its wall time on two cores, taken from the workers.  The memory grows slowly through the run (by
about 2 MB/s) to its peak at the end, so a sample a second misses at most a second's growth: measured, the
same run's peak is 699-705 MB sampled either way.
"""


class PeakMemory:
    """The largest memory of this process and all its descendants together [MB], and their CPU time [s].

    Two sums: of the proportional set sizes (``pss``: the physical memory they hold, a page shared by k
    processes counted 1/k in each) and of the resident sizes (``peak``: a shared page counted in every
    process that maps it).  The workers are forked from a fork server that imported the diagnosis's modules;
    those pages stay shared, and the resident sum counts them once per process.  Sampled every
    :data:`SAMPLE_EVERY_S`; the pool's workers are the fork server's children.  The CPU time (user + system,
    each process's last sample) is the figure a shared machine does not inflate.
    """

    def __init__(self) -> None:
        import threading

        self.peak = 0.0
        self.pss = 0.0
        self._cpu: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self) -> None:
        import psutil

        me = psutil.Process()
        start = sum(me.cpu_times()[:2])
        while not self._stop.wait(SAMPLE_EVERY_S):
            mine = me.memory_full_info()
            total, proportional = mine.rss, mine.pss
            self._cpu[me.pid] = sum(me.cpu_times()[:2]) - start
            for child in me.children(recursive=True):
                try:
                    theirs = child.memory_full_info()
                    total, proportional = total + theirs.rss, proportional + theirs.pss
                    self._cpu[child.pid] = sum(child.cpu_times()[:2])
                except psutil.Error:
                    pass
            self.peak = max(self.peak, total / 2**20)
            self.pss = max(self.pss, proportional / 2**20)

    @property
    def cpu_s(self) -> float:
        """CPU time of this process (since entering) and of its descendants while sampled [s]."""
        return sum(self._cpu.values())

    def __enter__(self) -> PeakMemory:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def year(args: argparse.Namespace) -> None:
    from pmr_ros.service.monitoring import monitor

    with tempfile.TemporaryDirectory() as tmp:
        config = _config(args.shape, Path(tmp))
    start = time.perf_counter()
    signals = _signals(config, args.days, args.cache)
    print(f"generated {args.days} days of a {args.shape} loop in {time.perf_counter() - start:.1f} s")
    data = PlantData.from_record(signals, source="bench", sample_time_s=60.0, start="2025-01-01T00:00:00+00:00")
    record_mb = sum(values.nbytes for values in signals.values()) / 2**20
    del signals
    start = time.perf_counter()
    with PeakMemory() as memory:
        found = monitor(data, config, window=args.window, step=args.step, jobs=args.jobs)
    wall = time.perf_counter() - start
    mine = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"monitor: {len(found.windows)} windows of {args.window} stepped by {args.step} in {wall:.1f} s")
    print(
        f"CPU time: {memory.cpu_s:.0f} s in all processes ({memory.cpu_s / len(found.windows):.2f} s a window; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores at the end)"
    )
    print(
        f"peak memory: {memory.pss:.0f} MB this process and its workers together (proportional set sizes; "
        f"resident sizes {memory.peak:.0f} MB, shared pages counted in each process; this process alone "
        f"{mine:.0f} MB; the record {record_mb:.0f} MB)"
    )
    (i, k), (j, m) = _elements(config)
    names = config.model.element_names()
    n_in = config.model.n_inputs
    for (row, col), parameter, day in (((i, k), "gain", RAMP_DAY), ((j, m), "delay", STEP_DAY)):
        name = names[row * n_in + col]
        onset = found.onsets[name][parameter]
        print(f"  {name} {parameter}: injected from day {day}; found {onset['kind']} from {onset['onset']}")
    moved = [
        (n, p, e[p]["kind"])
        for n, e in found.onsets.items()
        for p in ("gain", "tau", "delay")
        if e[p]["kind"] in ("step", "drift")
    ]
    print(f"  every parameter found moving: {moved}")


def _fleet_folder(folder: Path, controllers: int, days: int) -> Path:
    shapes = ("2x2", "2x4", "3x3", "4x4", "4x8")
    entries = []
    for index in range(controllers):
        shape = shapes[index % len(shapes)]
        config = _config(shape, folder, seed=index)
        changes = ()
        if index in (3, 11):  # the two drifting controllers: the first output's own gain +25 %
            (i, k), _ = _elements(config)
            changes = (Change(i, k, "gain", day=0, size=25.0),)
        signals = drifting_signals(config, days=days, changes=changes, seed=index)
        _write_export(folder / f"c{index}.csv", signals, config)
        params = f"{config.model.name}.yaml"  # written by bench_scale.load
        entries.append({"name": f"C{index:02d}_{shape}", "params": params, "data": f"c{index}.csv"})
    (folder / "fleet.yaml").write_text(json.dumps({"controllers": entries}))
    return folder / "fleet.yaml"


def _write_export(path: Path, signals: dict[str, np.ndarray], config) -> None:
    import pandas as pd

    stamps = pd.Timestamp("2025-03-01", tz="UTC") + pd.to_timedelta(60.0 * np.arange(signals["y"].shape[0]), "s")
    frame = pd.DataFrame({"time": stamps.strftime("%Y-%m-%dT%H:%M:%SZ")})
    model = config.model
    channels = [("r", model.output_names), ("u", model.input_names), ("y", model.output_names)]
    if "dither" in signals:
        channels.append(("dither", model.input_names))
    for signal, names in channels:
        for j, channel in enumerate(names):
            frame[f"{signal[0] if signal == 'dither' else signal}_{channel}"] = signals[signal][:, j]
    frame.to_csv(path, index=False)


def fleet(args: argparse.Namespace) -> None:
    from pmr_ros.service.fleet import read_fleet, run_fleet

    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        entries = read_fleet(_fleet_folder(Path(tmp), args.controllers, args.days))
        print(f"generated {args.controllers} controllers in {time.perf_counter() - start:.1f} s")
        start = time.perf_counter()
        rows, _ = run_fleet(entries, jobs=args.jobs)
        print(f"fleet locally ({args.jobs or 'all'} processes): {time.perf_counter() - start:.1f} s")
        top = sorted({row["controller"] for row in rows[:2]})
        first = [(r["controller"], r["element"], r["verdict"]) for r in rows[:3]]
        print(f"  ranked first: {first}; the two drifting first: {top == ['C03_4x4', 'C11_2x4']}")
        if args.dask:
            import logging

            from distributed import LocalCluster

            with LocalCluster(
                n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=logging.ERROR
            ) as cluster:
                start = time.perf_counter()
                remote, _ = run_fleet(entries, scheduler=cluster.scheduler_address)
                print(f"fleet on a local Dask cluster (2 workers): {time.perf_counter() - start:.1f} s")
            same = [(r["controller"], r["element"], r["verdict"]) for r in remote] == [
                (r["controller"], r["element"], r["verdict"]) for r in rows
            ]
            print(f"  the same summary as locally: {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    y = sub.add_parser("year")
    y.add_argument("--days", type=int, default=365)
    y.add_argument("--shape", default="4x8")
    y.add_argument("--window", default="14d")
    y.add_argument("--step", default="1d")
    y.add_argument("--jobs", type=int, default=None)
    y.add_argument("--cache", type=Path, default=None)
    f = sub.add_parser("fleet")
    f.add_argument("--controllers", type=int, default=20)
    f.add_argument("--days", type=int, default=4)
    f.add_argument("--jobs", type=int, default=None)
    f.add_argument("--dask", action="store_true")
    args = parser.parse_args()
    year(args) if args.what == "year" else fleet(args)


if __name__ == "__main__":
    main()
