"""Bag throughput and offline diagnosis time (a script, not a test).

    .venv/bin/python benchmarks/bench_bags.py [--messages N]

* write: messages/s of :class:`pmr_ros.bag.writer.BagWriter` writing the
  reference bag's CDR messages again (MCAP and sqlite3, default flush period);
* read: messages/s of :func:`pmr_ros.bag.reader.open_bag` + iterating (and
  decoding) every message of the reference bag;
* diagnose: wall time of the offline diagnosis of the reference bag
  (open, decode 24576 signal messages, align, diagnose the 8192-sample window).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.writer import BagWriter
from pmr_ros.service.bag_diagnosis import diagnose_bag

REFERENCE = Path(__file__).resolve().parents[1] / "bags" / "wood_berry_full"


def best_of(repeats: int, run) -> float:
    """Shortest wall time of ``repeats`` calls [s]."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    bag = open_bag(REFERENCE)
    messages = list(bag.messages())
    n = len(messages)
    print(
        f"reference bag: {REFERENCE} ({n} messages, {sum(f.stat().st_size for f in REFERENCE.iterdir()) / 2**20:.1f} "
        "MiB)"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for storage in ("mcap", "sqlite3"):
            counter = iter(range(10**6))

            def write(storage=storage, counter=counter) -> None:
                with BagWriter(Path(tmp) / f"{storage}{next(counter)}", storage=storage) as writer:
                    for m in messages:
                        writer.write_raw(m.topic, m.log_time_ns, m.data)

            t = best_of(args.repeats, write)
            print(f"write {storage:7s}: {n / t:10.0f} msgs/s ({t:.3f} s, flush every 0.5 s)")
            path = Path(tmp) / f"{storage}0"
            t = best_of(args.repeats, lambda path=path: sum(1 for _ in open_bag(path).messages()))
            print(f"read  {storage:7s}: {n / t:10.0f} msgs/s ({t:.3f} s, raw CDR)")
            opened = open_bag(path)
            t = best_of(args.repeats, lambda opened=opened: [opened.decode(m) for m in opened.messages()])
            print(f"read+decode {storage:7s}: {n / t:10.0f} msgs/s ({t:.3f} s, rosbags deserialize_cdr)")
    t = best_of(args.repeats, lambda: diagnose_bag(open_bag(REFERENCE)))
    print(f"offline diagnosis of the reference bag (8192 samples): {t:.3f} s")


if __name__ == "__main__":
    main()
