"""The benchmark's labelled runs: the rule that draws them, and the scenario file it wrote once.

The rule (:func:`draw_scenarios`), fixed by :data:`RULE_SEED`:

* cells: every unit of :func:`~pmr_ros.benchmark.units.all_units` (the four units with their
  PRBS setpoints, then the routine-operation variants: rare setpoint steps and MV dither) x the coloured
  output disturbance off / on x every record length of :data:`LENGTHS`;
  :data:`RUNS_PER_CELL` runs per cell, numbered from 1 in that order; a run's
  ``seed`` (noise, disturbance and PRBS phases) is its number;
* per modelled element of the run's unit, drawn from ``default_rng([RULE_SEED, run])``:
  no mismatch with probability :data:`P_NONE`, else all three of
  dK = +/-U[5, 30] %, dtau = +/-U[5, 40] % (0 on an integrating element, which has
  no time constant) and dD = +/-{1, 2, 3} samples (made positive where the
  model's delay would turn negative), each sign drawn on its own;
* ``quick`` marks the ``--quick`` subset: the first run of each Wood-Berry cell up to 4,096 samples.

The file (``config/benchmark_scenarios.csv``, :data:`COLUMNS`) holds one line
per (run, modelled element); ``python -m pmr_ros.benchmark.scenarios FILE``
writes it again, and a test checks that the committed file is what the rule draws.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..resources import share_dir
from .units import all_units, unit_config

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = [
    "COLUMNS",
    "LENGTHS",
    "RULE_SEED",
    "RUNS_PER_CELL",
    "SCENARIO_FILE",
    "draw_scenarios",
    "read_scenarios",
    "run_table",
    "truth_arrays",
]

RULE_SEED = 26
"""Seeds every draw of the rule (issue 26)."""

LENGTHS = (2048, 4096, 8192, 16384, 32768)
"""Record lengths [samples]."""

RUNS_PER_CELL = 26
"""Runs per (unit, disturbance, length): (4 + 2) x 2 x 5 x 26 = 1,560 runs (1,040 with PRBS setpoints first)."""

P_NONE = 0.5
"""Probability that an element has no mismatch."""

QUICK_LENGTH = 4096
"""``--quick``: Wood-Berry cells up to this length, their first run."""

SCENARIO_FILE = "benchmark_scenarios.csv"
"""The committed scenario file, in ``config/``."""

COLUMNS = (
    "run", "unit", "samples", "disturbance", "seed", "quick",
    "element", "row", "column", "gain_pct", "tau_pct", "delay_samples",
)  # fmt: skip
"""One line per (run, modelled element): the run's cell and seed, the element and its injected truth."""


def _element_draws(rng: np.random.Generator, integrating: bool, model_delay: int) -> tuple[float, float, int]:
    """One element's ``(dK %, dtau %, dD)`` by the rule (zeros when it draws no mismatch)."""
    if rng.random() < P_NONE:
        return 0.0, 0.0, 0
    signs = rng.choice([-1.0, 1.0], 3)
    gain = signs[0] * rng.uniform(5.0, 30.0)
    tau = signs[1] * rng.uniform(5.0, 40.0)
    delay = int(signs[2]) * int(rng.integers(1, 4))
    if model_delay + delay < 0:
        delay = -delay
    return round(gain, 2), 0.0 if integrating else round(tau, 2), delay


def _unit_rows(unit: str, run: int, cell: dict) -> list[dict]:
    model = unit_config(unit).model
    delays = np.rint(model.delay / model.sample_time).astype(int)
    rng = np.random.default_rng([RULE_SEED, run])
    names = model.element_names()
    rows = []
    for i, k in zip(*np.nonzero(model.present), strict=True):
        gain, tau, delay = _element_draws(rng, bool(model.integrating[i, k]), int(delays[i, k]))
        rows.append(
            {
                **cell,
                "element": names[i * model.n_inputs + k],
                "row": int(i),
                "column": int(k),
                "gain_pct": gain,
                "tau_pct": tau,
                "delay_samples": delay,
            }
        )
    return rows


def draw_scenarios() -> pd.DataFrame:
    """Every labelled run by the rule of this module, :data:`COLUMNS`, one line per (run, modelled element)."""
    import pandas as pd

    rows: list[dict] = []
    run = 0
    for unit in all_units():
        for disturbance in (0, 1):
            for samples in LENGTHS:
                for index in range(RUNS_PER_CELL):
                    run += 1
                    quick = int(unit == "wood_berry" and samples <= QUICK_LENGTH and index == 0)
                    cell = {"run": run, "unit": unit, "samples": samples, "disturbance": disturbance}
                    rows += _unit_rows(unit, run, {**cell, "seed": run, "quick": quick})
    return pd.DataFrame(rows, columns=list(COLUMNS))


def read_scenarios(path: str | Path | None = None) -> pd.DataFrame:
    """The scenario file (default: the shipped ``config/benchmark_scenarios.csv``).

    Raises
    ------
    ValueError
        A column of :data:`COLUMNS` is missing, naming the file and the column.
    """
    import pandas as pd

    path = Path(path) if path is not None else share_dir("config", SCENARIO_FILE) / SCENARIO_FILE
    table = pd.read_csv(path)
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"{path}: no column {missing[0]!r} (a scenario file has {', '.join(COLUMNS)})")
    return table


def run_table(scenarios: pd.DataFrame) -> pd.DataFrame:
    """One line per run: run, unit, samples, disturbance, seed, quick (in run order)."""
    keys = ["run", "unit", "samples", "disturbance", "seed", "quick"]
    return scenarios[keys].drop_duplicates("run").sort_values("run").reset_index(drop=True)


def truth_arrays(unit: str, lines: pd.DataFrame) -> dict[str, np.ndarray]:
    """A run's lines as full ``gain_pct``, ``tau_pct``, ``delay_samples`` arrays (n_outputs x n_inputs)."""
    model = unit_config(unit).model
    shape = (model.n_outputs, model.n_inputs)
    out = {"gain_pct": np.zeros(shape), "tau_pct": np.zeros(shape), "delay_samples": np.zeros(shape, dtype=int)}
    rows, columns = lines["row"].to_numpy(int), lines["column"].to_numpy(int)
    for key, values in out.items():
        values[rows, columns] = lines[key].to_numpy(values.dtype)
    return out


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else share_dir("config", "wood_berry.yaml") / SCENARIO_FILE
    draw_scenarios().to_csv(target, index=False)
    print(f"wrote {target}")
