"""How a declared parameter's value is checked, per type: numbers, names, per-channel lists, matrices, stretches.

:class:`~pmr_ros.config.schema.Parameter` takes these checks; each refuses a
bad value with one :class:`~pmr_ros.config.errors.ConfigError` line naming the
parameter (and the element, ``G21`` or ``D21``) and the value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.sim.model import element_name
from .column_lists import column_list
from .errors import ConfigError

__all__ = ["Shape", "ValueChecks", "element_label"]


@dataclass(frozen=True)
class Shape:
    """Sizes a per-channel or matrix parameter is checked against.

    Attributes
    ----------
    n_outputs, n_inputs : int
        Channels of the system.
    n_disturbances : int
        Measured disturbances (DVs): the columns of a parameter declared ``per: disturbances``.
    """

    n_outputs: int
    n_inputs: int
    n_disturbances: int = 0

    def columns(self, per: str) -> int:
        """The columns of a matrix declared ``per`` (``disturbance_elements``: the DVs), else the inputs."""
        return self.n_disturbances if per.startswith("disturbance") else self.n_inputs

    def channels(self, per: str) -> int:
        """The channels of a per-channel list declared ``per`` (outputs, inputs or disturbances)."""
        return self.n_outputs if per == "outputs" else self.columns(per)


class ValueChecks:
    """The per-type checks of a declared parameter (the fields are :class:`~pmr_ros.config.schema.Parameter`'s)."""

    name: str
    kind: str
    default: Any
    minimum: float | None
    maximum: float | None
    min_exclusive: bool
    max_exclusive: bool
    choices: tuple[str, ...]
    per: str
    scalar: bool
    integer: bool
    infinite: bool
    blank: bool

    def range_text(self) -> str:
        """The allowed values in words (``number > 0``, ``one of classic, parametric``)."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        parts = []
        if self.minimum is not None:
            parts.append(f"{'>' if self.min_exclusive else '>='} {self.minimum:g}")
        if self.maximum is not None:
            parts.append(f"{'<' if self.max_exclusive else '<='} {self.maximum:g}")
        return " and ".join(parts)

    def _error(self, source: str, value: Any, reason: str, field: str | None = None) -> ConfigError:
        return ConfigError(source, field or self.name, value, reason)

    def _number(self, value: Any, source: str, field: str, *, integer: bool) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self._error(source, value, "must be a number", field)
        if self.infinite and isinstance(value, float) and math.isinf(value):
            return value
        if not math.isfinite(value if isinstance(value, float) else (0.0 if abs(value) < 2**1023 else math.inf)):
            raise self._error(source, value, "must be finite", field)
        if integer and float(value) != int(value):
            raise self._error(source, value, "must be a whole number", field)
        low, high = self.minimum, self.maximum
        if low is not None and (value < low or (self.min_exclusive and value == low)):
            raise self._error(source, value, f"must be {self.range_text()}", field)
        if high is not None and (value > high or (self.max_exclusive and value == high)):
            raise self._error(source, value, f"must be {self.range_text()}", field)
        return int(value) if integer else float(value)

    def _check_int(self, value: Any, source: str, shape: Shape | None) -> int:
        return int(self._number(value, source, self.name, integer=True))

    def _check_float(self, value: Any, source: str, shape: Shape | None) -> float:
        return self._number(value, source, self.name, integer=False)

    def _check_bool(self, value: Any, source: str, shape: Shape | None) -> bool:
        if not isinstance(value, bool):
            raise self._error(source, value, "must be true or false")
        return value

    def _check_string(self, value: Any, source: str, shape: Shape | None) -> str:
        if not isinstance(value, str):
            raise self._error(source, value, "must be a string")
        if not value.isprintable():  # a newline or CR would break the one-line files and headers it names
            raise self._error(source, value, "must be one line of printable text (no newline, CR, tab or control code)")
        if self.choices and value not in self.choices:
            raise self._error(source, value, f"must be {self.range_text()}")
        return value

    def _check_names(self, value: Any, source: str, shape: Shape | None) -> tuple[str, ...]:
        if value == [] and self.default == []:  # an optional list of names (no DVs)
            return ()
        if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
            raise self._error(source, value, "must be a non-empty list of names")
        if not all(v.isprintable() for v in value):
            raise self._error(source, value, "names must be one line of printable text (no newline, CR or tab)")
        if len(set(value)) != len(value):
            raise self._error(source, value, "names must be unique")
        return tuple(value)

    def _check_columns(self, value: Any, source: str, shape: Shape | None) -> tuple[str, ...]:
        """One column name per channel of ``per`` (:func:`~pmr_ros.config.column_lists.column_list`); () for []."""
        if shape is None:
            raise ValueError(f"{self.name}: a per-channel parameter needs the system's shape")
        return column_list(self, value, source, shape)

    def _check_values(self, value: Any, source: str, shape: Shape | None) -> tuple[float | str, ...]:
        """A list of numbers and strings (may be empty); numbers as floats."""
        if not isinstance(value, list):
            raise self._error(source, value, "must be a list of numbers and strings, e.g. [-9999, Bad, '']")
        out: list[float | str] = []
        for j, item in enumerate(value):
            if isinstance(item, str):
                out.append(item)
            else:
                out.append(self._number(item, source, f"{self.name}[{j}]", integer=False))
        return tuple(out)

    def _check_stretches(self, value: Any, source: str, shape: Shape | None) -> tuple[tuple[int, int, int | str], ...]:
        """``[start, length, channel]`` triples (channel a 0-based index or a name); numbers whole, >= 0.

        Nested (``[[start, length, channel], ...]``, a params file read by pmr-ros) or flat
        (``[start, length, index, start, length, index, ...]``: an integer array, as a ROS
        parameter holds it); both give the same triples.
        """
        if not isinstance(value, list):
            raise self._error(source, value, "must be a list of [start, length, MV index or name]")
        items = value
        if value and not any(isinstance(item, list) for item in value):  # the flat spelling of the nodes
            if len(value) % 3:
                raise self._error(
                    source, value, f"a flat list holds start, length, MV index per stretch: {len(value)} numbers"
                )
            items = [value[j : j + 3] for j in range(0, len(value), 3)]
        out: list[tuple[int, int, int | str]] = []
        for j, item in enumerate(items):
            field = f"{self.name}[{j}]"
            if not isinstance(item, list) or len(item) != 3:
                raise self._error(source, item, "must be [start, length, MV index or name]", field)
            start, length, channel = item
            numbers = [start, length] + ([] if isinstance(channel, str) else [channel])
            if any(isinstance(n, bool) or not isinstance(n, int) or n < 0 for n in numbers):
                raise self._error(source, item, "start, length and an MV index must be whole numbers >= 0", field)
            if length < 1:
                raise self._error(source, item, "the length must be at least 1 sample", field)
            out.append((int(start), int(length), channel))
        return tuple(out)

    def _check_channels(self, value: Any, source: str, shape: Shape | None) -> np.ndarray:
        if shape is None:
            raise ValueError(f"{self.name}: a per-channel parameter needs the system's shape")
        length = shape.channels(self.per)
        if not isinstance(value, list):
            return np.full(length, self._number(value, source, self.name, integer=False))
        if len(value) != length:
            raise self._error(source, value, f"needs {length} entries (one per {self.per[:-1]}), got {len(value)}")
        items = [self._number(v, source, f"{self.name}[{j}]", integer=False) for j, v in enumerate(value)]
        return np.array(items, dtype=float)

    def _check_types(self, value: Any, source: str, shape: Shape | None) -> np.ndarray:
        if shape is None:
            raise ValueError(f"{self.name}: a per-element parameter needs the system's shape")
        if self.per in ("outputs", "inputs", "disturbances"):  # one string per channel
            rows, cols, what = 1, shape.channels(self.per), f"one per {self.per[:-1]}"
        else:
            rows, cols = shape.n_outputs, shape.columns(self.per)
            what = f"{rows}x{cols}, row by row"
        n = rows * cols
        items = [value] * n if isinstance(value, str) else value
        if not isinstance(items, list) or len(items) != n:
            count = f", got {len(items)}" if isinstance(items, list) else ""
            raise self._error(source, value, f"needs {n} entries ({what}) or one for all{count}")
        for j, item in enumerate(items):
            if item not in self.choices:
                per_channel = self.per in ("outputs", "inputs", "disturbances")
                label = "" if per_channel else f" ({element_label(j, shape, self.per)})"
                raise self._error(source, item, f"must be one of {', '.join(self.choices)}", f"{self.name}[{j}]{label}")
        out = np.array(items, dtype=object)
        return out if self.per in ("outputs", "inputs", "disturbances") else out.reshape(rows, cols)

    def _check_labels(self, value: Any, source: str, shape: Shape | None) -> tuple[str, ...]:
        """One text per channel of ``per`` (a unit: repeats allowed), one for all, or [] for none."""
        if shape is None:
            raise ValueError(f"{self.name}: a per-channel parameter needs the system's shape")
        length = shape.channels(self.per)
        items = [value] * length if isinstance(value, str) else value
        if items == []:
            return ()
        if not isinstance(items, list) or len(items) != length:
            raise self._error(source, value, f"needs {length} entries (one per {self.per[:-1]}), one for all, or []")
        for j, item in enumerate(items):
            if not isinstance(item, str) or not item.isprintable():
                raise self._error(source, item, "must be one line of text (a unit: degC, %, t/h)", f"{self.name}[{j}]")
        return tuple(items)

    def _check_strings(self, value: Any, source: str, shape: Shape | None) -> np.ndarray:
        """One string per element (row-major), or one string for every element."""
        if shape is None:
            raise ValueError(f"{self.name}: a per-element parameter needs the system's shape")
        columns = shape.columns(self.per)
        n = shape.n_outputs * columns
        items = [value] * n if isinstance(value, str) else value
        if not isinstance(items, list) or len(items) != n:
            count = f", got {len(items)}" if isinstance(items, list) else ""
            raise self._error(source, value, f"needs {n} strings ({shape.n_outputs}x{columns}, row by row){count}")
        for j, item in enumerate(items):
            if not isinstance(item, str):
                field = f"{self.name}[{j}] ({element_label(j, shape, self.per)})"
                raise self._error(source, item, "must be a string (quote the coefficients: '16.7, 1')", field)
        return np.array(items, dtype=object).reshape(shape.n_outputs, columns)

    def _check_matrix(self, value: Any, source: str, shape: Shape | None) -> np.ndarray:
        if shape is None:
            raise ValueError(f"{self.name}: a matrix parameter needs the system's shape")
        n_out, n_in = shape.n_outputs, shape.columns(self.per)
        if self.scalar and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value] * (n_out * n_in)
        if not isinstance(value, list):
            raise self._error(source, value, f"must be a list of {n_out}x{n_in} = {n_out * n_in} numbers, row by row")
        if value and all(isinstance(row, list) for row in value):
            lengths = [len(row) for row in value]
            if len(value) != n_out or any(n != n_in for n in lengths):
                raise self._error(source, value, f"must be {n_out} rows of {n_in} (got rows of {lengths})")
            value = [x for row in value for x in row]
        if len(value) != n_out * n_in:
            raise self._error(
                source, value, f"needs {n_out * n_in} entries ({n_out}x{n_in}, row by row), got {len(value)}"
            )
        fast = self._numbers_at_once(value)
        if fast is not None:
            return fast.reshape(n_out, n_in)
        items = [
            self._number(v, source, f"{self.name}[{j}] ({element_label(j, shape, self.per)})", integer=self.integer)
            for j, v in enumerate(value)
        ]
        return np.array(items, dtype=float).reshape(n_out, n_in)

    def _numbers_at_once(self, values: list) -> np.ndarray | None:
        """``values`` as an array when every one passes (checked vectorised); None to check one by one.

        The one-by-one check gives the message naming the first bad element;
        this path only saves the per-element work of a large matrix that is fine.
        """
        if not set(map(type, values)) <= {int, float}:  # bool, str, None: one by one
            return None
        try:
            array = np.array(values, dtype=float)
        except OverflowError:
            return None
        ok = np.isfinite(array)
        if self.integer:
            ok &= array == np.round(array)
        low, high = self.minimum, self.maximum
        if low is not None:
            ok &= array > low if self.min_exclusive else array >= low
        if high is not None:
            ok &= array < high if self.max_exclusive else array <= high
        return array if bool(np.all(ok)) else None


def element_label(flat_index: int, shape: Shape, per: str = "") -> str:
    """``G21`` for the row-major index of an element (``G2_10`` style beyond 9 channels).

    ``per="disturbance_elements"``: an element of the DV model, ``D21`` (``D10_3`` beyond nine).
    """
    columns = shape.columns(per)
    i, k = divmod(flat_index, max(columns, 1))
    name = element_name(i, k, max(shape.n_outputs, columns))
    return "D" + name[1:] if per.startswith("disturbance") else name
