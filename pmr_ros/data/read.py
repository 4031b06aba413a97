"""Reading a historian export (CSV or Parquet) with pandas / pyarrow: the wanted columns as numbers.

Only the columns the configuration names are read.  Cells equal to one of
``data.bad_values`` (a sentinel such as -9999, a string such as ``Bad``, an
empty cell) and non-finite numbers become missing (NaN) and are counted per
column; any other text in a signal column is refused, every such string of
the file named at once with its count and first row, since guessing what it
means could make a wrong verdict.  Large files are read in
chunks, with a progress callback.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .bad_data import DataError
from .columns import ColumnMap
from .duplicates import check_unique_columns
from .encoding import csv_encoding

__all__ = ["FORMATS", "Progress", "RawTable", "read_table", "table_format"]

FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
"""File suffix to the format read."""

CHUNK_ROWS = 200_000
"""Rows per chunk (CSV) or batch (Parquet): progress steps and bounded memory."""

NAN_TEXT = {"nan", "+nan", "-nan"}
"""Text that spells a non-finite number (``inf`` parses as a number and is caught as non-finite)."""

Progress = Callable[[int, int], None]
"""``progress(done, total)``: bytes (CSV) or rows (Parquet) read so far and in all."""


@dataclass
class RawTable:
    """The wanted columns of a file, values as floats (NaN missing).

    Attributes
    ----------
    path : str
    rows : int
        Data rows read.
    time : pandas.Series
        The time column as read (numbers, text or date-times).
    values : dict
        Signal column to its float values, shape (rows,).
    mode : ndarray of object, shape (rows, n_modes), or None
        The controller-mode columns as read.
    bad : dict
        Column to cells that were a bad value (sentinel, bad string, empty cell, null).
    non_finite : dict
        Column to cells that were NaN or +-inf.
    file_columns : int
        Columns in the file, those read and those ignored.
    """

    path: str
    rows: int
    time: Any
    values: dict[str, np.ndarray]
    mode: np.ndarray | None = None
    bad: dict[str, int] = field(default_factory=dict)
    non_finite: dict[str, int] = field(default_factory=dict)
    file_columns: int = 0


def table_format(path: str | Path) -> str | None:
    """``csv`` or ``parquet`` for a file with a suffix of :data:`FORMATS`, else None."""
    return FORMATS.get(Path(path).suffix.lower())


def _pandas(path: str | Path) -> Any:
    try:
        import pandas
    except ImportError:
        raise DataError(
            path, "", "reading CSV or Parquet needs pandas and pyarrow: pip install 'pmr_ros[data]'"
        ) from None
    return pandas


def read_table(
    path: str | Path, columns: ColumnMap, bad_values: Sequence[float | str], *, progress: Progress | None = None
) -> RawTable:
    """Read the columns of ``columns`` from a CSV or Parquet file.

    Parameters
    ----------
    path : str or Path
    columns : ColumnMap
        What to read; every column must be in the file.
    bad_values : sequence of float or str
        Cells equal to one of these are missing.
    progress : callable, optional
        Called after each chunk (see :data:`Progress`).

    Raises
    ------
    DataError
        Not a readable CSV/Parquet file, a column missing, text that is no
        number nor a bad value, no data rows, a signal column without one valid value.
    """
    path = Path(path)
    kind = table_format(path)
    if kind is None:
        raise DataError(path, "", f"not a CSV or Parquet file (suffix {path.suffix or 'none'!r}; use .csv or .parquet)")
    if not path.is_file():
        raise DataError(path, "", "no such file")
    cells = _BadCells(bad_values)
    reader = _read_csv if kind == "csv" else _read_parquet
    table = reader(path, columns, cells, progress)
    if table.rows == 0:
        raise DataError(path, "", "holds no data rows")
    for column, values in table.values.items():
        if not np.isfinite(values).any():
            raise DataError(
                path,
                f"column {column!r} ({columns.origin(column)})",
                f"holds no valid value: all {table.rows} rows are missing, bad or non-finite",
            )
    return table


@dataclass(frozen=True)
class _BadCells:
    """The bad values split into numbers and strings."""

    values: Sequence[float | str]

    @property
    def numbers(self) -> list[float]:
        return [float(v) for v in self.values if not isinstance(v, str)]

    @property
    def strings(self) -> list[str]:
        return [v for v in self.values if isinstance(v, str)]


class _Columns:
    """Accumulates the float values and counts of the signal columns, chunk by chunk."""

    def __init__(self, path: Path, columns: ColumnMap, cells: _BadCells) -> None:
        self.path, self.columns, self.cells = path, columns, cells
        self.parts: dict[str, list[np.ndarray]] = {c: [] for c in columns.value_columns}
        self.bad = dict.fromkeys(columns.value_columns, 0)
        self.non_finite = dict.fromkeys(columns.value_columns, 0)
        self.times: list[Any] = []
        self.modes: list[np.ndarray] = []
        self.rows = 0
        self.strings: dict[str, dict[str, list[int]]] = {}  # column -> non-numeric text -> its rows (1-based)
        self.file_columns = 0

    def take(self, frame: Any) -> None:
        """One chunk (a pandas DataFrame of the wanted columns)."""
        for column in self.columns.value_columns:
            self.parts[column].append(self._numbers(frame[column], column))
        self.times.append(frame[self.columns.time])
        if self.columns.modes:
            self.modes.append(frame[list(self.columns.modes)].to_numpy(dtype=object))
        self.rows += len(frame)

    def _numbers(self, series: Any, column: str) -> np.ndarray:
        pd = _pandas(self.path)
        if pd.api.types.is_bool_dtype(series.dtype) or pd.api.types.is_numeric_dtype(series.dtype):
            # a copy: under pandas 3's copy-on-write to_numpy may return a read-only view of the frame
            x = series.to_numpy(dtype=float, na_value=np.nan, copy=True)
            bad = np.isnan(x) | np.isin(x, self.cells.numbers)
        elif pd.api.types.is_object_dtype(series.dtype) or pd.api.types.is_string_dtype(series.dtype):
            x, bad = self._text(series, column)
        else:
            raise DataError(self.path, f"column {column!r}", f"holds {series.dtype} values, not numbers")
        non_finite = ~bad & ~np.isfinite(x)
        self.bad[column] += int(bad.sum())
        self.non_finite[column] += int(non_finite.sum())
        x[bad | non_finite] = np.nan
        return x

    def _text(self, series: Any, column: str) -> tuple[np.ndarray, np.ndarray]:
        """Numbers from a column with text in it; text that is no number nor a bad value is refused."""
        pd = _pandas(self.path)
        null = series.isna().to_numpy()
        text = series.astype(str).str.strip()
        bad = null | text.isin(self.cells.strings).to_numpy()
        x = pd.to_numeric(text.where(~bad, "nan"), errors="coerce").to_numpy(dtype=float, copy=True)
        bad |= np.isin(x, self.cells.numbers)
        unparsed = np.isnan(x) & ~bad & ~text.str.lower().isin(NAN_TEXT).to_numpy()
        for j in np.flatnonzero(unparsed):  # every one counted: the whole file is read before it is refused
            self.strings.setdefault(column, {}).setdefault(text.iloc[j], []).append(self.rows + int(j) + 1)
        return x, bad

    def refuse_strings(self) -> None:
        """Refuse the file when a signal column held text that is no number nor a bad value, naming every string.

        Raises
        ------
        DataError
            One line: per column, its distinct strings with their counts and first rows.
        """
        if not self.strings:
            return
        parts = [
            f"column {column!r} ({self.columns.origin(column)}): {_strings_text(found)}"
            for column, found in self.strings.items()
        ]
        raise DataError(
            self.path,
            "; ".join(parts),
            "not numbers nor data.bad_values (add them there to read them as missing)",
        )

    def table(self) -> RawTable:
        pd = _pandas(self.path)
        values = {c: np.concatenate(p) if p else np.empty(0) for c, p in self.parts.items()}
        time = pd.concat(self.times, ignore_index=True) if self.times else pd.Series([], dtype=object)
        mode = np.concatenate(self.modes) if self.modes else None
        return RawTable(str(self.path), self.rows, time, values, mode, self.bad, self.non_finite, self.file_columns)


STRINGS_SHOWN = 10
"""Distinct non-numeric strings named per column; the others are counted."""


def _strings_text(found: dict[str, list[int]]) -> str:
    """``3 non-numeric strings: 'I/O Timeout' ×12 (first row 57), 'Bad Input' ×3 (first row 880), ...``."""
    ranked = sorted(found.items(), key=lambda item: (-len(item[1]), item[1][0]))
    shown = [f"{_shorten(text)!r} ×{len(rows)} (first row {rows[0]})" for text, rows in ranked[:STRINGS_SHOWN]]
    more = f" and {len(ranked) - STRINGS_SHOWN} more" if len(ranked) > STRINGS_SHOWN else ""
    kinds = f"{len(found)} non-numeric string{'s' if len(found) > 1 else ''}"
    return f"{kinds}: {', '.join(shown)}{more}"


def _shorten(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _separator(path: Path) -> tuple[str, str]:
    """The CSV field separator (the most frequent of , ; and tab in the header line) and the encoding."""
    with path.open("rb") as handle:
        head = handle.read(65536)
    encoding = csv_encoding(head, path)
    first = head.decode(encoding, errors="ignore").split("\n", 1)[0]
    counts = {sep: first.count(sep) for sep in (",", ";", "\t")}
    return max(counts, key=lambda sep: counts[sep]), encoding


def _read_csv(path: Path, columns: ColumnMap, cells: _BadCells, progress: Progress | None) -> RawTable:
    pd = _pandas(path)
    sep, encoding = _separator(path)
    options = {"sep": sep, "encoding": encoding, "keep_default_na": False, "na_values": cells.strings}
    try:
        header = list(pd.read_csv(path, nrows=0, **options).columns)
        columns.check(header, path)
        total = path.stat().st_size
        out = _Columns(path, columns, cells)
        out.file_columns = len(header)
        with path.open("rb") as handle:
            for chunk in pd.read_csv(handle, usecols=columns.all, chunksize=CHUNK_ROWS, **options):
                out.take(chunk)
                if progress is not None:
                    progress(min(handle.tell(), total), total)
        out.refuse_strings()
    except UnicodeDecodeError as exc:
        raise DataError(
            path,
            "",
            f"not {encoding.upper().removesuffix('-SIG')} text ({exc.reason} at byte {exc.start}); "
            "save the export as UTF-8",
        ) from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        if isinstance(exc, DataError):
            raise
        raise DataError(path, "", f"not a readable CSV file: {' '.join(str(exc).split())}") from None
    return out.table()


def _read_parquet(path: Path, columns: ColumnMap, cells: _BadCells, progress: Progress | None) -> RawTable:
    _pandas(path)
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise DataError(path, "", "reading Parquet needs pyarrow: pip install 'pmr_ros[data]'") from None
    with path.open("rb") as handle:
        if handle.read(4) != b"PAR1":
            raise DataError(path, "", "not a Parquet file (it does not start with PAR1)")
    try:
        parquet = pq.ParquetFile(path)
        check_unique_columns(parquet.schema_arrow.names, path)
        columns.check(parquet.schema_arrow.names, path)
        total = parquet.metadata.num_rows
        out = _Columns(path, columns, cells)
        out.file_columns = len(parquet.schema_arrow.names)
        for batch in parquet.iter_batches(batch_size=CHUNK_ROWS, columns=columns.all):
            out.take(batch.to_pandas())
            if progress is not None:
                progress(out.rows, total)
        out.refuse_strings()
    except DataError:
        raise
    except Exception as exc:  # pyarrow's errors (ArrowInvalid, OSError ...) share no base class worth naming
        raise DataError(path, "", f"not a readable Parquet file: {' '.join(str(exc).split())}") from None
    return out.table()
