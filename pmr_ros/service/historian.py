"""Diagnosing a historian export (CSV, Parquet): read and clean it, diagnose with data quality, close the loop.

The inputs' limits are judged only when the params file gives them
(``mpc.u_min`` and ``mpc.u_max``, in the data's units): the declared defaults
describe the simulation, not the plant.  pandas and pyarrow load with the
first file read (the ``data`` extra).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..config import PmrConfig
from ..config.controller_block import foreign_controller
from ..core.pmr.diagnosis import diagnose_stretches
from ..core.records import Record
from ..core.results import Diagnosis
from ..core.sim.augment import missing_disturbances
from ..data import DataError, PlantData, load_plant_data
from .closing import close_and_write
from .outlier_notes import outlier_cost, with_outlier_reasons
from .refusal import ServiceError

__all__ = ["LIMITS", "TableDiagnosis", "diagnose_table", "limits_given", "read_export"]

LIMITS = frozenset({"mpc.u_min", "mpc.u_max"})
"""The settings that must both be given for saturation to be judged on plant data."""


@dataclass(frozen=True)
class TableDiagnosis:
    """A historian export diagnosed.

    Attributes
    ----------
    diagnosis : Diagnosis
        With data-quality figures and, for a mismatch, the control impact.
    data : PlantData
        The cleaned data, with the cleaning's counts.
    stretches : list of Record
        The unbroken stretches diagnosed (deviations from their means).
    config : PmrConfig
        The configuration diagnosed with.
    notes : tuple of str
        One line each, for the console: why the control impact was not computed.
    """

    diagnosis: Diagnosis
    data: PlantData
    stretches: list[Record]
    config: PmrConfig
    notes: tuple[str, ...] = ()


def limits_given(config: PmrConfig) -> bool:
    """Whether the configuration's file set both input limits (else saturation is not judged)."""
    return LIMITS <= config.given


def read_export(
    path: str | Path, config: PmrConfig, *, progress: Callable[[int, int], None] | None = None
) -> PlantData:
    """Read and clean a historian export once (for a rolling-window diagnosis).

    Raises
    ------
    ServiceError
        Bad input (one line naming the file, column, row and value).
    """
    try:
        return load_plant_data(path, config, progress=progress)
    except DataError as exc:
        raise ServiceError(str(exc)) from None


def diagnose_table(
    path: str | Path,
    config: PmrConfig,
    *,
    progress: Callable[[int, int], None] | None = None,
    model_path: str | None = None,
) -> TableDiagnosis:
    """Read, clean and diagnose a historian export as one estimate over its unbroken stretches.

    Parameters
    ----------
    path : str or Path
        A CSV or Parquet file (columns: :mod:`pmr_ros.data.columns`).
    config : PmrConfig
        The controller's model, the PMR settings and the ``data`` block.
    progress : callable, optional
        ``progress(done, total)`` while the file is read.
    model_path : str, optional
        Write the corrected model there (``--write-model``).

    Raises
    ------
    ServiceError
        Bad input (one line naming the file, column, row and value); a
        configuration with measured disturbances whose data lack them; a
        ``model_path`` the diagnosis cannot give a model for.
    """
    config = foreign_controller(config)  # an export's controller is not this tool's unless the file names it
    data = read_export(path, config, progress=progress)
    stretches = data.stretches()
    problem = missing_disturbances(stretches, config.disturbance_model)
    if problem:
        raise ServiceError(f"{path}: {problem}")
    quality = config.quality if limits_given(config) else config.quality.without_limits()
    diagnosis = diagnose_stretches(
        stretches,
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        quality=quality,
        as_read=data.stretches(deviations=False),
        disturbance_model=config.disturbance_model,
    )
    diagnosis = with_outlier_reasons(diagnosis, outlier_cost(data, config, method=diagnosis.method))
    notes: list[str] = []
    if diagnosis.status == "ok":
        diagnosis = close_and_write(config, diagnosis, model_path=model_path, notes=notes)
    return TableDiagnosis(diagnosis, data, stretches, config, tuple(notes))
