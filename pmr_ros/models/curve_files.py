"""A curve file read by its suffix: a DMCplus ``.mdl`` or the documented CSV (nothing of the configuration needed)."""

from __future__ import annotations

from pathlib import Path

from .csv_curves import read_csv_curves
from .curve_set import CurveSet, ModelFileError
from .mdl import read_mdl

__all__ = ["read_curves"]


def read_curves(path: str | Path, *, text: str | None = None) -> CurveSet:
    """The curves of a model file by its suffix: ``.mdl`` (DMCplus) or ``.csv`` (``text``: its contents, not read).

    Raises
    ------
    ModelFileError
        Another suffix, or a file that does not read (one line).
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".mdl":
        return read_mdl(path, text=text)
    if suffix == ".csv":
        return read_csv_curves(path, text=text)
    raise ModelFileError(f"{path}: unknown model file type {suffix or '(none)'!r}: use a DMCplus .mdl or a .csv")
