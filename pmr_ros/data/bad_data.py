"""The one error type of reading plant data: a one-line message naming the file, the place and the value."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["NO_VALUE", "DataError"]

NO_VALUE = object()
"""Marks a :class:`DataError` without an offending value."""


class DataError(ValueError):
    """Plant data that cannot be read or trusted; the message is one line.

    Parameters
    ----------
    path : str or Path
        The file.
    where : str
        The column and, where it applies, the row (``column 'y_x_D', row 1235``).
    reason : str
        What is wrong, in words the user can act on.
    value : object, optional
        The offending value (shown with ``repr``).
    """

    def __init__(self, path: str | Path, where: str, reason: str, value: Any = NO_VALUE) -> None:
        self.path, self.where, self.reason, self.value = str(path), where, reason, value
        shown = "" if value is NO_VALUE else f" = {_shorten(repr(value))}"
        place = f"{where}{shown}: " if where else ""
        super().__init__(f"{path}: {place}{reason}")


def _shorten(text: str, limit: int = 80) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
