"""Reading large params files (a script, not a test).

    .venv/bin/python benchmarks/bench_config.py [--repeats N]

Times ``pmr_ros.config.load_config`` (read, parse once, check every value, build
the model) on valid params files of about 1 MB and 10 MB in three shapes:

* ``system``: a square system whose matrices make the size (170 x 170 and
  540 x 540 elements, six significant digits per number);
* ``wide``: 50 MVs and as many CVs as make the size (the industrial shape);
* ``comments``: the Wood-Berry file under a long commented header.

Beside each: PyYAML's C safe loader alone on the same text, for reference.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from pmr_ros.config import config_dir, load_config


def _system(n_out: int, n_in: int) -> str:
    rng = np.random.default_rng(0)
    size = n_out * n_in

    def numbers(values) -> str:
        return ", ".join(f"{x:.6g}" for x in values)

    return (
        "/**:\n  ros__parameters:\n    system:\n      name: big\n      sample_time: 1.0\n"
        f"      output_names: [{', '.join(f'cv{i}' for i in range(n_out))}]\n"
        f"      input_names: [{', '.join(f'mv{i}' for i in range(n_in))}]\n"
        f"      gain: [{numbers(rng.uniform(0.5, 2.0, size))}]\n"
        f"      time_constant: [{numbers(rng.uniform(5.0, 20.0, size))}]\n"
        f"      delay: [{', '.join(f'{d}.0' for d in rng.integers(0, 5, size))}]\n"
        "    mpc:\n      prediction_horizon: 40\n"
    )


def _comments(megabytes: float) -> str:
    line = "# " + "x" * 76 + "\n"
    return line * int(megabytes * 1e6 / len(line)) + (config_dir() / "wood_berry.yaml").read_text()


def files(megabytes: float) -> dict[str, str]:
    """The three shapes of about ``megabytes`` MB each."""
    square = int(round(205 * megabytes**0.5))
    wide = int(round(megabytes * 1e6 / (50 * 3 * 8.5)))
    return {"system": _system(square, square), "wide": _system(wide, 50), "comments": _comments(megabytes)}


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
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    print(f"{'file':22s} {'size':>8s} {'load_config':>12s} {'PyYAML C loader alone':>22s}")
    with tempfile.TemporaryDirectory() as folder:
        for megabytes in (1.0, 10.0):
            for shape, text in files(megabytes).items():
                path = Path(folder) / f"{shape}_{megabytes:g}MB.yaml"
                path.write_text(text)
                mine = best_of(args.repeats, lambda p=path: load_config(p))
                plain = best_of(1, lambda t=text: yaml.load(t, Loader=loader))  # noqa: S506 - a safe loader
                print(f"{path.name:22s} {len(text) / 1e6:6.2f} MB {mine:10.2f} s {plain:20.2f} s")


if __name__ == "__main__":
    main()
