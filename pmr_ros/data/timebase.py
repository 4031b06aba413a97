"""Time stamps of a historian export: parsed (ISO 8601 or seconds) and placed on the sample grid.

The grid is ``t0 + k Ts``.  A stamp within ``data.grid_tolerance`` samples of
a grid point is moved onto it (a historian's jitter); a stamp farther off, a
stamp earlier than the one before, or two rows on one grid point with
different values are refused with the row: the export is not sampled at the
model's sample time, and no resampling can make it so without inventing data.
Grid points no row falls on are missing samples (a gap).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .bad_data import NO_VALUE, DataError

__all__ = ["Grid", "parse_time", "place_on_grid"]


@dataclass(frozen=True)
class ParsedTime:
    """Time stamps in seconds.

    Attributes
    ----------
    seconds : ndarray of float
        Seconds since the first row's stamp.
    start : str
        The first stamp as read (ISO text, or the number of seconds).
    iso : bool
        Whether the stamps were date-times.
    assumed_zone : str
        The zone stamps written without one were taken in (``UTC`` or ``data.timezone``); "" when they had one.
    """

    seconds: np.ndarray
    start: str
    iso: bool
    assumed_zone: str = ""


def _bad_stamp(path: str | Path, column: str, row: int, value: Any, reason: str) -> DataError:
    """A :class:`DataError` naming the time column and the (1-based) row."""
    return DataError(path, f"column {column!r} (data.time_column), row {row + 1}", reason, value)


def parse_time(raw: Any, time_format: str, *, path: str | Path, column: str, timezone: str = "") -> ParsedTime:
    """The time column as seconds.

    Parameters
    ----------
    raw : pandas.Series
        The column as read.
    time_format : str
        ``iso``, ``seconds``, ``detected`` (numbers: seconds; else ISO 8601)
        or a strptime pattern (``%d-%b-%y %H:%M:%S``).
    timezone : str, optional
        The zone of date-times written without one (IANA name); "" UTC.

    Raises
    ------
    DataError
        A stamp that does not parse, or a missing stamp (with its row).
    """
    import pandas as pd

    numeric = pd.api.types.is_numeric_dtype(raw.dtype) and not pd.api.types.is_bool_dtype(raw.dtype)
    if time_format == "seconds" or (time_format == "detected" and numeric):
        seconds = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float, copy=True)
        bad = ~np.isfinite(seconds)
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            raise _bad_stamp(path, column, j, raw.iloc[j], "is not a number of seconds (data.time_format)")
        return ParsedTime(seconds - seconds[0], f"{seconds[0]:g} s", iso=False)
    pattern = "%" in time_format
    stamps, zone = _date_times(raw, time_format if pattern else "ISO8601", timezone)
    bad = stamps.isna().to_numpy()
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        reason = "is not an ISO 8601 date-time (e.g. 2024-03-01T12:00:00Z)"
        if pattern:
            reason = f"does not match data.time_format {time_format!r}"
        if _parses(raw.iloc[j], time_format if pattern else "ISO8601"):
            reason = f"does not exist or is ambiguous in {zone} (a daylight-saving change): export in UTC"
        raise _bad_stamp(path, column, j, raw.iloc[j], reason)
    # from the differences, not the integers: Arrow stamps arrive in s, ms, us or ns (the dtype's unit)
    seconds = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy(dtype=float, copy=True)
    return ParsedTime(seconds, stamps.iloc[0].isoformat(), iso=True, assumed_zone=zone)


def _parses(value: Any, form: str) -> bool:
    """Whether one stamp parses on its own (then only its zone can have made it invalid)."""
    import pandas as pd

    try:
        return pd.notna(pd.to_datetime(value, format=form))
    except (ValueError, TypeError, OverflowError):
        return False


def _date_times(raw: Any, form: str, timezone: str) -> tuple[Any, str]:
    """The stamps in UTC (NaT where one does not parse), and the zone taken for stamps without one ("" none).

    Stamps with a zone or offset are converted from it; stamps without one are
    taken in ``timezone`` (UTC when empty).
    """
    import warnings

    import pandas as pd

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pandas 2 warns of mixed offsets (pandas 3 raises): aware stamps
            local = pd.to_datetime(raw, format=form, errors="coerce")
    except (ValueError, TypeError):
        local = None
    naive = local is not None and local.dtype != object and local.dt.tz is None
    if not naive:
        return pd.to_datetime(raw, utc=True, format=form, errors="coerce"), ""
    zone = timezone or "UTC"
    try:
        placed = local.dt.tz_localize(zone, ambiguous="infer", nonexistent="NaT")
    except (ValueError, TypeError):  # a repeated hour the order cannot resolve
        placed = local.dt.tz_localize(zone, ambiguous="NaT", nonexistent="NaT")
    return placed.dt.tz_convert("UTC"), zone


@dataclass(frozen=True)
class Grid:
    """Where each row of the file falls on the sample grid.

    Attributes
    ----------
    index : ndarray of int
        Sample k of each kept row.
    rows : ndarray of int
        The kept rows (a duplicate row repeating the one before is dropped).
    samples : int
        Grid points from the first row to the last.
    moved : int
        Rows moved onto the grid (off by more than a millionth of a sample).
    largest_offset : float
        The largest distance moved [samples].
    duplicates : int
        Rows dropped as exact repeats of the row before on the same grid point.
    """

    index: np.ndarray
    rows: np.ndarray
    samples: int
    moved: int
    largest_offset: float
    duplicates: int

    @property
    def gaps(self) -> int:
        """Grid points no row falls on."""
        return self.samples - self.index.size


@dataclass(frozen=True)
class GridSpec:
    """The grid a file must be sampled on.

    Attributes
    ----------
    sample_time_s : float
        ``system.sample_time x data.time_unit_s`` [s].
    tolerance : float
        ``data.grid_tolerance`` [samples].
    path, column : str
        For messages.
    """

    sample_time_s: float
    tolerance: float
    path: str
    column: str


def _check_spacing(position: np.ndarray, spec: GridSpec) -> None:
    """Refuse stamps that go back, and a file whose typical spacing is not the sample time."""
    step = np.diff(position)
    back = np.flatnonzero(step < 0)
    if back.size:
        j = int(back[0]) + 1
        raise _bad_stamp(
            spec.path,
            spec.column,
            j,
            NO_VALUE,
            f"goes back in time by {-step[j - 1] * spec.sample_time_s:g} s from row {j}",
        )
    positive = step[step > 0]
    typical = float(np.median(positive)) if positive.size else 1.0
    if abs(typical - 1.0) > spec.tolerance:
        raise DataError(
            spec.path,
            f"column {spec.column!r} (data.time_column)",
            f"stamps are {typical * spec.sample_time_s:.4g} s apart (median), but the sample time is "
            f"{spec.sample_time_s:g} s (system.sample_time x data.time_unit_s); export the data at the sample time, or "
            "name the model's time unit (system.time_unit: min), or set data.time_unit_s to the seconds in one "
            "time unit of the model (60 for minutes)",
        )


def place_on_grid(seconds: np.ndarray, values: np.ndarray, spec: GridSpec) -> Grid:
    """Place each row on the sample grid.

    Parameters
    ----------
    seconds : ndarray, shape (rows,)
        Stamps in seconds since the first.
    values : ndarray, shape (rows, columns)
        The row's values (NaN missing): two rows on one grid point must be equal.
    spec : GridSpec

    Raises
    ------
    DataError
        A stamp goes back, lies farther than the tolerance off the grid, the
        spacing is not the sample time, or two different rows share a grid point.
    """
    position = np.asarray(seconds, dtype=float) / spec.sample_time_s
    _check_spacing(position, spec)
    fraction = position - np.rint(position)
    phase = float(np.median(fraction))
    index = np.rint(position - phase).astype(np.int64)
    index -= index[0] if index.size else 0
    offset = position - phase - np.rint(position - phase)
    far = np.flatnonzero(np.abs(offset) > spec.tolerance)
    if far.size:
        j = int(far[0])
        raise _bad_stamp(
            spec.path,
            spec.column,
            j,
            NO_VALUE,
            f"lies {offset[j]:+.2f} samples off the {spec.sample_time_s:g} s sample grid (data.grid_tolerance "
            f"{spec.tolerance:g}): the export is not evenly sampled",
        )
    keep = _drop_repeats(index, values, spec)
    moved = int(np.sum(np.abs(offset[keep]) > 1e-6))
    return Grid(
        index=index[keep],
        rows=np.flatnonzero(keep),
        samples=int(index[-1] - index[0] + 1) if index.size else 0,
        moved=moved,
        largest_offset=float(np.abs(offset).max()) if offset.size else 0.0,
        duplicates=int(index.size - keep.sum()),
    )


def _drop_repeats(index: np.ndarray, values: np.ndarray, spec: GridSpec) -> np.ndarray:
    """Rows to keep: a row on the grid point of the row before is dropped if it repeats it, else refused."""
    keep = np.ones(index.size, dtype=bool)
    for j in np.flatnonzero(np.diff(index) == 0) + 1:
        same = np.array_equal(values[j], values[j - 1], equal_nan=True)
        if not same:
            raise _bad_stamp(
                spec.path,
                spec.column,
                int(j),
                NO_VALUE,
                f"falls on the same sample as row {j} with other values (a duplicated stamp; local time across a "
                "daylight-saving change? export in UTC)",
            )
        keep[j] = False
    return keep
