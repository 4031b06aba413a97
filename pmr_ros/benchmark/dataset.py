"""The exported dataset: each run's r, u, y as Parquet, the models, the labels, a schema; read with pandas alone.

Layout of an export folder (:data:`SCHEMA` is written beside it as ``SCHEMA.md``)::

    runs/run_00001.parquet   one per run: k, r_<output>, u_<input>, y_<output> (dither_<input> where the unit dithers)
    models/<unit>.parquet    the controller's model: one row per modelled element
    labels.csv               the injected truth: the scenario file's lines of the exported runs
    runs.csv                 one line per run: run, unit, samples, disturbance, seed, quick
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.records import Record
from ..core.sim.model import TransferMatrix
from ..outputs import replacing, write_text

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["SCHEMA", "model_table", "read_run", "run_file", "write_labels", "write_model", "write_run"]

SCHEMA = """# pmr_ros benchmark dataset

Closed-loop records of MPC-controlled units with an injected model-plant mismatch, labelled
per element, written by `pmr-ros benchmark --export DIR` (see docs/benchmark.md of pmr_ros).
Every file reads with pandas alone (`pandas.read_parquet`, `pandas.read_csv`).

## runs/run_NNNNN.parquet (one per run, NNNNN its number)

| column | meaning |
|---|---|
| `k` | sample number, 0 .. samples - 1 (one sample time apart, see the model) |
| `r_<output>` | setpoint of the output (a PRBS; in a `*_routine` unit rare operator steps) [output unit] |
| `u_<input>` | manipulated variable the MPC sent (its dither included) [input unit] |
| `y_<output>` | measured output (noise and, where the run has it, the coloured disturbance included) [output unit] |
| `dither_<input>` | the known MV dither added to u (units that dither only) [input unit] |

## models/<unit>.parquet (the controller's model: what the method is given)

| column | meaning |
|---|---|
| `element` | `G11` style name (`G1_10` beyond 9 outputs or inputs) |
| `row`, `column` | zero-based output i and input k |
| `output`, `input` | their names (the suffixes of `y_`, `u_` in the runs) |
| `kind` | `foptd`: K exp(-theta s) / (tau s + 1); `integrating`: K exp(-theta s) / s |
| `gain` | K [output unit / input unit, per time unit for integrating] |
| `time_constant` | tau [time unit]; 0 for integrating |
| `delay_samples` | theta / sample_time [samples] |
| `sample_time` | [time unit] |

The true plant of a run is this model with each element's K x (1 + gain_pct / 100),
tau x (1 + tau_pct / 100), delay + delay_samples, from labels.csv. Elements absent are empty cells.

## labels.csv (the truth; one line per run and modelled element)

`run, unit, samples, disturbance (0/1: coloured output disturbance), seed, quick (the --quick subset),
element, row, column, gain_pct, tau_pct, delay_samples`. An element is mismatched when any of
gain_pct, tau_pct, delay_samples is non-zero.

## runs.csv

`run, unit, samples, disturbance, seed, quick`, one line per run.
"""


def run_file(folder: str | Path, run: int) -> Path:
    """``folder/runs/run_NNNNN.parquet``."""
    return Path(folder) / "runs" / f"run_{run:05d}.parquet"


def write_run(folder: str | Path, run: int, record: Record, model: TransferMatrix) -> Path:
    """Write one run's record as Parquet (columns of :data:`SCHEMA`); the path written."""
    import pandas as pd

    columns: dict[str, np.ndarray] = {"k": np.arange(record.y.shape[0])}
    for prefix, data, names in (
        ("r", record.r, model.output_names),
        ("u", record.u, model.input_names),
        ("y", record.y, model.output_names),
        ("dither", record.dither, model.input_names),
    ):
        if data is not None:
            columns.update({f"{prefix}_{name}": data[:, j] for j, name in enumerate(names)})
    path = run_file(folder, run)
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:
        pd.DataFrame(columns).to_parquet(tmp, index=False)
    return path


def read_run(folder: str | Path, run: int) -> dict[str, pd.DataFrame]:
    """One exported run as ``{"r": ..., "u": ..., "y": ...}`` frames (columns: the names), pandas alone."""
    import pandas as pd

    table = pd.read_parquet(run_file(folder, run))
    out = {}
    for prefix in ("r", "u", "y"):
        chosen = [c for c in table.columns if c.startswith(f"{prefix}_")]
        out[prefix] = table[chosen].rename(columns=lambda c, p=prefix: c[len(p) + 1 :])
    return out


def model_table(model: TransferMatrix) -> pd.DataFrame:
    """The model's modelled elements, one row each (columns of :data:`SCHEMA`)."""
    import pandas as pd

    names = model.element_names()
    rows = []
    for i, k in zip(*np.nonzero(model.present), strict=True):
        integrating = bool(model.integrating[i, k])
        rows.append(
            {
                "element": names[i * model.n_inputs + k],
                "row": int(i), "column": int(k),
                "output": model.output_names[i], "input": model.input_names[k],
                "kind": "integrating" if integrating else "foptd",
                "gain": float(model.gain[i, k]),
                "time_constant": 0.0 if integrating else float(model.time_constant[i, k]),
                "delay_samples": float(model.delay[i, k] / model.sample_time),
                "sample_time": float(model.sample_time),
            }
        )  # fmt: skip
    return pd.DataFrame(rows)


def write_model(folder: str | Path, unit: str, model: TransferMatrix) -> None:
    """``folder/models/<unit>.parquet``."""
    path = Path(folder) / "models" / f"{unit}.parquet"
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:
        model_table(model).to_parquet(tmp, index=False)


def write_labels(folder: str | Path, labels: pd.DataFrame, runs: pd.DataFrame) -> None:
    """``labels.csv``, ``runs.csv`` and ``SCHEMA.md`` of the export."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_text(folder / "labels.csv", labels.to_csv(index=False))
    write_text(folder / "runs.csv", runs.to_csv(index=False))
    write_text(folder / "SCHEMA.md", SCHEMA)
