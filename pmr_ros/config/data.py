"""The ``data`` block: how a historian export maps onto r, u, y and how it is cleaned, as typed settings."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["DataSettings", "data_settings"]

DATA_BLOCK = "data"


@dataclass(frozen=True)
class DataSettings:
    """Settings of the ``data`` block (defaults, ranges and meanings: ``config/parameters.yaml``).

    Attributes
    ----------
    time_column : str
        Column of the time stamps.
    time_format : str
        ``iso``, ``seconds`` or ``detected``.
    time_unit_s : float
        Seconds in one time unit of the model [s].
    grid_tolerance : float
        Largest distance of a stamp from the sample grid that is moved onto it [samples].
    setpoint_columns, input_columns, output_columns, dither_columns : tuple of str
        Column per channel; empty: the default naming (no dither for ``dither_columns``).
    bad_values : tuple of float or str
        Cells equal to one of these are missing.
    outlier_mad : float
        A cell farther than this many robust steps from its tag's running median is missing; 0: no check.
    frozen_samples : int
        Longest run of one repeated value on a normally noisy tag [samples]; 0: no check.
    mode_column : str
        The controller's on/off column; empty: on throughout.
    mode_on_values : tuple of float or str
        Values of ``mode_column`` meaning on.
    """

    time_column: str
    time_format: str
    time_unit_s: float
    grid_tolerance: float
    setpoint_columns: tuple[str, ...]
    input_columns: tuple[str, ...]
    output_columns: tuple[str, ...]
    dither_columns: tuple[str, ...]
    bad_values: tuple[float | str, ...]
    outlier_mad: float
    frozen_samples: int
    mode_column: str
    mode_on_values: tuple[float | str, ...]


def data_settings(value: Callable[[str], Any], keys: list[str]) -> DataSettings:
    """The ``data`` block as :class:`DataSettings`.

    Parameters
    ----------
    value : callable
        The checked value of a dotted parameter name (the config reader's; it
        raises :class:`~pmr_ros.config.errors.ConfigError` naming a bad value).
    keys : list of str
        The declared keys of the block.
    """
    return DataSettings(**{key: value(f"{DATA_BLOCK}.{key}") for key in keys})
