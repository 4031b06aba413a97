"""From a historian export to clean plant data: read, place on the grid, clean, count every step."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..config import PmrConfig
from ..core.sim.memory import available_bytes, format_bytes
from .bad_data import DataError
from .clean import CleaningStep, PlantData, at_limit, frozen, mode_on, runs
from .columns import ColumnMap, column_map
from .far_stamps import far_stamps, grid_bytes
from .outliers import gross_outliers, outlier_step
from .read import Progress, RawTable, read_table
from .timebase import Grid, GridSpec, ParsedTime, parse_time, place_on_grid

__all__ = ["load_plant_data"]


def load_plant_data(path: str | Path, config: PmrConfig, *, progress: Progress | None = None) -> PlantData:
    """Read and clean a CSV or Parquet export of r, u, y for the model of ``config``.

    Parameters
    ----------
    path : str or Path
    config : PmrConfig
        The model (channel names, sample time) and the ``data`` block.
    progress : callable, optional
        Called while reading (see :data:`pmr_ros.data.read.Progress`).

    Raises
    ------
    DataError
        One line naming the file, the column (and row) and the value.
    """
    settings = config.data
    columns = column_map(settings, config.model)
    raw = read_table(path, columns, settings.bad_values, progress=progress)
    spec = GridSpec(config.model.sample_time * settings.time_unit_s, settings.grid_tolerance, str(path), columns.time)
    raw, parsed, far = _without_far_rows(raw, spec, settings.time_format)
    table = np.column_stack([raw.values[c] for c in columns.value_columns])
    grid = place_on_grid(parsed.seconds, table, spec)
    _check_grid_memory(grid, table.shape[1], spec)
    on_grid = np.full((grid.samples, table.shape[1]), np.nan)
    on_grid[grid.index] = table[grid.rows]
    outliers = gross_outliers(on_grid, settings.outlier_mad)
    on_grid[outliers] = np.nan
    signals = _split(on_grid, columns)
    limited = np.column_stack([at_limit(u) for u in signals["u"].T])
    stuck = _frozen(signals, limited, settings.frozen_samples)
    on = _controller_on(raw, grid, settings.mode_on_values, path=str(path), column=columns.mode)
    missing = ~np.all(np.isfinite(on_grid), axis=1)
    excluded = {"missing": missing, "frozen": stuck.any(axis=1), "controller off": ~on}
    steps = _steps(raw, grid, columns, stuck=stuck, limited=limited, off=~on & ~missing)
    steps = _with_outlier_step(steps, outlier_step(outliers, columns.value_columns, settings.outlier_mad))
    steps = (steps[0], far, *steps[1:])
    data = PlantData(
        str(path),
        parsed.start,
        spec.sample_time_s,
        signals,
        columns.signals,
        excluded,
        limited,
        steps,
        outliers=_split(outliers, columns),
    )
    return _with_usable_step(data)


def _without_far_rows(raw: RawTable, spec: GridSpec, time_format: str) -> tuple[RawTable, ParsedTime, CleaningStep]:
    """The table without rows whose stamp lies far outside the rest (:mod:`.far_stamps`), its times, the step."""
    parsed = parse_time(raw.time, time_format, path=spec.path, column=spec.column)
    far = far_stamps(parsed.seconds / spec.sample_time_s)
    detail = ""
    if far.any():
        j = int(np.flatnonzero(far)[0])
        detail = f"first: row {j + 1}, {raw.time.iloc[j]!s}"
        keep = ~far
        raw = replace(
            raw,
            time=raw.time[keep].reset_index(drop=True),
            values={c: v[keep] for c, v in raw.values.items()},
            mode=None if raw.mode is None else raw.mode[keep],
        )
        parsed = parse_time(raw.time, time_format, path=spec.path, column=spec.column)
    step = CleaningStep("time stamps far outside the rest (a typo?) -> rows dropped", int(far.sum()), "rows", detail)
    return raw, parsed, step


def _check_grid_memory(grid: Grid, columns: int, spec: GridSpec) -> None:
    """Refuse a sample grid that the machine cannot hold, with the figures, before it is allocated."""
    needed, have = grid_bytes(grid.samples, columns), available_bytes()
    if have is not None and needed > have:
        days = grid.samples * spec.sample_time_s / 86400.0
        raise DataError(
            spec.path,
            f"column {spec.column!r} (data.time_column)",
            f"the stamps span {days:.4g} days, {grid.samples} samples of {spec.sample_time_s:g} s: the sample grid "
            f"needs about {format_bytes(needed)} of memory, {format_bytes(have)} available; export a shorter period",
        )


def _controller_on(raw: RawTable, grid: Grid, on_values, *, path: str, column: str) -> np.ndarray:
    """Samples with the controller on (all without a mode column); a mode column never on is refused, naming it."""
    on = np.ones(grid.samples, dtype=bool)
    if raw.mode is None:
        return on
    on[:] = False
    on[grid.index] = mode_on(raw.mode[grid.rows], on_values)
    if not on.any():
        seen = sorted({str(v) for v in raw.mode[grid.rows][:10000]})
        shown = ", ".join(repr(v) for v in seen[:5]) + (", ..." if len(seen) > 5 else "")
        raise DataError(
            path,
            f"column {column!r} (data.mode_column)",
            f"no row has one of data.mode_on_values ({', '.join(str(v) for v in on_values)}), so no sample is "
            f"usable; the column holds {shown}: add its on-value to data.mode_on_values",
        )
    return on


def _split(on_grid: np.ndarray, columns: ColumnMap) -> dict[str, np.ndarray]:
    out, first = {}, 0
    for signal, names in columns.signals.items():
        out[signal] = on_grid[:, first : first + len(names)]
        first += len(names)
    return out


def _frozen(signals: dict[str, np.ndarray], limited: np.ndarray, limit: int) -> np.ndarray:
    """Frozen cells of the outputs and inputs, shape (samples, n_out + n_in); an input at a limit is not frozen."""
    y = [frozen(column, limit) for column in signals["y"].T]
    u = [frozen(column, limit, keep=limited[:, k]) for k, column in enumerate(signals["u"].T)]
    return np.column_stack([*y, *u])


def _per_column(counts: dict[str, int]) -> str:
    return ", ".join(f"{column} {n}" for column, n in counts.items() if n)


def _steps(
    raw: RawTable, grid: Grid, columns: ColumnMap, *, stuck: np.ndarray, limited: np.ndarray, off: np.ndarray
) -> tuple[CleaningStep, ...]:
    watched = [*columns.signals["y"], *columns.signals["u"]]
    off_runs = runs(off)
    grid_detail = f"largest offset {grid.largest_offset:.3f} samples" if grid.moved else ""
    return (
        CleaningStep("rows read", raw.rows, "rows", f"{len(columns.all)} columns"),
        CleaningStep("time stamps moved onto the sample grid", grid.moved, "rows", grid_detail),
        CleaningStep("duplicated rows dropped", grid.duplicates, "rows"),
        CleaningStep("time gaps (grid points without a row) -> missing", grid.gaps, "samples"),
        CleaningStep(
            "bad values (sentinels, bad strings, empty cells) -> missing",
            sum(raw.bad.values()),
            "cells",
            _per_column(raw.bad),
        ),
        CleaningStep(
            "non-finite values -> missing", sum(raw.non_finite.values()), "cells", _per_column(raw.non_finite)
        ),
        CleaningStep(
            "frozen values (a noisy tag stuck) -> missing",
            int(stuck.sum()),
            "cells",
            _per_column({c: int(n) for c, n in zip(watched, stuck.sum(axis=0), strict=True)}),
        ),
        CleaningStep(
            "controller off -> excluded", int(off.sum()), "samples", f"{len(off_runs)} period(s)" if off_runs else ""
        ),
        CleaningStep(
            "MV at a limit (flagged, kept)",
            int(limited.sum()),
            "samples",
            _per_column({c: int(n) for c, n in zip(columns.signals["u"], limited.sum(axis=0), strict=True)}),
        ),
    )


def _with_outlier_step(steps: tuple[CleaningStep, ...], step: CleaningStep) -> tuple[CleaningStep, ...]:
    """``step`` placed after the non-finite values' step."""
    at = next((j + 1 for j, s in enumerate(steps) if s.name.startswith("non-finite")), len(steps))
    return (*steps[:at], step, *steps[at:])


def _with_usable_step(data: PlantData) -> PlantData:
    bounds = data.stretch_bounds()
    longest = max((b - a for a, b in bounds), default=0)
    step = CleaningStep(
        "usable samples", int(data.usable.sum()), "samples", f"{len(bounds)} unbroken stretch(es), longest {longest}"
    )
    return replace(data, steps=(*data.steps, step))
