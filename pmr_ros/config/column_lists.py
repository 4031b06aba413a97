"""The ``columns`` kind of the parameter declaration: a list of column names, one per channel.

``per`` counts the channels (``outputs``, ``inputs``; ``disturbances`` are
counted by the config reader against ``system.disturbance_names``); with
``scalar`` one name may stand for every channel, with ``blank`` an entry
``""`` or ``~`` leaves its channel without a column.
"""

from __future__ import annotations

from typing import Any, Protocol

from .errors import ConfigError

__all__ = ["ColumnsParameter", "column_counts", "column_list"]


class ColumnsParameter(Protocol):
    """What a ``columns`` check reads of its declared parameter (:class:`pmr_ros.config.schema.Parameter`)."""

    @property
    def name(self) -> str:
        """Dotted name."""

    @property
    def per(self) -> str:
        """``outputs``, ``inputs`` or ``disturbances``."""

    @property
    def scalar(self) -> bool:
        """One name may stand for every channel."""

    @property
    def blank(self) -> bool:
        """An entry may leave its channel without a column."""


class Channels(Protocol):
    """The system's channel counts (:class:`pmr_ros.config.schema.Shape`)."""

    @property
    def n_outputs(self) -> int:
        """CVs."""

    @property
    def n_inputs(self) -> int:
        """MVs."""


def column_counts(parameter: ColumnsParameter, shape: Channels) -> tuple[int, ...]:
    """The allowed numbers of columns (empty: not counted here).

    Examples
    --------
    >>> from pmr_ros.config.schema import Shape, parameter
    >>> column_counts(parameter("data.mode_columns"), Shape(3, 2))
    (1, 2)
    """
    if parameter.per not in ("outputs", "inputs"):
        return ()
    length = shape.n_outputs if parameter.per == "outputs" else shape.n_inputs
    return (1, length) if parameter.scalar and length != 1 else (length,)


def column_list(parameter: ColumnsParameter, value: Any, source: str, shape: Channels) -> tuple[str, ...]:
    """The checked column names of ``parameter``, ``""`` for a channel left without one; () for [].

    Raises
    ------
    ConfigError
        Not a list of names, the wrong number of them, a name twice.
    """
    if value == []:
        return ()
    lengths = column_counts(parameter, shape)
    wanted = " or ".join(str(n) for n in lengths) if lengths else "the"
    one = f"one per {parameter.per[:-1]}" + (" or one for all" if parameter.scalar else "")
    if parameter.scalar and isinstance(value, str):
        value = [value]
    if parameter.blank and isinstance(value, list):
        value = ["" if v is None else v for v in value]
    if not isinstance(value, list) or not all(isinstance(v, str) and (v or parameter.blank) for v in value):
        raise ConfigError(source, parameter.name, value, f"must be a list of {wanted} column names ({one})")
    if lengths and len(value) not in lengths:
        raise ConfigError(source, parameter.name, value, f"needs {wanted} column names ({one}), got {len(value)}")
    named = [v for v in value if v]
    if len(set(named)) != len(named):
        raise ConfigError(source, parameter.name, value, "column names must be unique")
    return tuple(value)
