"""From a historian export to clean plant data: read, place on the grid, clean, count every step."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..config import PmrConfig
from ..config.data import DataSettings, configured_disturbances, output_modes
from ..core.sim.memory import available_bytes, format_bytes
from .bad_data import DataError
from .clean import CleaningStep, PlantData, at_limit, frozen
from .columns import ColumnMap, column_map
from .far_stamps import far_stamps, grid_bytes
from .modes import controller_modes, mode_steps
from .outliers import gross_outliers, outlier_step
from .read import Progress, RawTable, read_table
from .timebase import Grid, GridSpec, ParsedTime, parse_time, place_on_grid

__all__ = ["load_plant_data"]


def load_plant_data(path: str | Path, config: PmrConfig, *, progress: Progress | None = None) -> PlantData:
    """Read and clean a CSV or Parquet export of r, u, y (and DVs, modes) for the model of ``config``.

    Parameters
    ----------
    path : str or Path
    config : PmrConfig
        The model (channel names, sample time), the DVs (its disturbance model
        or ``system.disturbance_names``), ``mpc.output_mode`` and the ``data`` block.
    progress : callable, optional
        Called while reading (see :data:`pmr_ros.data.read.Progress`).

    Raises
    ------
    DataError
        One line naming the file, the column (and row) and the value.
    """
    settings = config.data
    columns = column_map(
        settings, config.model, output_modes=output_modes(config.parameters, len(config.model.output_names))
    )
    _check_disturbances(columns, configured_disturbances(config), str(path))
    raw = read_table(path, columns, settings.bad_values, progress=progress)
    spec = GridSpec(config.model.sample_time * settings.time_unit_s, settings.grid_tolerance, str(path), columns.time)
    raw, parsed, far = _without_far_rows(raw, spec, settings)
    table = np.column_stack([raw.values[c] for c in columns.value_columns])
    grid = place_on_grid(parsed.seconds, table, spec)
    _check_grid_memory(grid, table.shape[1], spec)
    on_grid = np.full((grid.samples, table.shape[1]), np.nan)
    on_grid[grid.index] = table[grid.rows]
    outliers = gross_outliers(on_grid, settings.outlier_mad)
    on_grid[outliers] = np.nan
    signals = _split(on_grid, columns)
    limited = np.column_stack([at_limit(u) for u in signals["u"].T])
    modes = controller_modes(raw, grid, settings, columns=columns, n_inputs=signals["u"].shape[1])
    stuck = _frozen(signals, limited | modes.manual, settings.frozen_samples)
    missing = ~np.all(np.isfinite(on_grid), axis=1)
    excluded = {
        "missing": missing,
        "frozen": stuck.any(axis=1),
        "controller off": modes.all_off,
        "mode unknown": modes.unknown & ~missing,
    }
    steps = _steps(raw, grid, columns, stuck=stuck, limited=limited)
    steps = _with_outlier_step(steps, outlier_step(outliers, columns.value_columns, settings.outlier_mad))
    head = (steps[0], *_zone_step(parsed, raw.rows), far)
    steps = (*head, *steps[1:-1], *mode_steps(modes, columns.signals["u"]), steps[-1])
    data = PlantData(
        str(path),
        parsed.start,
        spec.sample_time_s,
        signals,
        columns.signals,
        excluded,
        limited,
        steps,
        modes.manual,
        outliers=_split(outliers, columns),
    )
    return _with_usable_step(data)


def _check_disturbances(columns: ColumnMap, names: tuple[str, ...], path: str) -> None:
    """Refuse data without the DVs the system declares (their effect would be unexplained), naming them."""
    if names and "dv" not in columns.signals:
        raise DataError(
            path,
            "data.disturbance_columns",
            f"is empty, but system.disturbance_names declares {len(names)} measured disturbance(s) "
            f"({', '.join(names)}): name their columns in that order",
        )


def _without_far_rows(
    raw: RawTable, spec: GridSpec, settings: DataSettings
) -> tuple[RawTable, ParsedTime, CleaningStep]:
    """The table without rows whose stamp lies far outside the rest (:mod:`.far_stamps`), its times, the step."""
    when = {"path": spec.path, "column": spec.column, "timezone": settings.timezone}
    parsed = parse_time(raw.time, settings.time_format, **when)
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
        parsed = parse_time(raw.time, settings.time_format, **when)
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


def _split(on_grid: np.ndarray, columns: ColumnMap) -> dict[str, np.ndarray]:
    """The grid's columns per signal; a CV without a setpoint column gets r = 0 throughout (constant)."""
    out, first = {}, 0
    for signal, names in columns.signals.items():
        parts = []
        for name in names:
            # zeros of the grid's dtype: a bool grid (the outlier mask) stays bool
            parts.append(on_grid[:, first] if name else np.zeros(on_grid.shape[0], dtype=on_grid.dtype))
            first += bool(name)
        out[signal] = np.column_stack(parts) if parts else np.empty((on_grid.shape[0], 0), dtype=on_grid.dtype)
    return out


def _frozen(signals: dict[str, np.ndarray], kept: np.ndarray, limit: int) -> np.ndarray:
    """Frozen cells of the outputs, inputs and DVs, shape (samples, n_out + n_in + n_dv).

    An input at a limit or held by the operator (``kept``) is not frozen.
    """
    y = [frozen(column, limit) for column in signals["y"].T]
    u = [frozen(column, limit, keep=kept[:, k]) for k, column in enumerate(signals["u"].T)]
    dv = [frozen(column, limit) for column in signals.get("dv", np.empty((len(kept), 0))).T]
    return np.column_stack([*y, *u, *dv])


def _per_column(counts: dict[str, int]) -> str:
    return ", ".join(f"{column} {n}" for column, n in counts.items() if n)


def _zone_step(parsed: ParsedTime, rows: int) -> tuple[CleaningStep, ...]:
    """The assumption made of stamps without a zone, as a step of the summary (none when they had one)."""
    if not parsed.assumed_zone:
        return ()
    if parsed.assumed_zone == "UTC":
        return (CleaningStep("time stamps have no zone: taken as UTC", rows, "rows", "data.timezone names another"),)
    return (CleaningStep(f"time stamps have no zone: taken as {parsed.assumed_zone} (data.timezone)", rows, "rows"),)


def _columns_detail(in_file: int, used: int) -> str:
    """``10 columns: 8 used, 2 ignored`` (the file's columns and those the data block names)."""
    in_file = max(in_file, used)
    return f"{in_file} columns: {used} used, {in_file - used} ignored"


def _steps(
    raw: RawTable, grid: Grid, columns: ColumnMap, *, stuck: np.ndarray, limited: np.ndarray
) -> tuple[CleaningStep, ...]:
    watched = [*columns.signals["y"], *columns.signals["u"], *columns.signals.get("dv", ())]
    grid_detail = f"largest offset {grid.largest_offset:.3f} samples" if grid.moved else ""
    return (
        CleaningStep("rows read", raw.rows, "rows", _columns_detail(raw.file_columns, len(dict.fromkeys(columns.all)))),
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
