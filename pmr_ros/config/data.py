"""The ``data`` block: how a historian export maps onto r, u, y and how it is cleaned, as typed settings."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from ..core.monitor.windows import UNITS
from .errors import ConfigError

__all__ = [
    "DataSettings",
    "check_data_settings",
    "configured_disturbances",
    "data_settings",
    "disturbance_names",
    "output_modes",
    "with_time_unit",
]

DATA_BLOCK = "data"
ZONE = "zone"
"""The ``mpc.output_mode`` of a CV held inside limits instead of at a setpoint."""


@dataclass(frozen=True)
class DataSettings:
    """Settings of the ``data`` block (defaults, ranges and meanings: ``config/parameters.yaml``).

    Attributes
    ----------
    time_column : str
        Column of the time stamps.
    time_format : str
        ``iso``, ``seconds``, ``detected`` or a strptime pattern (with a ``%``).
    timezone : str
        The IANA zone of stamps written without one; ``""``: UTC (said in the cleaning summary).
    time_unit_s : float
        Seconds in one time unit of the model [s].
    grid_tolerance : float
        Largest distance of a stamp from the sample grid that is moved onto it [samples].
    setpoint_columns, input_columns, output_columns, dither_columns : tuple of str
        Column per channel; empty: the default naming (no dither for ``dither_columns``).
        A ``""`` setpoint column: that CV has none (a zone CV; its r is constant).
    disturbance_columns : tuple of str
        Column per measured disturbance (DV), in the order of ``system.disturbance_names``; empty: none.
    bad_values : tuple of float or str
        Cells equal to one of these are missing.
    outlier_mad : float
        A cell farther than this many robust steps from its tag's running median is missing; 0: no check.
    frozen_samples : int
        Longest run of one repeated value on a normally noisy tag [samples]; 0: no check.
    mode_columns : tuple of str
        The controllers' on/off columns: one per MV, or one for all; empty: ``mode_column``.
    mode_column : str
        One on/off column for every MV (the older spelling); empty with ``mode_columns``: on throughout.
    mode_on_values : tuple of float or str
        Values of the mode columns meaning on.
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
    disturbance_columns: tuple[str, ...] = ()
    mode_columns: tuple[str, ...] = ()
    timezone: str = ""

    @property
    def modes(self) -> tuple[str, ...]:
        """The mode columns, whichever spelling named them: one per MV, one for all, or none."""
        return self.mode_columns or ((self.mode_column,) if self.mode_column else ())

    @property
    def modes_parameter(self) -> str:
        """The parameter that named the mode columns (for messages)."""
        return "data.mode_columns" if self.mode_columns else "data.mode_column"


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


def with_time_unit(
    settings: DataSettings, time_unit: str, *, given: bool, error: Callable[[str, Any, str], ConfigError]
) -> DataSettings:
    """``settings`` whose ``time_unit_s`` agrees with ``system.time_unit``: one source of the seconds per unit.

    ``system.time_unit`` (``s``, ``min``, ``h``) names the model's time unit and so
    sets ``data.time_unit_s`` (1, 60, 3600); a ``data.time_unit_s`` given as well
    must say the same.  Without a unit (``none``) ``data.time_unit_s`` stands as
    given (1 s by default).

    Parameters
    ----------
    settings : DataSettings
    time_unit : str
        ``system.time_unit``.
    given : bool
        Whether the file gave ``data.time_unit_s``.
    error : callable
        ``(name, value, reason)`` to the :class:`ConfigError` naming the file.

    Raises
    ------
    ConfigError
        A given ``data.time_unit_s`` that contradicts ``system.time_unit``.

    Examples
    --------
    >>> from pmr_ros.config import load_config
    >>> with_time_unit(load_config().data, "min", given=False, error=ConfigError).time_unit_s
    60.0
    """
    seconds = UNITS.get(time_unit)
    if seconds is None:
        return settings
    if not given:
        return replace(settings, time_unit_s=seconds)
    if not math.isclose(settings.time_unit_s, seconds, rel_tol=1e-9):
        raise error(
            "data.time_unit_s",
            settings.time_unit_s,
            f"contradicts system.time_unit {time_unit} ({seconds:g} s in one {time_unit}): leave data.time_unit_s out "
            "or give the same",
        )
    return settings


def disturbance_names(tree: Mapping[str, Any]) -> tuple[str, ...]:
    """The DV names of ``system.disturbance_names`` in an effective parameter tree; () when it declares none."""
    names = tree.get("system", {}).get("disturbance_names", [])
    if isinstance(names, str):
        names = [names]
    return tuple(str(n) for n in names) if isinstance(names, list | tuple) else ()


def configured_disturbances(config: Any) -> tuple[str, ...]:
    """The DV names of a :class:`~pmr_ros.config.PmrConfig`: its disturbance model's inputs, else the tree's.

    ``config.disturbance_model`` when set, else ``system.disturbance_names`` of ``config.parameters``.
    """
    model = getattr(config, "disturbance_model", None)
    return tuple(model.input_names) if model is not None else disturbance_names(config.parameters)


def output_modes(tree: Mapping[str, Any], n_outputs: int) -> tuple[str, ...]:
    """Each CV's ``mpc.output_mode`` (``setpoint`` or ``zone``): one for all or one per CV; all setpoint if unset.

    Examples
    --------
    >>> output_modes({"mpc": {"output_mode": ["setpoint", "zone"]}}, 2)
    ('setpoint', 'zone')
    """
    modes = tree.get("mpc", {}).get("output_mode", "setpoint")
    if isinstance(modes, str):
        return (modes,) * n_outputs
    if isinstance(modes, list | tuple) and len(modes) == n_outputs:
        return tuple(str(m) for m in modes)
    return ("setpoint",) * n_outputs


def check_data_settings(
    settings: DataSettings, tree: Mapping[str, Any], *, output_names: tuple[str, ...], source_of: Callable[[str], str]
) -> tuple[str, ...]:
    """Check the ``data`` block against the system and the MPC; its warnings.

    Parameters
    ----------
    settings : DataSettings
    tree : mapping
        The effective parameter tree (``system.disturbance_names``, ``mpc.output_mode``).
    output_names : tuple of str
        The CVs.
    source_of : callable
        The source (file) of a dotted parameter name, for the messages.

    Returns
    -------
    tuple of str
        One line per zone CV given a setpoint column (read, but a zone CV has no setpoint).

    Raises
    ------
    ConfigError
        Both mode spellings given; DV columns that do not match ``system.disturbance_names``; a
        ``time_format`` that is no keyword nor strptime pattern; an unknown ``timezone``.
    """
    _check_time_settings(settings, source_of)
    if settings.mode_columns and settings.mode_column:
        raise ConfigError(
            source_of("data.mode_columns"),
            "data.mode_columns",
            list(settings.mode_columns),
            f"give data.mode_columns or data.mode_column (its older spelling), not both "
            f"(data.mode_column = {settings.mode_column!r})",
        )
    dvs = disturbance_names(tree)
    if settings.disturbance_columns and len(settings.disturbance_columns) != len(dvs):
        declared = f"{len(dvs)} DV(s) ({', '.join(dvs)})" if dvs else "no DV"
        raise ConfigError(
            source_of("data.disturbance_columns"),
            "data.disturbance_columns",
            list(settings.disturbance_columns),
            f"needs one column per DV of system.disturbance_names, which declares {declared}; "
            f"got {len(settings.disturbance_columns)}",
        )
    modes = output_modes(tree, len(output_names))
    return tuple(
        f"{source_of('data.setpoint_columns')}: data.setpoint_columns[{i}] = {column!r}: {output_names[i]} is a "
        f'zone CV (mpc.output_mode), which has no setpoint; the column is read as its r (write "" for none)'
        for i, column in enumerate(settings.setpoint_columns)
        if column and modes[i] == ZONE
    )


TIME_FORMATS = ("detected", "iso", "seconds")
"""The ``data.time_format`` keywords; anything else must be a strptime pattern."""


def _check_time_settings(settings: DataSettings, source_of: Callable[[str], str]) -> None:
    """``data.time_format`` a keyword or a pattern with a ``%`` directive; ``data.timezone`` a zone Python knows."""
    form = settings.time_format
    if form not in TIME_FORMATS and "%" not in form:
        raise ConfigError(
            source_of("data.time_format"),
            "data.time_format",
            form,
            f"must be one of {', '.join(TIME_FORMATS)} or a strptime pattern such as '%d-%b-%y %H:%M:%S'",
        )
    if settings.timezone:
        from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

        try:
            ZoneInfo(settings.timezone)
        except (ZoneInfoNotFoundError, ValueError):
            raise ConfigError(
                source_of("data.timezone"),
                "data.timezone",
                settings.timezone,
                "is not a time zone name (an IANA name such as Europe/Berlin, America/Chicago or UTC)",
            ) from None
