"""Read and write step-response curves as CSV: one column per output-input pair, one row per sample.

The layout (docs/models.md)::

    time, x_D | reflux, x_D | steam, x_B | reflux, x_B | steam
    ramp, 0, 0, 0, 0
    1.0, 0.0, 0.0, 0.0, 0.0
    2.0, 0.744, 0.0, 0.0, 0.0
    ...

* the header: ``time``, then ``OUTPUT|INPUT`` per pair (outputs and inputs in
  the order they first appear; a pair without a column has no model);
* the ``ramp`` row: 1 where the pair is a ramp (integrating) curve, else 0;
* one row per coefficient k = 1..N: the time ``k Ts`` [time unit] and
  ``s_k`` of every pair.  Numbers are written with ``repr``: lossless.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from .curve_set import CurveSet, ModelFileError, curve_gains

__all__ = ["SEPARATOR", "csv_text", "read_csv_curves", "write_csv_curves"]

SEPARATOR = "|"
"""Between the output and the input name of a column."""


def _pairs(path: Path, header: list[str]) -> tuple[list[str], list[str], list[tuple[int, int]]]:
    if not header or header[0].strip() != "time":
        raise ModelFileError(f"{path} line 1: the first column must be 'time', got {header[:1]}")
    outputs: list[str] = []
    inputs: list[str] = []
    pairs = []
    for column in header[1:]:
        out, sep, inp = column.strip().partition(SEPARATOR)
        if not sep or not out or not inp:
            raise ModelFileError(f"{path} line 1: column {column!r} must be OUTPUT{SEPARATOR}INPUT")
        outputs += [out] if out not in outputs else []
        inputs += [inp] if inp not in inputs else []
        pairs.append((outputs.index(out), inputs.index(inp)))
    if len(set(pairs)) != len(pairs):
        raise ModelFileError(f"{path} line 1: a pair has two columns")
    return outputs, inputs, pairs


def _numbers(path: Path, rows: list[list[str]], width: int) -> np.ndarray:
    out = np.empty((len(rows), width))
    for r, row in enumerate(rows):
        if len(row) != width:
            raise ModelFileError(f"{path} line {r + 3}: {len(row)} cells, the header has {width}")
        try:
            out[r] = [float(cell) for cell in row]
        except ValueError:
            raise ModelFileError(f"{path} line {r + 3}: not all numbers: {','.join(row)}") from None
    if not np.all(np.isfinite(out)):
        raise ModelFileError(f"{path}: every cell must be a finite number")
    return out


def _sample_time(path: Path, times: np.ndarray) -> float:
    ts = float(times[0])
    bad = np.flatnonzero(np.abs(times - ts * np.arange(1, times.size + 1)) > 1e-6 * ts)
    if not ts > 0 or bad.size:
        r = int(bad[0]) if bad.size else 0
        raise ModelFileError(f"{path} line {r + 3}: time {times[r]:g} must be {r + 1} x the sample time {ts:g} (> 0)")
    return ts


def read_csv_curves(path: str | Path, *, text: str | None = None) -> CurveSet:
    """The curves of a CSV file in the layout of this module (or of its ``text``, ``path`` then only named).

    Raises
    ------
    ModelFileError
        One line naming the file, the line and what is wrong.
    """
    path = Path(path)
    try:
        rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8") if text is None else text)))
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    rows = [row for row in rows if row]
    outputs, inputs, pairs = _pairs(path, rows[0] if rows else [])
    if len(rows) < 3 or rows[1][0].strip() != "ramp":
        raise ModelFileError(f"{path} line 2: the second row must be the ramp flags ('ramp,0,1,...'), then the curves")
    flags = _numbers(path, [["0", *rows[1][1:]]], len(rows[0]))[0, 1:]
    if not np.all(np.isin(flags, (0.0, 1.0))):
        raise ModelFileError(f"{path} line 2: ramp flags must be 0 or 1")
    table = _numbers(path, rows[2:], len(rows[0]))
    ts = _sample_time(path, table[:, 0])
    curves = np.zeros((len(outputs), len(inputs), table.shape[0]))
    ramp = np.zeros((len(outputs), len(inputs)), dtype=bool)
    for column, (i, k) in enumerate(pairs, start=1):
        curves[i, k] = table[:, column]
        ramp[i, k] = flags[column - 1] == 1.0
    return CurveSet(ts, tuple(outputs), tuple(inputs), curves, ramp, curve_gains(curves, ramp, ts))


def csv_text(curves: CurveSet) -> str:
    """The CSV text of ``curves``, every pair a column (see the module's layout)."""
    for name in (*curves.output_names, *curves.input_names):
        if SEPARATOR in name or "," in name:
            raise ModelFileError(f"name {name!r} cannot be a CSV column part: it holds {SEPARATOR!r} or ','")
    names = [(i, k) for i in range(len(curves.output_names)) for k in range(len(curves.input_names))]
    header = ["time"] + [f"{curves.output_names[i]}{SEPARATOR}{curves.input_names[k]}" for i, k in names]
    lines = [",".join(header), ",".join(["ramp"] + [str(int(curves.ramp[i, k])) for i, k in names])]
    for j in range(curves.n_coefficients):
        row = [repr((j + 1) * curves.sample_time)] + [repr(float(curves.curves[i, k, j])) for i, k in names]
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def write_csv_curves(curves: CurveSet, path: str | Path) -> None:
    """Write ``curves`` as CSV (see :func:`csv_text`).

    Raises
    ------
    ModelFileError
        The file cannot be written, or a name would break the layout.
    """
    text = csv_text(curves)
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot write: {exc.strerror or exc}") from None
