"""Column names a file holds more than once: refused with the name and the positions, never one picked silently."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path

from .bad_data import DataError

__all__ = ["check_unique_columns"]


def check_unique_columns(names: Sequence[str], path: str | Path) -> None:
    """Refuse a header that names one column twice (Parquet allows it; which one is meant cannot be known).

    Parameters
    ----------
    names : sequence of str
        The file's column names in order.
    path : str or Path
        For the message.

    Raises
    ------
    DataError
        Naming the first duplicated column and its (1-based) positions.

    Examples
    --------
    >>> check_unique_columns(["t", "y1", "u1"], "a.parquet")
    >>> check_unique_columns(["t", "y1", "y1"], "a.parquet")
    Traceback (most recent call last):
    ...
    pmr_ros.data.bad_data.DataError: a.parquet: column 'y1': appears 2 times in the file (columns 2, 3): rename ...
    """
    twice = [name for name, count in Counter(names).items() if count > 1]
    if twice:
        name = twice[0]
        positions = [str(j + 1) for j, other in enumerate(names) if other == name]
        raise DataError(
            path,
            f"column {name!r}",
            f"appears {len(positions)} times in the file (columns {', '.join(positions)}): rename the copies",
        )
