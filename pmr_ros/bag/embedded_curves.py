"""The curve files a run's configuration names (``model_file``), carried inside its bag so the bag stands alone.

A recorded configuration names its step-response curves by the absolute path
of ``system.model_file`` (and ``plant.model_file``) on the machine that ran
it.  The bag keeps each file's text beside the parameters
(:class:`~pmr_ros.bag.storage.RunConfig`), and the offline diagnosis builds the
model from that text, so the bag diagnoses the same on another machine, or
after the file has moved, changed or gone.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["MODEL_FILE_FIELDS", "embedded_curve_sets", "model_file_texts"]

MODEL_FILE_FIELDS = ("system.model_file", "plant.model_file")
"""The parameters that name a curve file."""


def _named(params: Mapping[str, Any], name: str) -> str:
    block, key = name.split(".", 1)
    values = params.get(block)
    return str(values.get(key) or "") if isinstance(values, Mapping) else ""


def model_file_texts(params: Mapping[str, Any]) -> dict[str, str]:
    """The text of every curve file ``params`` names that reads now, by its parameter's dotted name.

    Parameters
    ----------
    params : mapping
        A nested parameter tree (``system``, ``plant``, ...); ``model_file`` is
        absolute there (the configuration reader makes it so).

    Returns
    -------
    dict
        ``{"system.model_file": text, ...}``; a file that does not read now is
        left out (the run itself would have refused it).
    """
    out = {}
    for name in MODEL_FILE_FIELDS:
        path = _named(params, name)
        if not path:
            continue
        try:
            out[name] = Path(path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            continue
    return out


def embedded_curve_sets(params: Mapping[str, Any], texts: Mapping[str, str]) -> dict[str, Any]:
    """The curves of ``texts`` (by dotted name), read as the files ``params`` names (their suffix: .mdl or .csv).

    Raises
    ------
    ModelFileError
        An embedded text that does not read (one line naming the file).
    """
    from ..models.curve_files import read_curves

    return {name: read_curves(_named(params, name), text=text) for name, text in texts.items() if _named(params, name)}
