"""The one error type of configuration reading."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["ConfigError"]


class ConfigError(ValueError):
    """A configuration value is invalid; the one-line message names the file, the field and the value.

    Parameters
    ----------
    source : str or Path
        The file (or "parameters of node ...") the value came from.
    field : str
        Dotted parameter name (``mpc.prediction_horizon``), ``<file>`` for the file itself.
    value : object
        The offending value (shown with ``repr``); None when it is missing.
    reason : str
        What is wrong, in words the user can act on.
    """

    def __init__(self, source: str | Path, field: str, value: Any, reason: str) -> None:
        self.source, self.field, self.value, self.reason = str(source), field, value, reason
        shown = _shorten(repr(value))
        super().__init__(
            f"{source}: {field} = {shown}: {reason}" if value is not None else f"{source}: {field}: {reason}"
        )


def _shorten(text: str, limit: int = 120) -> str:
    """A long value (a whole matrix, a binary blob) cut to one readable line."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 5] + " ...]"
