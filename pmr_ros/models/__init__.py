"""Model files: step-response curves in DMCplus .mdl and CSV layouts, and the model YAML that names them.

``curve_set`` the curves of a model file (:class:`CurveSet`), ``mdl`` the
DMCplus text layout, ``csv_curves`` the CSV layout, ``system_file`` the
model params file written from curves and read into elements of any type
(``pmr-ros model import`` / ``export``; docs/models.md).

The names below are imported when first used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_WHERE = {
    "CurveSet": "curve_set",
    "LoadedModel": "system_file",
    "MdlExtras": "mdl",
    "ModelFileError": "curve_set",
    "csv_text": "csv_curves",
    "curve_gains": "curve_set",
    "import_params_text": "system_file",
    "load_model": "system_file",
    "mdl_text": "mdl",
    "read_csv_curves": "csv_curves",
    "read_curves": "curve_files",
    "read_mdl": "mdl",
    "relative_model_file": "system_file",
    "to_curve_set": "system_file",
    "write_csv_curves": "csv_curves",
    "write_mdl": "mdl",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "CurveSet",
    "LoadedModel",
    "MdlExtras",
    "ModelFileError",
    "csv_text",
    "curve_gains",
    "import_params_text",
    "load_model",
    "mdl_text",
    "read_csv_curves",
    "read_curves",
    "read_mdl",
    "relative_model_file",
    "to_curve_set",
    "write_csv_curves",
    "write_mdl",
]

__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)

if TYPE_CHECKING:
    from .csv_curves import csv_text, read_csv_curves, write_csv_curves
    from .curve_files import read_curves
    from .curve_set import CurveSet, ModelFileError, curve_gains
    from .mdl import MdlExtras, mdl_text, read_mdl, write_mdl
    from .system_file import LoadedModel, import_params_text, load_model, relative_model_file, to_curve_set
