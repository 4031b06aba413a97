"""Test helper: long closed-loop 1-minute records whose plant drifts or steps on known days, made fast in pieces.

Each day is one closed-loop run of one lockstep batch (:func:`run_lockstep`),
with that day's plant: all days advance together, so a year costs one day of
batched steps, not a year of single ones.  A
day's run starts at rest: its first ``settle`` samples are left out (NaN, so
the cleaning marks them missing) and every day is an unbroken stretch of its
own, as a historian export with a daily break would be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pmr_ros.config import PmrConfig
from pmr_ros.core.sim.batch import run_lockstep
from pmr_ros.core.sim.model import Mismatch
from pmr_ros.data import PlantData

DAY = 1440
"""1-minute samples per day."""

START = "2025-01-01T00:00:00+00:00"


@dataclass(frozen=True)
class Change:
    """One parameter of one element that moves: a ramp over ``days`` from ``day`` (0: a step on ``day``).

    Attributes
    ----------
    row, column : int
        The element (0-based).
    parameter : str
        ``gain`` [%] or ``delay`` [samples].
    day : float
        When it begins to move [days since the start].
    size : float
        How far it moves.
    days : float
        How long the ramp takes (0: a step).
    """

    row: int
    column: int
    parameter: str
    day: float
    size: float
    days: float = 0.0

    def value(self, day: int) -> float:
        """Its value over day ``day`` (a ramp taken at the day's middle; a step from its day on)."""
        if self.days == 0:
            return self.size if day >= self.day else 0.0
        return self.size * float(np.clip((day + 0.5 - self.day) / self.days, 0.0, 1.0))


def day_mismatch(changes: tuple[Change, ...], shape: tuple[int, int], day: int) -> Mismatch:
    """The plant's mismatch on day ``day``: every change's value then, nothing else."""
    mismatch = Mismatch.zero(*shape)
    for change in changes:
        if change.parameter == "gain":
            mismatch.gain_pct[change.row, change.column] += change.value(day)
        else:
            mismatch.delay_samples[change.row, change.column] += int(round(change.value(day)))
    return mismatch


def drifting_signals(
    config: PmrConfig, *, days: int, changes: tuple[Change, ...], settle: int = 60, seed: int = 0
) -> dict[str, np.ndarray]:
    """r, u, y (and the dither) of ``days`` days of 1-minute closed loop, the plant changing as ``changes`` say.

    The first ``settle`` samples of each day are NaN (left out).
    """
    shape = (config.model.n_outputs, config.model.n_inputs)
    plants = [config.model.with_mismatch(day_mismatch(changes, shape, day)) for day in range(days)]
    records = run_lockstep(_DayPlants(config, plants), [("full", seed + day) for day in range(days)], DAY).records
    out: dict[str, np.ndarray] = {}
    for day, record in enumerate(records):
        for name in ("r", "u", "y", "dither"):
            values = getattr(record, name)
            if values is not None:
                whole = out.setdefault(name, np.full((days * DAY, values.shape[1]), np.nan))
                whole[day * DAY + settle : (day + 1) * DAY] = values[settle:]
    return out


class _DayPlants:
    """``config`` whose ``plant()`` gives each day's plant in turn: one lockstep batch runs every day at once.

    :func:`run_lockstep` asks for each run's plant once, in run order (its runs are the days).
    """

    def __init__(self, config: PmrConfig, plants: list) -> None:
        self._config, self._plants = config, iter(plants)

    def __getattr__(self, name: str):
        return getattr(self._config, name)

    def plant(self, scenario: str | None = None):
        return next(self._plants)


def drifting_data(config: PmrConfig, **kwargs) -> PlantData:
    """:func:`drifting_signals` as plant data starting on :data:`START` (the settling samples missing)."""
    signals = drifting_signals(config, **kwargs)
    return PlantData.from_record(signals, source="drifting", sample_time_s=60.0, start=START)
