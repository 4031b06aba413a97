"""The sweep's record-level CSV: one row per method, point, scenario, seed and element.

Rows of one sweep point are appended in one write and flushed, so an
interrupted sweep keeps every finished point; a torn last line (a killed
process) is dropped when the file is read back.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
from collections.abc import Iterable
from pathlib import Path

from ..core.results.codec import CSV_FIELDS, CSV_TYPES
from ..outputs import write_text

COLUMNS = (
    "method",
    "sweep",
    "element_swept",
    "nu",
    "time_constant_swept",
    "row_time_constant_ratio",
    "scenario",
    "seed",
    "samples",
    "prediction_horizon",
    "control_horizon",
    "loop_spectral_radius",
    "mpc_solves",
    "mpc_failures",
    "tracking_rms",
    "element",
    "true_gain_ratio",
    "true_time_constant_pct",
    "true_delay_samples",
    "status",
    *CSV_FIELDS,
)
"""Column order of ``results.csv``.  A method adds rows (``method``); the result columns are the codec's
:data:`~pmr_ros.core.results.codec.CSV_FIELDS` (each method fills its own, the other's stay empty)."""

RESULTS_FILE = "results.csv"
MANIFEST_FILE = "sweep.json"

_INT_COLUMNS = {
    "seed",
    "samples",
    "prediction_horizon",
    "control_horizon",
    "mpc_solves",
    "mpc_failures",
    "true_delay_samples",
    *(name for name, kind in CSV_TYPES.items() if kind is int),
}
_TEXT_COLUMNS = {
    "method",
    "sweep",
    "element_swept",
    "scenario",
    "element",
    "status",
    *(name for name, kind in CSV_TYPES.items() if kind is str),
}
_BOOL_COLUMNS = {name for name, kind in CSV_TYPES.items() if kind is bool}
_FLOAT_COLUMNS = set(COLUMNS) - _INT_COLUMNS - _TEXT_COLUMNS - _BOOL_COLUMNS


def _format(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ""
    return str(value)


def _parse(column: str, text: str):
    if text == "":
        return None
    if column in _INT_COLUMNS:
        return int(text)
    if column in _FLOAT_COLUMNS:
        return float(text)
    if column in _BOOL_COLUMNS:
        if text not in ("true", "false"):
            raise ValueError(text)
        return text == "true"
    return text


def append_rows(path: Path, rows: Iterable[dict]) -> None:
    """Append rows (dicts keyed by :data:`COLUMNS`) to ``path``, writing the header if new."""
    new = not path.exists() or path.stat().st_size == 0
    lines = []
    if new:
        lines.append(",".join(COLUMNS))
    for row in rows:
        lines.append(",".join(_format(row.get(c)) for c in COLUMNS))
    with path.open("a", newline="") as fh:
        fh.write("\n".join(lines) + "\n")
        fh.flush()


def read_rows(path: Path) -> list[dict]:
    """The well-formed rows of a results CSV, typed (floats, ints, bools, None for blank)."""
    rows = []
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            return []
        if tuple(header) != COLUMNS:
            raise ValueError(f"{path}: not a pmr-ros sweep CSV (unexpected header)")
        for fields in reader:
            if len(fields) != len(COLUMNS):
                continue  # a torn last line
            try:
                rows.append({c: _parse(c, v) for c, v in zip(COLUMNS, fields, strict=True)})
            except ValueError:
                continue
    return rows


def run_key(row: dict) -> tuple:
    """Identity of one closed-loop run's diagnosis: (method, sweep, nu, scenario, seed)."""
    return (row["method"], row["sweep"], round(float(row["nu"]), 9), row["scenario"], int(row["seed"]))


def complete_rows(rows: list[dict], elements_per_run: int) -> list[dict]:
    """The rows of runs that have all their elements (drops runs torn by a kill)."""
    counts: dict[tuple, int] = {}
    for row in rows:
        key = run_key(row)
        counts[key] = counts.get(key, 0) + 1
    return [row for row in rows if counts[run_key(row)] == elements_per_run]


def rewrite(path: Path, rows: list[dict]) -> None:
    """Replace ``path`` by exactly ``rows`` (via a temporary file)."""
    tmp = path.with_suffix(".tmp")
    if tmp.exists():
        tmp.unlink()
    append_rows(tmp, rows)
    tmp.replace(path)


def config_fingerprint(parameters: dict) -> str:
    """A stable hash of a configuration's parameters: a resumed sweep must use the same."""
    text = json.dumps(parameters, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def write_manifest(folder: Path, manifest: dict) -> None:
    """Write the sweep's manifest (its plan and configuration hash) into ``folder``."""
    write_text(folder / MANIFEST_FILE, json.dumps(manifest, indent=2, sort_keys=True) + "\n")


def read_manifest(folder: Path) -> dict | None:
    """The manifest of the sweep in ``folder``, or None when there is none."""
    path = folder / MANIFEST_FILE
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None
